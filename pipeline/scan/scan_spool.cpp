#include "pipeline/scan/scan_spool.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "core/errors.h"

namespace sylva {

namespace fs = std::filesystem;

static_assert(std::is_trivially_copyable_v<ScanPoint>, "the spool stores raw ScanPoint bytes");

namespace {

[[noreturn]] void fail(const std::string& what, const fs::path& dir, int err) {
    const std::string message =
        "scan point spool: " + what + " in '" + dir.string() + "': " + std::strerror(err);
    if (isResourceErrno(err)) throw ResourceError(err, dir.string(), message);
    throw std::runtime_error(message);
}

// An unnamed read-write file in `dir`.
int openUnnamed(const fs::path& dir) {
    int fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
    if (fd >= 0) return fd;
    if (errno != EOPNOTSUPP && errno != EISDIR && errno != EINVAL && errno != ENOENT) {
        fail("cannot create a temporary file", dir, errno);
    }
    // No O_TMPFILE here: a named file, unlinked at once.
    std::string name = (dir / ".scan-points.XXXXXX").string();
    fd = ::mkostemp(name.data(), O_CLOEXEC);
    if (fd < 0) fail("cannot create a temporary file", dir, errno);
    ::unlink(name.c_str());
    return fd;
}

}  // namespace

ScanPointSpool::ScanPointSpool(fs::path dir, size_t memoryPoints)
    : dir_(std::move(dir)), memoryPoints_(std::max<size_t>(1, memoryPoints)) {}

ScanPointSpool::~ScanPointSpool() {
    if (fd_ >= 0) ::close(fd_);
}

void ScanPointSpool::append(const ScanPoint* points, size_t count) {
    while (count > 0) {
        const size_t take = std::min(count, memoryPoints_ - memory_.size());
        memory_.insert(memory_.end(), points, points + take);
        points += take;
        count -= take;
        if (memory_.size() == memoryPoints_) spill();
    }
}

void ScanPointSpool::spill() {
    if (fd_ < 0) {
        std::error_code ec;
        fs::create_directories(dir_, ec);
        if (ec) fail("cannot create the directory", dir_, ec.value());
        fd_ = openUnnamed(dir_);
    }
    const char* p = reinterpret_cast<const char*>(memory_.data());
    size_t left = memory_.size() * sizeof(ScanPoint);
    while (left > 0) {
        const ssize_t w = ::write(fd_, p, left);
        if (w < 0) {
            if (errno == EINTR) continue;
            fail("cannot write", dir_, errno);
        }
        p += w;
        left -= static_cast<size_t>(w);
    }
    onDisk_ += memory_.size();
    memory_.clear();
}

void ScanPointSpool::forEachBlock(const Block& block) const {
    if (onDisk_ > 0) {
        std::vector<ScanPoint> buffer(std::min<uint64_t>(memoryPoints_, onDisk_));
        const uint64_t bytes = onDisk_ * sizeof(ScanPoint);
        uint64_t at = 0;
        while (at < bytes) {
            const size_t want = static_cast<size_t>(
                std::min<uint64_t>(bytes - at, buffer.size() * sizeof(ScanPoint)));
            char* p = reinterpret_cast<char*>(buffer.data());
            size_t got = 0;
            while (got < want) {
                const ssize_t r = ::pread(fd_, p + got, want - got, static_cast<off_t>(at + got));
                if (r < 0 && errno == EINTR) continue;
                if (r < 0) fail("cannot read back", dir_, errno);
                if (r == 0)
                    throw std::runtime_error("scan point spool: the file in '" + dir_.string() +
                                             "' is shorter than written");
                got += static_cast<size_t>(r);
            }
            block(buffer.data(), want / sizeof(ScanPoint));
            at += want;
        }
    }
    if (!memory_.empty()) block(memory_.data(), memory_.size());
}

}  // namespace sylva
