// What a failure means, for the exit code: bad input (a spec file, a command-line value, a
// directory that is not a dataset) is an InputError and exits 2 with its one-line message;
// anything else that escapes a command (an I/O failure, a broken invariant — the libraries'
// std::invalid_argument on a programmer error) exits 1.
#pragma once

#include <stdexcept>
#include <string>

namespace sylva {

// Bad input: the message is one line saying what was wrong and where.
class InputError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// A place in a spec file (1-based line and column; line 0: the file as a whole).
struct SourcePos {
    std::string file;
    int line = 0;
    int column = 0;
    std::string str() const;
};

// The machine ran out of something the build needs — disk space (ENOSPC), quota (EDQUOT), the
// file size limit (EFBIG) or memory (ENOMEM) — while writing `path`: neither bad input nor a
// bug. A build stops at the first one and a rerun resumes (pipeline/batch/build.h).
class ResourceError : public std::runtime_error {
  public:
    ResourceError(int error, const std::string& path, const std::string& message);
    int error() const { return error_; }
    const std::string& path() const { return path_; }
    // "disk full", "disk quota exceeded", "file size limit reached", "out of memory".
    std::string whatRanOut() const;

  private:
    int error_;
    std::string path_;
};

// Whether an errno value is one of ResourceError's.
bool isResourceErrno(int error);

// A bad spec: the message is one line, "file:line:col: key.path: what was expected".
class SpecError : public InputError {
  public:
    SpecError(const SourcePos& where, const std::string& keyPath, const std::string& message);
    // Where the error is (a file that references this one wraps it with its own place).
    const SourcePos& where() const { return where_; }

  private:
    SourcePos where_;
};

}  // namespace sylva
