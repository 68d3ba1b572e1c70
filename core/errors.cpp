#include "core/errors.h"

#include <cerrno>
#include <cstdio>
#include <sstream>

namespace sylva {

namespace {
// The message with its control characters escaped (\n, \t, \r, \xNN): a spec error is one
// line whatever the spec's strings, keys or file names hold (found by fuzzing: a key or
// `name` with a newline split the message).
std::string oneLine(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    for (char c : s) {
        const auto u = static_cast<unsigned char>(c);
        if (c == '\n') {
            out += "\\n";
        } else if (c == '\r') {
            out += "\\r";
        } else if (c == '\t') {
            out += "\\t";
        } else if (u < 0x20 || u == 0x7f) {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\x%02x", u);
            out += buf;
        } else {
            out += c;
        }
    }
    return out;
}
}  // namespace

std::string SourcePos::str() const {
    std::ostringstream s;
    s << (file.empty() ? "<spec>" : file);
    if (line > 0) s << ':' << line << ':' << column;
    return s.str();
}

SpecError::SpecError(const SourcePos& where, const std::string& keyPath, const std::string& message)
    : InputError(oneLine(where.str() + ": " + (keyPath.empty() ? "" : keyPath + ": ") + message)),
      where_(where) {}

ResourceError::ResourceError(int error, const std::string& path, const std::string& message)
    : std::runtime_error(message), error_(error), path_(path) {}

std::string ResourceError::whatRanOut() const {
    switch (error_) {
        case ENOSPC:
            return "disk full";
        case EDQUOT:
            return "disk quota exceeded";
        case EFBIG:
            return "file size limit reached";
        default:
            return "out of memory";
    }
}

bool isResourceErrno(int error) {
    return error == ENOSPC || error == EDQUOT || error == EFBIG || error == ENOMEM;
}

}  // namespace sylva
