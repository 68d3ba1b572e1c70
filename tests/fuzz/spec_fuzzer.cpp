// libFuzzer target: arbitrary bytes as a species or dataset file, read as `sylva validate`
// reads them (spec_input.h). Built only with clang and SYLVA_FUZZ=ON; run by scripts/fuzz.
// Anything but acceptance or a one-line SpecError — a crash, a sanitizer report, another
// exception (std::terminate), a multi-line message — aborts, and libFuzzer keeps the input.
#include <tbb/global_control.h>

#include <cstdio>
#include <cstdlib>
#include <memory>

#include "tests/fuzz/spec_input.h"

namespace {
std::unique_ptr<sylva::fuzz::Sandbox> gBox;
std::unique_ptr<tbb::global_control> gThreads;
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    gBox = std::make_unique<sylva::fuzz::Sandbox>(SYLVA_SOURCE_DIR);
    // One worker: level sets and CSG measures may use TBB; the machine is shared.
    gThreads =
        std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, 1);
    std::atexit([] { gBox.reset(); });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const sylva::fuzz::Outcome o = sylva::fuzz::readSpec(*gBox, data, size);
    if (!o.accepted && !sylva::fuzz::isOneLine(o.message)) {
        std::fprintf(stderr, "sylva fuzz: SpecError message is not one line:\n%s\n",
                     o.message.c_str());
        std::abort();
    }
    return 0;
}
