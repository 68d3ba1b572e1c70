// InputFile: only regular files are read (a FIFO is refused at once instead of blocking, a
// device instead of reading without end), within their size and line limits; lines come back
// whole across the reader's 64 KiB chunks, a last line without '\n' as torn.
#include "core/input_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/errors.h"
#include "tests/test_support.h"

namespace {

namespace fs = std::filesystem;
using sylva::InputError;
using sylva::InputFile;
using sylva::readInputFile;
using sylva::test::TempDir;

void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary);
    out << bytes;
}

std::string errorOf(const fs::path& p) {
    try {
        InputFile f(p);
        (void)f.readAll(1 << 20, "a test file");
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

TEST(InputFile, AFifoADeviceAndADirectoryAreRefusedWithoutReading) {
    TempDir t;
    const fs::path fifo = t / "fifo";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // No writer: opening it for reading with a blocking open would wait forever.
    EXPECT_EQ(errorOf(fifo), fifo.string() + ": not a regular file (a FIFO)");
    EXPECT_EQ(errorOf("/dev/zero"), "/dev/zero: not a regular file (a character device)");
    EXPECT_EQ(errorOf(t.path()), t.path().string() + ": not a regular file (a directory)");
    EXPECT_NE(errorOf(t / "missing").find(": cannot read (No such file"), std::string::npos);
}

TEST(InputFile, AFileLargerThanItsLimitIsRefusedNamingBoth) {
    TempDir t;
    spit(t / "f", std::string(2500, 'x'));
    EXPECT_EQ(readInputFile(t / "f", 2500, "a test file"), std::string(2500, 'x'));
    try {
        (void)readInputFile(t / "f", 2499, "a test file");
        FAIL() << "read past its limit";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()),
                  (t / "f").string() + ": 2.5 kB, more than the 2.5 kB a test file may hold");
    }
    spit(t / "g", std::string(1200, 'x'));
    try {
        (void)readInputFile(t / "g", 999, "a reference file");
        FAIL() << "read past its limit";
    } catch (const InputError& e) {
        EXPECT_EQ(
            std::string(e.what()),
            (t / "g").string() + ": 1.2 kB, more than the 999 bytes a reference file may hold");
    }
}

TEST(InputFile, LinesComeBackWholeAcrossChunksAndALastLineWithoutNewlineIsTorn) {
    TempDir t;
    const std::string longLine(200000, 'a');  // three of the reader's 64 KiB chunks
    spit(t / "f", "one\n\n" + longLine + "\nlast");
    InputFile f(t / "f");
    std::string line;
    ASSERT_EQ(f.next(line, 1 << 20), InputFile::Line::complete);
    EXPECT_EQ(line, "one");
    EXPECT_EQ(f.lineNumber(), 1u);
    ASSERT_EQ(f.next(line, 1 << 20), InputFile::Line::complete);
    EXPECT_EQ(line, "");
    ASSERT_EQ(f.next(line, 1 << 20), InputFile::Line::complete);
    EXPECT_EQ(line, longLine);
    EXPECT_EQ(f.lineNumber(), 3u);
    ASSERT_EQ(f.next(line, 1 << 20), InputFile::Line::torn);
    EXPECT_EQ(line, "last");
    EXPECT_EQ(f.next(line, 1 << 20), InputFile::Line::end);
}

TEST(InputFile, ALineLongerThanItsLimitIsRefusedWithItsNumber) {
    TempDir t;
    spit(t / "f", "short\n" + std::string(300000, '[') + "\n");
    InputFile f(t / "f");
    std::string line;
    ASSERT_EQ(f.next(line, 100000), InputFile::Line::complete);
    try {
        (void)f.next(line, 100000);
        FAIL() << "a 300 kB line under a 100 kB limit";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()), (t / "f").string() + ":2: a line of more than 100 kB");
    }
}

}  // namespace
