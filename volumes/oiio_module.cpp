#include "volumes/oiio_module.h"

#include <mutex>

#include "core/module.h"

namespace sylva {

namespace {

const OiioModule* load() {
    return static_cast<const OiioModule*>(openModule("libsylva_oiio.so", "SYLVA_OIIO_MODULE",
                                                     "sylva_oiio_module",
                                                     "OpenImageIO, for images other than PNG"));
}

}  // namespace

const OiioModule& oiioModule() {
    static std::once_flag once;
    static const OiioModule* module = nullptr;
    // call_once rethrows and lets a later call try again when loading failed.
    std::call_once(once, [] { module = load(); });
    return *module;
}

}  // namespace sylva
