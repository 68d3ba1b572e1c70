// Progress on stderr: a live line with count, rate and ETA on a terminal; plain log lines at
// most every few seconds otherwise.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace sylva {

// A duration for the progress line: "42s", "3m07s", "5h04m" (below 100 hours), "12d05h"
// (below a year), "930y", "over 1000000y"; negative as 0, NaN as "?".
std::string formatDuration(double seconds);

class Progress {
  public:
    Progress(int64_t total, bool enabled);
    void tick(int64_t done, int64_t failed);
    void finish(int64_t done, int64_t failed);

  private:
    std::string line(int64_t done, int64_t failed) const;
    int64_t total_;
    bool enabled_;
    bool tty_;
    std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace sylva
