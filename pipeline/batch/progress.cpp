#include "pipeline/batch/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>
#include <utility>

namespace sylva {

Progress::Progress(int64_t total, bool enabled)
    : total_(total),
      enabled_(enabled),
      tty_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

std::string formatDuration(double s) {
    if (std::isnan(s)) return "?";
    s = std::max(s, 0.0);
    // In doubles throughout: an hour count past 2^31 (a count of 10^12 trees at a few per
    // second) must not wrap into a negative number.
    constexpr double kMinute = 60, kHour = 3600, kDay = 86400, kYear = 365.25 * kDay;
    char buf[48];
    if (s < kMinute) {
        std::snprintf(buf, sizeof buf, "%.0fs", std::floor(s));
    } else if (s < kHour) {
        std::snprintf(buf, sizeof buf, "%.0fm%02.0fs", std::floor(s / kMinute),
                      std::floor(std::fmod(s, kMinute)));
    } else if (s < 100 * kHour) {
        std::snprintf(buf, sizeof buf, "%.0fh%02.0fm", std::floor(s / kHour),
                      std::floor(std::fmod(s, kHour) / kMinute));
    } else if (s < kYear) {
        std::snprintf(buf, sizeof buf, "%.0fd%02.0fh", std::floor(s / kDay),
                      std::floor(std::fmod(s, kDay) / kHour));
    } else if (s < 1e6 * kYear) {
        std::snprintf(buf, sizeof buf, "%.0fy", std::floor(s / kYear));
    } else {
        std::snprintf(buf, sizeof buf, "over 1000000y");
    }
    return buf;
}

std::string Progress::line(int64_t done, int64_t failed) const {
    double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    double rate = t > 0 ? done / t : 0;
    double eta = rate > 0 ? (total_ - done) / rate : 0;
    char buf[160];
    std::snprintf(buf, sizeof buf, "%lld/%lld trees  %.1f trees/s  elapsed %s  ETA %s%s",
                  static_cast<long long>(done), static_cast<long long>(total_), rate,
                  formatDuration(t).c_str(), formatDuration(eta).c_str(),
                  failed ? ("  failed " + std::to_string(failed)).c_str() : "");
    return buf;
}

void Progress::tick(int64_t done, int64_t failed) {
    if (!enabled_) return;
    auto now = std::chrono::steady_clock::now();
    double since = std::chrono::duration<double>(now - last_).count();
    if (since < (tty_ ? 0.1 : 5.0)) return;  // finish() prints the last line
    last_ = now;
    if (tty_)
        std::fprintf(stderr, "\r\033[K%s", line(done, failed).c_str());
    else
        std::fprintf(stderr, "sylva: %s\n", line(done, failed).c_str());
    std::fflush(stderr);
}

void Progress::finish(int64_t done, int64_t failed) {
    if (!enabled_) return;
    if (tty_)
        std::fprintf(stderr, "\r\033[K%s\n", line(done, failed).c_str());
    else
        std::fprintf(stderr, "sylva: %s\n", line(done, failed).c_str());
}

struct InstanceProgress::State {
    std::string id;
    double every;
    std::FILE* out;
    std::chrono::steady_clock::time_point start;
    std::mutex mutex;
    double lastPrinted = 0;  // seconds since start
};

InstanceProgress::InstanceProgress(std::string id, double every, std::FILE* out)
    : state_(std::make_shared<State>()) {
    state_->id = std::move(id);
    state_->every = every;
    state_->out = out;
    state_->start = std::chrono::steady_clock::now();
}

void InstanceProgress::operator()(const char* phase, int64_t done, int64_t total,
                                  const char* unit) const {
    State& s = *state_;
    const double t =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - s.start).count();
    std::lock_guard<std::mutex> lock(s.mutex);
    if (t < s.lastPrinted + s.every) return;
    s.lastPrinted = t;
    std::fprintf(s.out, "sylva: %s: %s %lld of %lld %s (elapsed %s)\n", s.id.c_str(), phase,
                 static_cast<long long>(std::min(done, total)), static_cast<long long>(total), unit,
                 formatDuration(t).c_str());
    std::fflush(s.out);
}

}  // namespace sylva
