#include "pipeline/build/progress.h"

#include <unistd.h>

#include <cstdio>

namespace sylva {

Progress::Progress(int64_t total, bool enabled)
    : total_(total),
      enabled_(enabled),
      tty_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

static std::string duration(double s) {
    char buf[32];
    if (s < 60)
        std::snprintf(buf, sizeof buf, "%.0fs", s);
    else if (s < 3600)
        std::snprintf(buf, sizeof buf, "%dm%02ds", int(s) / 60, int(s) % 60);
    else
        std::snprintf(buf, sizeof buf, "%dh%02dm", int(s) / 3600, (int(s) / 60) % 60);
    return buf;
}

std::string Progress::line(int64_t done, int64_t failed) const {
    double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    double rate = t > 0 ? done / t : 0;
    double eta = rate > 0 ? (total_ - done) / rate : 0;
    char buf[160];
    std::snprintf(buf, sizeof buf, "%lld/%lld trees  %.1f trees/s  elapsed %s  ETA %s%s",
                  static_cast<long long>(done), static_cast<long long>(total_), rate,
                  duration(t).c_str(), duration(eta).c_str(),
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

}  // namespace sylva
