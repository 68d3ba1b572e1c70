#include "pipeline/analysis/cmaes_module.h"

#include <mutex>

#include "core/module.h"

namespace sylva {

const CmaesModule& cmaesModule() {
    static std::once_flag once;
    static const CmaesModule* module = nullptr;
    // call_once rethrows and lets a later call try again when loading failed.
    std::call_once(once, [] {
        module = static_cast<const CmaesModule*>(
            openModule("libsylva_cmaes.so", "SYLVA_CMAES_MODULE", "sylva_cmaes_module",
                       "pagmo2, for sylva fit"));
    });
    return *module;
}

}  // namespace sylva
