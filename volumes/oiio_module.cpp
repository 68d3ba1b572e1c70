#include "volumes/oiio_module.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>

namespace sylva {

namespace {

constexpr const char* kModuleName = "libsylva_oiio.so";
constexpr const char* kEntryPoint = "sylva_oiio_module";

const OiioModule* load() {
    // SYLVA_OIIO_MODULE when set, else the module beside the running executable.
    std::string path;
    if (const char* env = std::getenv("SYLVA_OIIO_MODULE"); env && *env) {
        path = env;
    } else {
        std::error_code ec;
        const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
        if (!ec) path = (exe.parent_path() / kModuleName).string();
    }
    std::string why = "nothing";
    if (!path.empty()) {
        // RTLD_LOCAL: OpenImageIO's symbols stay out of the executable's global scope.
        if (void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL)) {
            using Entry = const OiioModule* (*)();
            if (auto entry = reinterpret_cast<Entry>(dlsym(handle, kEntryPoint))) return entry();
            why = path + " (no " + kEntryPoint + ")";
        } else {
            const char* error = dlerror();
            why = path + " (" + (error ? error : "?") + ")";
        }
    }
    throw std::runtime_error(std::string("cannot load ") + kModuleName +
                             " (OpenImageIO, for images other than PNG): tried " + why +
                             "; keep it beside the sylva executable or set SYLVA_OIIO_MODULE");
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
