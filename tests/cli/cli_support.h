// Running the real `sylva` binary (SYLVA_EXE) from the CLI tests: one fork/exec runner for every
// tests/cli/ file, with what each needs — the environment without the test's abort hook plus
// extra variables, a working directory, stdout/stderr captured to files there, resource limits
// (RLIMIT_FSIZE for full disks, RLIMIT_AS for memory bounds), a start gate so several processes
// begin together, a watchdog that kills a hung run, and the child's wall, CPU time and peak RSS.
#pragma once

#include <sys/resource.h>
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

namespace sylva::test {

struct CliOptions {
    std::vector<std::string> env;  // "NAME=value", added to the test's environment (from which
                                   // the SYLVA_TEST_ hooks are removed)
    rlim_t fileSizeLimit = 0;      // > 0: RLIMIT_FSIZE in bytes (`ulimit -f`; SIGXFSZ default)
    rlim_t addressSpace = 0;       // > 0: RLIMIT_AS in bytes
    const int* gate = nullptr;     // a pipe: the child waits until its write end is closed
    bool keepStdout = true;        // false: stdout to /dev/null
    std::filesystem::path logDir;  // where stdout/stderr are kept meanwhile (empty: the run's dir)
    std::chrono::seconds watchdog{0};  // > 0: kill the run after this long (result.hung)
};

struct CliResult {
    int code = -1;  // exit status, or 128 + signal number
    bool hung = false;
    std::string out, err;
    double seconds = 0;     // wall time
    double cpuSeconds = 0;  // user + system time of the process
    long maxRssKiB = 0;     // peak resident size
};

struct CliChild {
    pid_t pid = -1;
    std::filesystem::path outFile, errFile;
    std::chrono::steady_clock::time_point start;
    std::chrono::seconds watchdog{0};
};

// Starts `sylva args…` in `dir` (its stdout/stderr in files there, or in options.logDir, until
// finishSylva).
CliChild spawnSylva(const std::vector<std::string>& args, const std::filesystem::path& dir,
                    const CliOptions& options = {});
// Waits for it (killing it at its watchdog), reads and removes its output files.
CliResult finishSylva(const CliChild& child);
CliResult runSylva(const std::vector<std::string>& args, const std::filesystem::path& dir,
                   const CliOptions& options = {});
// Independent runs started together (process start-up dominates the CLI tests' time).
std::vector<CliResult> runAllSylva(const std::vector<std::vector<std::string>>& runs,
                                   const std::filesystem::path& dir,
                                   const CliOptions& options = {});

// A bad-spec fixture: its leading comments say what the error must say (`# expect: <text>`, any
// number) and on which line (`# line: <n>`). Runs `sylva validate SPEC` and `sylva build SPEC
// --out work/out` in an empty work directory and expects, for both: exit 2, one line on stderr
// naming SPEC:<n>: and every expected text, and nothing written (no out, the work dir empty).
void expectBadSpecFixture(const std::filesystem::path& spec);
// A run that failed on bad input: exit 2 and one line naming `spec`'s file name and `line`
// ("NAME:LINE:") and containing every string of `expect`.
void expectOneLineAt(const CliResult& r, const std::filesystem::path& spec, int line,
                     const std::vector<std::string>& expect);
// The .toml files of `dir`, sorted by name (a bad-spec test's parameters).
std::vector<std::string> tomlFiles(const std::filesystem::path& dir);

// "exit N\n--- stdout:\n…--- stderr:\n…", for failure messages.
std::string describeRun(const CliResult& r);

}  // namespace sylva::test
