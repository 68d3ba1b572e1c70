#include "volumes/vdb_module.h"

#include "core/module.h"

namespace sylva {

const VdbModule& vdbModule() {
    return moduleTable<VdbModule>(
        "libsylva_vdb.so", "SYLVA_VDB_MODULE", "sylva_vdb_module",
        "OpenVDB, for level-set volumes, watertight meshes and sylva volume");
}

}  // namespace sylva
