#include "core/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "core/errors.h"

namespace sylva {

namespace {
constexpr size_t kChunk = size_t(1) << 16;

const char* kindOf(mode_t mode) {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISFIFO(mode)) return "a FIFO";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a file";
}
}  // namespace

std::string formatBytes(uint64_t bytes) {
    char buf[64];
    if (bytes < 1000) {
        std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(bytes));
        return buf;
    }
    const char* units[] = {"kB", "MB", "GB", "TB", "PB", "EB"};
    double x = static_cast<double>(bytes) / 1000;
    int u = 0;
    while (x >= 1000 && u < 5) x /= 1000, ++u;
    std::snprintf(buf, sizeof buf, "%.3g %s", x, units[u]);
    return buf;
}

InputFile::InputFile(const std::filesystem::path& path) : path_(path) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) {
        throw InputError(path.string() + ": cannot read (" + std::strerror(errno) + ")");
    }
    struct stat st {};
    if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
        const std::string kind = kindOf(st.st_mode);
        ::close(fd_);
        fd_ = -1;
        throw InputError(path.string() + ": not a regular file (" + kind + ")");
    }
    size_ = static_cast<uint64_t>(st.st_size);
}

InputFile::~InputFile() {
    if (fd_ >= 0) ::close(fd_);
}

bool InputFile::fill() {
    if (pos_ > 0) buffer_.erase(0, pos_), pos_ = 0;
    const size_t had = buffer_.size();
    buffer_.resize(had + kChunk);
    ssize_t n;
    do n = ::read(fd_, buffer_.data() + had, kChunk);
    while (n < 0 && errno == EINTR);
    if (n < 0) {
        const int err = errno;
        buffer_.resize(had);
        throw InputError(path_.string() + ": cannot read (" + std::strerror(err) + ")");
    }
    buffer_.resize(had + static_cast<size_t>(n));
    return n > 0;
}

std::string InputFile::readAll(uint64_t maxBytes, const std::string& what) {
    auto tooLarge = [&](uint64_t bytes) {
        return InputError(path_.string() + ": " + formatBytes(bytes) + ", more than the " +
                          formatBytes(maxBytes) + " " + what + " may hold");
    };
    if (size_ > maxBytes) throw tooLarge(size_);
    while (fill()) {
        if (buffer_.size() - pos_ > maxBytes) throw tooLarge(buffer_.size() - pos_);
    }
    std::string all = buffer_.substr(pos_);
    buffer_.clear(), pos_ = 0;
    return all;
}

InputFile::Line InputFile::next(std::string& line, uint64_t maxLineBytes) {
    size_t searched = pos_;
    for (;;) {
        const size_t nl = buffer_.find('\n', searched);
        if (nl != std::string::npos && nl - pos_ <= maxLineBytes) {
            line.assign(buffer_, pos_, nl - pos_);
            pos_ = nl + 1;
            ++lineNumber_;
            return Line::complete;
        }
        if (buffer_.size() - pos_ > maxLineBytes) {
            throw InputError(path_.string() + ":" + std::to_string(lineNumber_ + 1) +
                             ": a line of more than " + formatBytes(maxLineBytes));
        }
        const size_t searchedBefore = buffer_.size() - pos_;
        if (!fill()) {
            if (buffer_.size() == pos_) return Line::end;
            line.assign(buffer_, pos_, std::string::npos);
            pos_ = buffer_.size();
            ++lineNumber_;
            return Line::torn;
        }
        searched = pos_ + searchedBefore;  // fill() moved the unread part to the front
    }
}

std::string readInputFile(const std::filesystem::path& path, uint64_t maxBytes,
                          const std::string& what) {
    return InputFile(path).readAll(maxBytes, what);
}

}  // namespace sylva
