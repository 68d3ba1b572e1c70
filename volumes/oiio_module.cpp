#include "volumes/oiio_module.h"

#include "core/module.h"

namespace sylva {

const OiioModule& oiioModule() {
    return moduleTable<OiioModule>("libsylva_oiio.so", "SYLVA_OIIO_MODULE", "sylva_oiio_module",
                                   "OpenImageIO, for images other than PNG");
}

}  // namespace sylva
