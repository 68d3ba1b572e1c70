// Versions of the geometry libraries the volumes build on (for dataset.json), for code that
// does not include their headers.
#pragma once

#include <string>

namespace sylva {

std::string cgalVersion();  // CGAL_VERSION_STR

}  // namespace sylva
