#include "core/errors.h"

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

}  // namespace sylva
