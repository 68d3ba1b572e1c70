// ProcessStart: the wall time of a whole `sylva --help`, spawned and waited for. The command
// itself does next to nothing, so this is the cost of starting any sylva process: mapping and
// relocating its shared libraries and running their static initialisers (docs/benchmarks.md,
// "Process start"). The program timed is the `sylva` beside this one, or $SYLVA_EXE (to
// compare two builds in one run).
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

extern char** environ;

namespace {

std::string sylvaExe() {
    if (const char* env = std::getenv("SYLVA_EXE"); env && *env) return env;
    return (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "sylva").string();
}

void ProcessStart(benchmark::State& state) {
    const std::string exe = sylvaExe();
    if (::access(exe.c_str(), X_OK) != 0) {
        state.SkipWithError(("no executable " + exe).c_str());
        return;
    }
    posix_spawn_file_actions_t io;
    posix_spawn_file_actions_init(&io);
    posix_spawn_file_actions_addopen(&io, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&io, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
    char* argv[] = {const_cast<char*>(exe.c_str()), const_cast<char*>("--help"), nullptr};
    for (auto _ : state) {
        pid_t pid = 0;
        if (posix_spawn(&pid, exe.c_str(), &io, nullptr, argv, environ) != 0) {
            state.SkipWithError("posix_spawn failed");
            break;
        }
        int status = 0;
        ::waitpid(pid, &status, 0);
        if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
            state.SkipWithError("sylva --help did not exit 0");
            break;
        }
    }
    posix_spawn_file_actions_destroy(&io);
}
BENCHMARK(ProcessStart)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
