// The progress line's durations (pipeline/batch/progress.h): known values in each unit, and
// the elapsed and remaining times of a count far past 2^31 seconds stay positive and readable.
#include "pipeline/batch/progress.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <regex>
#include <string>

namespace sylva {
namespace {

TEST(ProgressDuration, EachUnitWithKnownValues) {
    EXPECT_EQ(formatDuration(0), "0s");
    EXPECT_EQ(formatDuration(59.9), "59s");
    EXPECT_EQ(formatDuration(61), "1m01s");
    EXPECT_EQ(formatDuration(3599), "59m59s");
    EXPECT_EQ(formatDuration(3600 + 4 * 60 + 30), "1h04m");
    EXPECT_EQ(formatDuration(99 * 3600 + 59 * 60), "99h59m");
    EXPECT_EQ(formatDuration(100 * 3600), "4d04h");
    EXPECT_EQ(formatDuration(3e6), "34d17h");  // 34.72 days
    EXPECT_EQ(formatDuration(2 * 365.25 * 86400 + 10), "2y");
}

TEST(ProgressDuration, HugeNegativeAndUndefinedTimesStayReadable) {
    // 10^12 trees at 34 per second: 2.9 × 10^10 s, which wrapped to "-596523h-14m" through an
    // int hour count.
    EXPECT_EQ(formatDuration(1e12 / 34), "932y");
    EXPECT_EQ(formatDuration(1e30), "over 1000000y");
    EXPECT_EQ(formatDuration(std::numeric_limits<double>::infinity()), "over 1000000y");
    EXPECT_EQ(formatDuration(-5), "0s");
    EXPECT_EQ(formatDuration(std::nan("")), "?");
}

}  // namespace
}  // namespace sylva

namespace {

// What an InstanceProgress printed into a temporary file.
std::string printed(std::FILE* f) {
    std::fflush(f);
    std::rewind(f);
    std::string s;
    for (int c; (c = std::fgetc(f)) != EOF;) s += static_cast<char>(c);
    return s;
}

// Lines name the instance, the phase and the counts (capped at the total: a regrown tree counts
// again); none before the interval has passed once, so a short instance prints nothing.
TEST(InstanceProgress, LinesNameTheInstanceAndComeAtMostOncePerInterval) {
    std::FILE* f = std::tmpfile();
    ASSERT_NE(f, nullptr);
    const sylva::InstanceProgress every(std::string("stand-00000"), 0.0, f);
    every("growing", 3, 5, "trees");
    const sylva::InstanceProgress copy = every;  // copies share the state
    copy("growing", 7, 5, "trees");
    every("scanning", 256, 1000, "pulses");
    // (The elapsed time is the machine's: compared as a pattern.)
    const std::string lines =
        std::regex_replace(printed(f), std::regex(R"(\(elapsed \d+(m\d\ds)?s?\))"), "(elapsed T)");
    EXPECT_EQ(lines,
              "sylva: stand-00000: growing 3 of 5 trees (elapsed T)\n"
              "sylva: stand-00000: growing 5 of 5 trees (elapsed T)\n"
              "sylva: stand-00000: scanning 256 of 1000 pulses (elapsed T)\n");
    std::fclose(f);
    std::FILE* g = std::tmpfile();
    ASSERT_NE(g, nullptr);
    const sylva::InstanceProgress hourly(std::string("stand-00001"), 3600.0, g);
    for (int k = 1; k <= 100; ++k) hourly("growing", k, 100, "trees");
    EXPECT_EQ(printed(g), "");
    std::fclose(g);
}

}  // namespace
