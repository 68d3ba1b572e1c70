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
    std::vector<std::string> tried;
    std::vector<std::string> candidates;
    if (const char* env = std::getenv("SYLVA_OIIO_MODULE"); env && *env) {
        candidates.push_back(env);
    } else {
        std::error_code ec;
        const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
        if (!ec) candidates.push_back((exe.parent_path() / kModuleName).string());
    }
    for (const std::string& path : candidates) {
        // RTLD_LOCAL: OpenImageIO's symbols stay out of the executable's global scope.
        void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!handle) {
            const char* why = dlerror();
            tried.push_back(path + " (" + (why ? why : "?") + ")");
            continue;
        }
        using Entry = const OiioModule* (*)();
        auto entry = reinterpret_cast<Entry>(dlsym(handle, kEntryPoint));
        if (!entry) {
            tried.push_back(path + " (no " + kEntryPoint + ")");
            continue;
        }
        return entry();
    }
    std::string list;
    for (const std::string& t : tried) list += (list.empty() ? "" : "; ") + t;
    throw std::runtime_error(std::string("cannot load ") + kModuleName +
                             " (OpenImageIO, for images other than PNG): tried " +
                             (list.empty() ? "nothing" : list) +
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
