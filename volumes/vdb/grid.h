// What a VdbGrid is (volumes/vdb_module.h): an OpenVDB float grid. Included by the module and by
// tests that read grids with OpenVDB; the libraries see VdbGrid only as an opaque type.
#pragma once

#include <openvdb/openvdb.h>

namespace sylva {

struct VdbGrid {
    openvdb::FloatGrid::Ptr grid;
};

}  // namespace sylva
