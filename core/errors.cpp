#include "core/errors.h"

#include <cerrno>
#include <sstream>

namespace sylva {

std::string SourcePos::str() const {
    std::ostringstream s;
    s << (file.empty() ? "<spec>" : file);
    if (line > 0) s << ':' << line << ':' << column;
    return s.str();
}

SpecError::SpecError(const SourcePos& where, const std::string& keyPath, const std::string& message)
    : InputError(where.str() + ": " + (keyPath.empty() ? "" : keyPath + ": ") + message),
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
