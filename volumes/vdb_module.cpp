#include "volumes/vdb_module.h"

#include <mutex>

#include "core/module.h"

namespace sylva {

const VdbModule& vdbModule() {
    static std::once_flag once;
    static const VdbModule* module = nullptr;
    // call_once rethrows and lets a later call try again when loading failed.
    std::call_once(once, [] {
        module = static_cast<const VdbModule*>(
            openModule("libsylva_vdb.so", "SYLVA_VDB_MODULE", "sylva_vdb_module",
                       "OpenVDB, for level-set volumes, watertight meshes and sylva volume"));
    });
    return *module;
}

}  // namespace sylva
