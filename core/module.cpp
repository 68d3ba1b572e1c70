#include "core/module.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>

namespace sylva {

const void* openModule(const char* fileName, const char* envVar, const char* entryPoint,
                       const std::string& purpose) {
    std::string path;
    if (const char* env = std::getenv(envVar); env && *env) {
        path = env;
    } else {
        std::error_code ec;
        const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
        if (!ec) path = (exe.parent_path() / fileName).string();
    }
    std::string why = "nothing";
    if (!path.empty()) {
        // RTLD_LOCAL: the module's libraries' symbols stay out of the executable's global scope.
        if (void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL)) {
            using Entry = const void* (*)();
            if (auto entry = reinterpret_cast<Entry>(dlsym(handle, entryPoint))) return entry();
            why = path + " (no " + entryPoint + ")";
        } else {
            const char* error = dlerror();
            why = path + " (" + (error ? error : "?") + ")";
        }
    }
    throw std::runtime_error(std::string("cannot load ") + fileName + " (" + purpose + "): tried " +
                             why + "; keep it beside the sylva executable or set " + envVar);
}

}  // namespace sylva
