// Elapsed time for the timings a build records (the manifest's `timing`, stats' `grow_ms`): a
// steady clock, never the calendar, so a clock change cannot make a stage take negative time.
#pragma once

#include <chrono>

namespace sylva {

// Milliseconds since `t0` (std::chrono::steady_clock).
inline double msSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace sylva
