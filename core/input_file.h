// Files a command reads that a user or a dataset supplies: a spec's reference, a manifest, a
// dataset.json, a skeleton. Only regular files are read (a FIFO would block forever, a device
// such as /dev/zero never ends), each within a stated size, whole or a bounded line at a time.
// Failures are InputError (exit 2) with one line that names the file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace sylva {

// "12.3 MB", "512 bytes": a byte count for messages.
std::string formatBytes(uint64_t bytes);

class InputFile {
  public:
    // Opens `path` without blocking (a FIFO opens at once and is then refused) and checks it is a
    // regular file. InputError "PATH: cannot read (…)" or "PATH: not a regular file (…)".
    explicit InputFile(const std::filesystem::path& path);
    ~InputFile();
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    uint64_t size() const { return size_; }
    const std::filesystem::path& path() const { return path_; }

    // The whole file. InputError "PATH: N bytes, more than the M …" when it is larger than
    // `maxBytes` (checked before reading, and again while reading a file that grows).
    std::string readAll(uint64_t maxBytes, const std::string& what);

    // The next line, without its '\n'. A last line without '\n' (a writer killed mid-line, or
    // one still appending) is `torn`; `end` after the last. InputError "PATH:LINE: a line of more
    // than M" when a line is longer than `maxLineBytes`, without reading it all.
    enum class Line { complete, torn, end };
    Line next(std::string& line, uint64_t maxLineBytes);
    // 1-based number of the line `next` returned last.
    uint64_t lineNumber() const { return lineNumber_; }

  private:
    bool fill();  // reads more into the buffer; false at the end of the file

    std::filesystem::path path_;
    int fd_ = -1;
    uint64_t size_ = 0;
    std::string buffer_;
    size_t pos_ = 0;
    uint64_t lineNumber_ = 0;
};

// InputFile(path).readAll(maxBytes, what).
std::string readInputFile(const std::filesystem::path& path, uint64_t maxBytes,
                          const std::string& what);

}  // namespace sylva
