// The progress line's durations (pipeline/build/progress.h): known values in each unit, and
// the elapsed and remaining times of a count far past 2^31 seconds stay positive and readable.
#include "pipeline/build/progress.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

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
