// Progress on stderr: a live line with count, rate and ETA on a terminal; plain log lines at
// most every few seconds otherwise.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <memory>
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

// Progress inside one long instance — a plot's trees growing, its scan's pulses — as plain
// lines "sylva: ID: growing 1234 of 100000 trees (elapsed 2m05s)", at most one per `every`
// seconds and the first only after `every` seconds, so a short instance prints nothing.
// Callable from any thread; copies share one state.
class InstanceProgress {
  public:
    explicit InstanceProgress(std::string id, double every = 10.0, std::FILE* out = stderr);
    // `phase` ("growing", "scanning"), how many of `total` `unit`s ("trees", "pulses") are done.
    void operator()(const char* phase, int64_t done, int64_t total, const char* unit) const;

  private:
    struct State;
    std::shared_ptr<State> state_;
};

}  // namespace sylva
