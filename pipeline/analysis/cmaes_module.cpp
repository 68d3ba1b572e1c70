#include "pipeline/analysis/cmaes_module.h"

#include "core/module.h"

namespace sylva {

const CmaesModule& cmaesModule() {
    return moduleTable<CmaesModule>("libsylva_cmaes.so", "SYLVA_CMAES_MODULE", "sylva_cmaes_module",
                                    "pagmo2, for sylva fit");
}

}  // namespace sylva
