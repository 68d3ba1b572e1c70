// Crash-safe file output: whole files appear atomically (temp + rename), and the manifest is an
// append-only log whose torn last line (from a killed run) is dropped on resume.
#pragma once

#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace sylva {

// A sibling of `target` named "<target>.tmp.<pid>.<thread>.<counter><suffix>", unique per
// process and thread so concurrent writers never collide; same directory, so a rename onto
// `target` is atomic. `suffix` lets format-sniffing writers (OIIO) see the right extension.
std::filesystem::path uniqueTempPath(const std::filesystem::path& target,
                                     std::string_view suffix = {});

// Creates parent directories, writes `bytes` to a unique temp sibling, then renames it over
// `path`, so readers see either the old or the new complete file. fsync is off by default
// (dataset files can be regenerated; the rename is what guarantees no torn files after a
// process kill); pass fsyncData = true to also survive power loss. Throws std::runtime_error
// naming the path and the OS error (a ResourceError, core/errors.h, when the disk, quota, file
// size limit or memory ran out); the temp file is removed on failure.
void writeFileAtomic(const std::filesystem::path& path, std::string_view bytes,
                     bool fsyncData = false);

// A file written piece by piece (files too large to hold in memory whole, such as a plot's
// scene meshes) and then committed as writeFileAtomic commits: parent directories created, a
// unique temp sibling written through a buffer of `bufferBytes`, every write() checked (a
// ResourceError on a full disk, quota, file size limit, else std::runtime_error naming the
// path), then commit() closes and renames it over the target. Destroyed without commit() (an
// exception on the way), the temp file is removed and the target left as it was.
class AtomicFileWriter {
  public:
    explicit AtomicFileWriter(std::filesystem::path path, size_t bufferBytes = size_t(1) << 20);
    ~AtomicFileWriter();
    AtomicFileWriter(const AtomicFileWriter&) = delete;
    AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

    void write(std::string_view bytes);
    // Room for n bytes at the end of the buffer (flushed first when needed), to be filled by
    // the caller: writers that store numbers in place (little_endian.h) use it.
    char* reserve(size_t n);
    uint64_t bytesWritten() const { return written_ + buffer_.size(); }
    // Replaces bytes already written, from byte `offset` of the file (offset + size ≤
    // bytesWritten(), else std::logic_error): values known only at the end, such as the offset
    // of a LAZ file's chunk table. Throws as write() does.
    void overwrite(uint64_t offset, std::string_view bytes);
    // Flushes, closes and renames the temp file over the target. Throws as write() does.
    void commit();

  private:
    void flush();
    std::filesystem::path path_, tmp_;
    int fd_ = -1;
    std::string buffer_;
    size_t capacity_;
    uint64_t written_ = 0;
};

// Renames `from` over `to`, throwing std::runtime_error (and removing `from`) on failure.
void commitTempFile(const std::filesystem::path& from, const std::filesystem::path& to);

// Append-only line log (the manifest). Each append() is one write() on an O_APPEND fd, so a
// line from this process is never interleaved with other writers' lines and reaches the kernel
// immediately (no user-space buffer). Thread-safe. A kill can still leave a partial last line:
// call readCompleteLines() before opening the log to drop it.
class AppendLog {
  public:
    // Creates parent directories and the file if needed. Throws std::runtime_error.
    explicit AppendLog(const std::filesystem::path& path);
    ~AppendLog();
    AppendLog(const AppendLog&) = delete;
    AppendLog& operator=(const AppendLog&) = delete;

    // Appends line + "\n". The line must not contain '\n' (std::invalid_argument).
    // Throws std::runtime_error on I/O failure (ResourceError on a full disk, after cutting a
    // partly written line off again).
    void append(std::string line);
    // fsync the log (optional durability point, e.g. at the end of a batch).
    void sync();

    const std::filesystem::path& path() const { return path_; }

    // Complete ('\n'-terminated) lines of the file, without the '\n', empty lines included.
    // A trailing partial line is truncated off the file itself. A missing file gives {}.
    // Logs are read whole: at most kMaxLogBytes (else InputError naming the file; a file that is
    // not regular is one too).
    static constexpr uint64_t kMaxLogBytes = uint64_t(256) << 20;
    static std::vector<std::string> readCompleteLines(const std::filesystem::path& path);

  private:
    std::filesystem::path path_;
    int fd_ = -1;
    std::mutex mutex_;
};

}  // namespace sylva
