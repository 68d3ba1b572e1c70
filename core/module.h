// Shared modules built beside the executable and opened on first use: a library that is costly
// to load (its own dependencies, its static initialisers, its relocations) then costs only the
// processes that need it. volumes/oiio_module.h (OpenImageIO), volumes/vdb_module.h (OpenVDB) and
// pipeline/analysis/cmaes_module.h (pagmo2) are such modules; each is compiled by the same build
// as its callers, so their tables pass C++ types.
#pragma once

#include <mutex>
#include <string>

namespace sylva {

// Opens the module `fileName` — the path in the environment variable `envVar` when that is set
// and not empty, else the file of that name beside the running executable — with its symbols
// kept out of the executable's scope, and returns what its C entry point `entryPoint` returns.
// Throws std::runtime_error in one line naming the module, `purpose`, what was tried and why it
// failed, and how to fix it.
const void* openModule(const char* fileName, const char* envVar, const char* entryPoint,
                       const std::string& purpose);

// The table `Table` of a module, opened by openModule on the first call (thread-safe); later
// calls return the same table. A failed open throws and lets a later call try again.
template <class Table>
const Table& moduleTable(const char* fileName, const char* envVar, const char* entryPoint,
                         const char* purpose) {
    static std::once_flag once;
    static const Table* table = nullptr;
    std::call_once(once, [&] {
        table = static_cast<const Table*>(openModule(fileName, envVar, entryPoint, purpose));
    });
    return *table;
}

}  // namespace sylva
