#include "tests/cli/cli_support.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fstream>
#include <thread>

#include "tests/test_support.h"

extern char** environ;

namespace sylva::test {

namespace fs = std::filesystem;

CliChild spawnSylva(const std::vector<std::string>& args, const fs::path& dir,
                    const CliOptions& options) {
    static std::atomic<int> counter{0};
    CliChild c;
    const std::string n = std::to_string(counter++);
    const fs::path logs = options.logDir.empty() ? dir : options.logDir;
    c.outFile = logs / ("run" + n + ".stdout");
    c.errFile = logs / ("run" + n + ".stderr");
    c.watchdog = options.watchdog;

    // Everything the child needs is prepared before fork (only async-signal-safe calls after).
    std::vector<std::string> argStore = {SYLVA_EXE};
    argStore.insert(argStore.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argStore) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> envStore;
    for (char** e = environ; *e; ++e) {
        if (std::strncmp(*e, "SYLVA_TEST_", 11) != 0) envStore.emplace_back(*e);  // test hooks
    }
    envStore.insert(envStore.end(), options.env.begin(), options.env.end());
    std::vector<char*> envp;
    for (auto& e : envStore) envp.push_back(e.data());
    envp.push_back(nullptr);
    const std::string dirStr = dir.string(), errStr = c.errFile.string();
    const std::string outStr = options.keepStdout ? c.outFile.string() : "/dev/null";
    const int* gate = options.gate;
    const rlim_t fsize = options.fileSizeLimit, as = options.addressSpace;

    c.start = std::chrono::steady_clock::now();
    c.pid = ::fork();
    if (c.pid == 0) {
        const int o = ::open(outStr.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int e = ::open(errStr.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int in = ::open("/dev/null", O_RDONLY);
        if (o < 0 || e < 0 || in < 0 || ::dup2(o, 1) < 0 || ::dup2(e, 2) < 0 || ::dup2(in, 0) < 0 ||
            ::chdir(dirStr.c_str()) != 0) {
            ::_exit(126);
        }
        if (gate) {
            ::close(gate[1]);  // (the parent's copy is the one that counts)
            char ch;
            while (::read(gate[0], &ch, 1) < 0 && errno == EINTR) {
            }
            ::close(gate[0]);
        }
        ::signal(SIGXFSZ, SIG_DFL);
        if (fsize > 0) {
            const rlimit rl = {fsize, fsize};
            if (::setrlimit(RLIMIT_FSIZE, &rl) != 0) ::_exit(125);
        }
        if (as > 0) {
            const rlimit rl = {as, as};
            if (::setrlimit(RLIMIT_AS, &rl) != 0) ::_exit(125);
        }
        ::execve(argv[0], argv.data(), envp.data());
        ::_exit(127);
    }
    EXPECT_GT(c.pid, 0) << "fork failed";
    return c;
}

CliResult finishSylva(const CliChild& c) {
    CliResult r;
    if (c.pid <= 0) return r;
    int status = 0;
    rusage usage{};
    if (c.watchdog.count() > 0) {
        const auto deadline = c.start + c.watchdog;
        for (;;) {
            const pid_t got = ::wait4(c.pid, &status, WNOHANG, &usage);
            if (got == c.pid || (got < 0 && errno != EINTR)) break;
            if (std::chrono::steady_clock::now() > deadline) {
                ::kill(c.pid, SIGKILL);
                while (::wait4(c.pid, &status, 0, &usage) < 0 && errno == EINTR) {
                }
                r.hung = true;
                break;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    } else {
        while (::wait4(c.pid, &status, 0, &usage) < 0 && errno == EINTR) {
        }
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - c.start).count();
    r.cpuSeconds = usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
                   1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
    r.maxRssKiB = usage.ru_maxrss;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status)
                               : (WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1);
    std::error_code ec;
    if (fs::exists(c.outFile, ec)) r.out = slurp(c.outFile);
    r.err = slurp(c.errFile);
    fs::remove(c.outFile, ec);
    fs::remove(c.errFile, ec);
    return r;
}

CliResult runSylva(const std::vector<std::string>& args, const fs::path& dir,
                   const CliOptions& options) {
    return finishSylva(spawnSylva(args, dir, options));
}

std::vector<CliResult> runAllSylva(const std::vector<std::vector<std::string>>& runs,
                                   const fs::path& dir, const CliOptions& options) {
    std::vector<CliChild> children;
    for (const auto& args : runs) children.push_back(spawnSylva(args, dir, options));
    std::vector<CliResult> results;
    for (const CliChild& c : children) results.push_back(finishSylva(c));
    return results;
}

void expectOneLineAt(const CliResult& r, const fs::path& spec, int line,
                     const std::vector<std::string>& expect) {
    EXPECT_EQ(r.code, 2) << describeRun(r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    const std::string at = spec.filename().string() + ":" + std::to_string(line) + ":";
    EXPECT_NE(r.err.find(at), std::string::npos) << "expected \"" << at << "\" in: " << r.err;
    for (const std::string& e : expect) {
        EXPECT_NE(r.err.find(e), std::string::npos) << "expected \"" << e << "\" in: " << r.err;
    }
}

void expectBadSpecFixture(const fs::path& spec) {
    const auto [expect, line] = fixtureComments(spec);
    ASSERT_FALSE(expect.empty()) << spec;
    ASSERT_GT(line, 0) << spec;
    TempDir t;
    const fs::path work = t / "work", out = work / "build_out";
    fs::create_directories(work);
    CliOptions o;
    o.logDir = t.path();  // the run's output files stay out of the work directory
    for (const auto& args : std::vector<std::vector<std::string>>{
             {"validate", spec.string()}, {"build", spec.string(), "--out", out.string()}}) {
        SCOPED_TRACE(args[0]);
        expectOneLineAt(runSylva(args, work, o), spec, line, expect);
    }
    EXPECT_FALSE(fs::exists(out));
    EXPECT_TRUE(fs::is_empty(work)) << "the failed runs wrote into " << work;
}

std::vector<std::string> tomlFiles(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) {
        if (e.path().extension() == ".toml") names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

std::string describeRun(const CliResult& r) {
    return (r.hung ? "killed after its watchdog" : "exit " + std::to_string(r.code)) +
           "\n--- stdout:\n" + r.out + "--- stderr:\n" + r.err;
}

}  // namespace sylva::test
