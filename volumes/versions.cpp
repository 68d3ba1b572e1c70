#include "volumes/versions.h"

#include <CGAL/version.h>

#include <string>

namespace sylva {

std::string cgalVersion() { return CGAL_VERSION_STR; }

}  // namespace sylva
