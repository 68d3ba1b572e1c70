#include "core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "core/errors.h"
#include "core/input_file.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

// A full disk, quota, file size limit or memory is a ResourceError (a build stops on it and a
// rerun resumes); any other failure a std::runtime_error.
[[noreturn]] void throwErrno(const std::string& what, const fs::path& path, int err) {
    const std::string message = what + " '" + path.string() + "': " + std::strerror(err);
    if (isResourceErrno(err)) throw ResourceError(err, path.string(), message);
    throw std::runtime_error(message);
}

void createParentDirs(const fs::path& path) {
    fs::path parent = path.parent_path();
    if (parent.empty()) return;
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throwErrno("cannot create directory", parent, ec.value());
}

// Writes all of `bytes`, retrying on EINTR and short writes. Returns 0 or an errno value.
int writeAll(int fd, std::string_view bytes) {
    const char* p = bytes.data();
    size_t left = bytes.size();
    while (left > 0) {
        ssize_t w = ::write(fd, p, left);
        if (w < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        p += w;
        left -= static_cast<size_t>(w);
    }
    return 0;
}

}  // namespace

fs::path uniqueTempPath(const fs::path& target, std::string_view suffix) {
    static std::atomic<uint64_t> counter{0};
    std::ostringstream name;
    // pid separates processes; thread hash + process-wide counter separate calls within one.
    name << target.filename().string() << ".tmp." << ::getpid() << '.'
         << (std::hash<std::thread::id>{}(std::this_thread::get_id()) & 0xffffff) << '.'
         << counter.fetch_add(1) << suffix;
    return target.parent_path() / name.str();
}

void commitTempFile(const fs::path& from, const fs::path& to) {
    std::error_code ec;
    fs::rename(from, to, ec);
    if (ec) {
        std::error_code ignored;
        fs::remove(from, ignored);
        throw std::runtime_error("cannot rename '" + from.string() + "' to '" + to.string() +
                                 "': " + ec.message());
    }
}

void writeFileAtomic(const fs::path& path, std::string_view bytes, bool fsyncData) {
    createParentDirs(path);
    fs::path tmp = uniqueTempPath(path);
    int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) throwErrno("cannot create temp file for", path, errno);
    int err = writeAll(fd, bytes);
    if (err == 0 && fsyncData && ::fsync(fd) != 0) err = errno;
    if (::close(fd) != 0 && err == 0) err = errno;
    if (err != 0) {
        ::unlink(tmp.c_str());
        throwErrno("cannot write", path, err);
    }
    commitTempFile(tmp, path);
}

AtomicFileWriter::AtomicFileWriter(fs::path path, size_t bufferBytes)
    : path_(std::move(path)), capacity_(std::max<size_t>(bufferBytes, 4096)) {
    createParentDirs(path_);
    tmp_ = uniqueTempPath(path_);
    fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd_ < 0) throwErrno("cannot create temp file for", path_, errno);
    buffer_.reserve(capacity_);
}

AtomicFileWriter::~AtomicFileWriter() {
    if (fd_ >= 0) {
        ::close(fd_);
        ::unlink(tmp_.c_str());
    }
}

void AtomicFileWriter::flush() {
    if (fd_ < 0) throw std::logic_error("AtomicFileWriter: write after commit");
    const int err = writeAll(fd_, buffer_);
    if (err != 0) throwErrno("cannot write", path_, err);  // (the destructor removes the temp)
    written_ += buffer_.size();
    buffer_.clear();
}

void AtomicFileWriter::write(std::string_view bytes) {
    if (buffer_.size() + bytes.size() > capacity_) {
        flush();
        if (bytes.size() >= capacity_) {  // large pieces go straight to the file
            const int err = writeAll(fd_, bytes);
            if (err != 0) throwErrno("cannot write", path_, err);
            written_ += bytes.size();
            return;
        }
    }
    buffer_.append(bytes);
}

void AtomicFileWriter::overwrite(uint64_t offset, std::string_view bytes) {
    if (offset + bytes.size() > bytesWritten()) {
        throw std::logic_error("AtomicFileWriter: overwrite past the end");
    }
    flush();
    const char* p = bytes.data();
    size_t left = bytes.size();
    while (left > 0) {
        const ssize_t w = ::pwrite(fd_, p, left, static_cast<off_t>(offset));
        if (w < 0) {
            if (errno == EINTR) continue;
            throwErrno("cannot write", path_, errno);
        }
        p += w;
        offset += static_cast<uint64_t>(w);
        left -= static_cast<size_t>(w);
    }
}

char* AtomicFileWriter::reserve(size_t n) {
    if (buffer_.size() + n > capacity_) flush();
    if (n > capacity_) {
        capacity_ = n;
        buffer_.reserve(capacity_);
    }
    const size_t at = buffer_.size();
    buffer_.resize(at + n);
    return buffer_.data() + at;
}

void AtomicFileWriter::commit() {
    flush();
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) {
        const int err = errno;
        ::unlink(tmp_.c_str());
        throwErrno("cannot write", path_, err);
    }
    commitTempFile(tmp_, path_);
}

AppendLog::AppendLog(const fs::path& path) : path_(path) {
    createParentDirs(path_);
    fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throwErrno("cannot open log", path_, errno);
}

AppendLog::~AppendLog() {
    if (fd_ >= 0) ::close(fd_);
}

void AppendLog::append(std::string line) {
    if (line.find('\n') != std::string::npos) {
        throw std::invalid_argument("AppendLog::append: line contains a newline");
    }
    line.push_back('\n');
    // The mutex keeps a (rare) short-write continuation contiguous with its first part.
    std::lock_guard<std::mutex> lock(mutex_);
    struct stat before {};
    const bool sized = ::fstat(fd_, &before) == 0;
    int err = writeAll(fd_, line);
    if (err != 0) {
        // A full disk can take part of the line: cut the file back so it still ends with a
        // complete record (shrinking needs no space; should it fail, the next run drops the
        // torn tail).
        if (sized) {
            [[maybe_unused]] int ignored = ::ftruncate(fd_, before.st_size);
        }
        throwErrno("cannot append to", path_, err);
    }
}

void AppendLog::sync() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (::fsync(fd_) != 0) throwErrno("cannot fsync", path_, errno);
}

std::vector<std::string> AppendLog::readCompleteLines(const fs::path& path) {
    std::vector<std::string> lines;
    std::error_code ec;
    if (!fs::exists(path, ec)) return lines;
    const std::string data = readInputFile(path, kMaxLogBytes, "log");

    size_t start = 0;
    for (size_t nl; (nl = data.find('\n', start)) != std::string::npos; start = nl + 1) {
        lines.emplace_back(data, start, nl - start);
    }
    if (start < data.size()) {
        // Torn last line from a killed run: drop it so the next append starts a fresh line.
        if (::truncate(path.c_str(), static_cast<off_t>(start)) != 0) {
            throwErrno("cannot truncate partial line of", path, errno);
        }
    }
    return lines;
}

}  // namespace sylva
