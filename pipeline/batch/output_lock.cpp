#include "pipeline/batch/output_lock.h"

#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <vector>

#include "core/errors.h"
#include "core/input_file.h"
#include "pipeline/batch/build.h"

namespace sylva {

namespace fs = std::filesystem;

namespace {

std::string readSmallFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

std::string hostName() {
    char buf[HOST_NAME_MAX + 1] = {};
    if (::gethostname(buf, sizeof buf - 1) != 0) return "";
    return buf;
}

std::string bootId() {
    std::string id = readSmallFile("/proc/sys/kernel/random/boot_id");
    while (!id.empty() && std::isspace(static_cast<unsigned char>(id.back()))) id.pop_back();
    return id;
}

// Field 22 of /proc/<pid>/stat (start time, clock ticks after boot); 0 when unknown. With the
// pid it names one process for the life of the boot, whatever pids are reused.
int64_t processStart(int64_t pid) {
    const std::string stat = readSmallFile("/proc/" + std::to_string(pid) + "/stat");
    const size_t paren = stat.rfind(')');  // the command name may hold spaces and ')'
    if (paren == std::string::npos) return 0;
    std::istringstream rest(stat.substr(paren + 1));
    std::string field;
    for (int i = 3; i <= 22 && rest >> field; ++i) {
        if (i == 22) return std::strtoll(field.c_str(), nullptr, 10);
    }
    return 0;
}

std::string utcNow() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    ::gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

nlohmann::json toJson(const LockHolder& h) {
    return {{"pid", h.pid},         {"host", h.host},
            {"boot_id", h.bootId},  {"pid_start", h.pidStart},
            {"started", h.started}, {"command", h.command}};
}

// A lock file is one JSON line of a few hundred bytes.
constexpr uint64_t kMaxLockFileBytes = 64 * 1024;

// The holder recorded in a lock file; false when it is unreadable (gone, not a regular file,
// over kMaxLockFileBytes, not a JSON object, or a field of the wrong type).
bool readHolder(const fs::path& file, LockHolder& h) {
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(readInputFile(file, kMaxLockFileBytes, "lock file"), nullptr,
                                  false);
    } catch (const InputError&) {
        return false;
    }
    if (j.is_discarded() || !j.is_object()) return false;
    auto integer = [&](const char* key, int64_t& v) {
        const auto it = j.find(key);
        if (it == j.end()) return true;
        if (!it->is_number_integer()) return false;
        v = it->get<int64_t>();
        return true;
    };
    auto text = [&](const char* key, std::string& v) {
        const auto it = j.find(key);
        if (it == j.end()) return true;
        if (!it->is_string()) return false;
        v = it->get<std::string>();
        return true;
    };
    if (!integer("pid", h.pid) || !integer("pid_start", h.pidStart) || !text("host", h.host) ||
        !text("boot_id", h.bootId) || !text("started", h.started) || !text("command", h.command)) {
        return false;
    }
    return h.pid > 0;
}

// Whether some process holds an flock on `file` (false when it cannot tell, e.g. no flock on
// this file system: the pid check decides then).
bool flockHeld(const fs::path& file) {
    int fd = ::open(file.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0) fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return false;
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    ::close(fd);  // releases the flock if it was taken
    return held;
}

// A lock left by a process that is gone: only decidable on the holder's own host (and boot).
bool isStale(const LockHolder& h, const fs::path& file, const LockHolder& me) {
    if (h.host != me.host || flockHeld(file)) return false;
    if (!h.bootId.empty() && !me.bootId.empty() && h.bootId != me.bootId) return true;  // reboot
    if (::kill(static_cast<pid_t>(h.pid), 0) != 0 && errno == ESRCH) return true;
    return h.pidStart != 0 && processStart(h.pid) != h.pidStart;  // the pid was reused
}

// ".sylva.lock" → {0, 1, whole}; ".sylva.shard-I-of-N.lock" → {I, N}.
struct Scope {
    bool whole = true;
    int index = 0, count = 1;
};
bool parseLockName(const std::string& name, Scope& s) {
    if (name == ".sylva.lock") {
        s = Scope{};
        return true;
    }
    const std::optional<ShardOf> shard = parseShardFileName(name, ".sylva", ".lock");
    if (!shard) return false;
    s.whole = false;
    s.index = shard->index;
    s.count = shard->count;
    return true;
}

// Two holders may not work in one directory at once: the whole directory excludes everything,
// and shards of different counts overlap.
bool conflicts(const Scope& a, const Scope& b) {
    return a.whole || b.whole || a.count != b.count || a.index == b.index;
}

std::string describe(const LockHolder& h) {
    return (h.command.empty() ? std::string("sylva") : h.command) + " (pid " +
           std::to_string(h.pid) + " on host " + h.host + ", since " + h.started + ")";
}

// Lock files to remove should the process be ended by a signal (async-signal-safe: fixed
// slots, unlink only).
constexpr int kSlots = 8;
std::array<char[PATH_MAX], kSlots> gSlotPath;
std::array<std::atomic<bool>, kSlots> gSlotUsed{};

void onTerminatingSignal(int sig) {
    for (int i = 0; i < kSlots; ++i) {
        if (gSlotUsed[i].load()) ::unlink(gSlotPath[i]);
    }
    ::signal(sig, SIG_DFL);
    ::raise(sig);
}

void installSignalCleanup() {
    static std::atomic<bool> installed{false};
    if (installed.exchange(true)) return;
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
        struct sigaction old {};
        if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL) continue;
        struct sigaction sa {};
        sa.sa_handler = onTerminatingSignal;
        ::sigemptyset(&sa.sa_mask);
        ::sigaction(sig, &sa, nullptr);
    }
}

int registerSlot(const fs::path& file) {
    const std::string p = fs::absolute(file).string();
    if (p.size() >= PATH_MAX) return -1;
    for (int i = 0; i < kSlots; ++i) {
        if (gSlotUsed[i].load()) continue;
        std::memcpy(gSlotPath[i], p.c_str(), p.size() + 1);
        gSlotUsed[i].store(true);
        return i;
    }
    return -1;
}

void unregisterSlot(const fs::path& file) {
    const std::string p = fs::absolute(file).string();
    for (int i = 0; i < kSlots; ++i) {
        if (gSlotUsed[i].load() && p == gSlotPath[i]) gSlotUsed[i].store(false);
    }
}

// Serialises lock checks and takeovers among processes of this host (flock on the directory;
// where the file system has none, the atomic creation below still excludes two holders).
class DirGuard {
  public:
    explicit DirGuard(const fs::path& dir) {
        fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (fd_ >= 0) {
            while (::flock(fd_, LOCK_EX) != 0 && errno == EINTR) {
            }
        }
    }
    ~DirGuard() {
        if (fd_ >= 0) ::close(fd_);
    }

  private:
    int fd_ = -1;
};

}  // namespace

void unlinkOnSignal(const fs::path& file) {
    installSignalCleanup();
    registerSlot(file);
}

void keepOnSignal(const fs::path& file) { unregisterSlot(file); }

LockHolder currentHolder(const std::string& command) {
    LockHolder h;
    h.pid = ::getpid();
    h.host = hostName();
    h.bootId = bootId();
    h.pidStart = processStart(h.pid);
    h.started = utcNow();
    h.command = command;
    return h;
}

std::string OutputLock::fileName(int shardIndex, int shardCount) {
    if (shardCount <= 1) return ".sylva.lock";
    return ".sylva.shard-" + std::to_string(shardIndex) + "-of-" + std::to_string(shardCount) +
           ".lock";
}

bool OutputLock::isLockFile(const std::string& name) {
    Scope s;
    return parseLockName(name, s);
}

OutputLock::OutputLock(const fs::path& dir, const std::string& command, int shardIndex,
                       int shardCount) {
    const std::string name = fileName(shardIndex, shardCount);
    Scope mine;
    parseLockName(name, mine);
    const LockHolder me = currentHolder(command);
    const fs::path lockFile = dir / name;
    DirGuard guard(dir);

    // Every conflicting lock (this one's own name included): held → LockError; left by a
    // process that is gone → removed.
    auto clearConflicts = [&](bool ownName) {
        std::error_code ec;
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
            const std::string other = it->path().filename().string();
            Scope theirs;
            if (!parseLockName(other, theirs) || !conflicts(mine, theirs)) continue;
            if (other == name && !ownName) continue;
            LockHolder h;
            if (!readHolder(it->path(), h)) {
                if (!fs::exists(it->path())) continue;  // its holder just ended
                throw LockError(dir.string() + " is locked (" + it->path().string() +
                                ", holder unreadable); if no sylva runs there, delete that file");
            }
            if (isStale(h, it->path(), me)) {
                ::unlink(it->path().c_str());
                continue;
            }
            std::string message = dir.string() + " is in use by " + describe(h);
            if (h.host != me.host) {
                message += "; if that process no longer runs, delete " + it->path().string();
            } else {
                message += "; wait for it to finish or use another directory";
            }
            throw LockError(message);
        }
    };
    clearConflicts(true);
    // Temp files of a lock creation on this host whose process died between two system calls.
    {
        // (a pid has at most 7 digits on Linux: 9 keep std::stoll in range whatever the name)
        static const std::regex newFile(R"(\.sylva.*\.lock\.new\.(.*)\.(\d{1,9}))");
        std::error_code ec;
        std::vector<fs::path> stale;
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
            const std::string f = it->path().filename().string();
            std::smatch m;
            if (std::regex_match(f, m, newFile) && m[1] == me.host &&
                ::kill(static_cast<pid_t>(std::stoll(m[2])), 0) != 0 && errno == ESRCH) {
                stale.push_back(it->path());
            }
        }
        for (const fs::path& p : stale) ::unlink(p.c_str());
    }

    // Create the lock complete or not at all: a temporary file hard-linked to the lock's name
    // (link fails if the name exists, on NFS too); O_EXCL where hard links are not supported.
    const std::string content = toJson(me).dump() + "\n";
    const fs::path tmp = dir / (name + ".new." + me.host + "." + std::to_string(me.pid));
    int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) {
        throw LockError("cannot lock " + dir.string() + ": cannot create " + tmp.string() + ": " +
                        std::strerror(errno));
    }
    const bool written =
        ::write(fd, content.data(), content.size()) == static_cast<ssize_t>(content.size());
    const int writeErr = errno;
    ::close(fd);
    int linkErr = 0;
    if (written && ::link(tmp.c_str(), lockFile.c_str()) != 0) linkErr = errno;
    ::unlink(tmp.c_str());
    if (!written) {
        if (isResourceErrno(writeErr)) {
            throw ResourceError(
                writeErr, lockFile.string(),
                "cannot write " + lockFile.string() + ": " + std::strerror(writeErr));
        }
        throw LockError("cannot lock " + dir.string() + ": " + std::strerror(writeErr));
    }
    if (linkErr == EPERM || linkErr == ENOTSUP || linkErr == EOPNOTSUPP || linkErr == EXDEV) {
        fd = ::open(lockFile.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (fd < 0) {
            linkErr = errno;
        } else {
            linkErr = 0;
            [[maybe_unused]] ssize_t w = ::write(fd, content.data(), content.size());
            ::close(fd);
        }
    }
    if (linkErr == EEXIST) {
        clearConflicts(true);  // created meanwhile (another host): name its holder
        throw LockError(dir.string() + " is in use (" + lockFile.string() + " appeared)");
    }
    if (linkErr != 0) {
        throw LockError("cannot lock " + dir.string() + ": cannot create " + lockFile.string() +
                        ": " + std::strerror(linkErr));
    }
    file_ = lockFile;
    fd_ = ::open(lockFile.c_str(), O_RDWR | O_CLOEXEC);
    if (fd_ >= 0) {
        while (::flock(fd_, LOCK_EX) != 0 && errno == EINTR) {
        }
    }
    installSignalCleanup();
    registerSlot(file_);

    // A conflicting lock of another scope may have been created on another host between the
    // check and the creation: then both see each other and at least one backs off.
    try {
        clearConflicts(false);
    } catch (...) {
        unregisterSlot(file_);
        ::unlink(file_.c_str());
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
        throw;
    }
}

OutputLock::~OutputLock() {
    unregisterSlot(file_);
    struct stat mine {
    }, now{};
    // Only this lock: should the file have been replaced (deleted by hand and taken by another
    // process), it is theirs now.
    if (fd_ >= 0 && ::fstat(fd_, &mine) == 0 && ::stat(file_.c_str(), &now) == 0 &&
        mine.st_ino == now.st_ino && mine.st_dev == now.st_dev) {
        ::unlink(file_.c_str());
    }
    if (fd_ >= 0) ::close(fd_);
}

void OutputLock::movedTo(const fs::path& dir) {
    unregisterSlot(file_);
    file_ = dir / file_.filename();
    registerSlot(file_);
}

void checkOutputDir(const fs::path& dir, const std::string& option) {
    if (dir.empty()) throw InputError(option + ": expected a directory, got an empty path");
    const std::string name = option + " " + dir.string();
    struct stat st {};
    if (::stat(dir.c_str(), &st) == 0) {
        if (!S_ISDIR(st.st_mode)) throw InputError(name + ": exists and is not a directory");
        if (::access(dir.c_str(), W_OK | X_OK) != 0) {
            throw InputError(name + ": not writable (" + std::strerror(errno) + ")");
        }
        return;
    }
    if (errno != ENOENT && errno != ENOTDIR) throw InputError(name + ": " + std::strerror(errno));
    // The nearest existing ancestor must be a writable directory.
    fs::path p = fs::absolute(dir).lexically_normal();
    while (p.has_parent_path() && p != p.parent_path()) {
        p = p.parent_path();
        if (::stat(p.c_str(), &st) != 0) {
            if (errno == ENOENT || errno == ENOTDIR) continue;
            throw InputError(name + ": cannot be created (" + p.string() + ": " +
                             std::strerror(errno) + ")");
        }
        if (!S_ISDIR(st.st_mode)) {
            throw InputError(name + ": cannot be created (" + p.string() + " is not a directory)");
        }
        if (::access(p.c_str(), W_OK | X_OK) != 0) {
            throw InputError(name + ": cannot be created (" + p.string() + ": " +
                             std::strerror(errno) + ")");
        }
        return;
    }
}

void createOutputDir(const fs::path& dir, const std::string& option) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (!ec) return;
    const std::string message =
        option + " " + dir.string() + ": cannot be created (" + ec.message() + ")";
    if (isResourceErrno(ec.value())) throw ResourceError(ec.value(), dir.string(), message);
    throw InputError(message);
}

}  // namespace sylva
