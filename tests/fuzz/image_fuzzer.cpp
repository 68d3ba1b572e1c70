// libFuzzer target: arbitrary bytes as every image or sketch file a spec can name (a mask, a
// stroke image, a canopy layer image, an SVG stroke; spec_input.h). Built only with clang and
// SYLVA_FUZZ=ON; run by `scripts/fuzz SECONDS image`. Anything but acceptance or the reader's
// own one-line error aborts, and libFuzzer keeps the input.
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
    gThreads =
        std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, 1);
    std::atexit([] { gBox.reset(); });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    sylva::fuzz::readImage(*gBox, data, size);
    return 0;
}
