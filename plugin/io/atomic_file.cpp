/// @file atomic_file.cpp
/// @brief writeAtomically() and the async-signal-safe registry of in-flight temp files.
#include "plugin/io/atomic_file.h"

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace nimbus::io {

namespace {

namespace fs = std::filesystem;

// ---- in-flight registry: fixed storage, lock-free, readable from a signal handler ----

constexpr int kSlots = 64;
constexpr std::size_t kMaxPath = 4096;

/// kFree -> kFilling -> kActive (registered by writeAtomically) -> kRemoving -> kRemoved (by
/// removeInFlightTempFiles) -> kFree (only by the owning writeAtomically call, so a slot is never
/// reused while its owner may still unregister it).
enum SlotState : int { kFree = 0, kFilling = 1, kActive = 2, kRemoving = 3, kRemoved = 4 };

struct Slot {
    std::atomic<int> state{kFree};
    char path[kMaxPath];
};

Slot g_slots[kSlots];
static_assert(std::atomic<int>::is_always_lock_free, "signal safety needs lock-free atomics");

/// Registers @p path; returns the slot index, or -1 if no slot is free or the path is too long
/// (the write then proceeds unregistered: its temp file is a hidden .tmp file, never taken for a
/// valid frame).
int registerTemp(const std::string& path) {
    if (path.size() + 1 > kMaxPath) return -1;
    for (int i = 0; i < kSlots; ++i) {
        int expected = kFree;
        if (g_slots[i].state.compare_exchange_strong(expected, kFilling)) {
            std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
            g_slots[i].state.store(kActive, std::memory_order_release);
            return i;
        }
    }
    return -1;
}

void unregisterTemp(int slot) {
    if (slot < 0) return;
    for (;;) {
        int s = g_slots[slot].state.load();
        if (s == kRemoving) continue; // another thread's handler is unlinking it: a short wait
        if (g_slots[slot].state.compare_exchange_weak(s, kFree)) return;
    }
}

std::atomic<unsigned long long> g_counter{0};

std::string sysError(const std::string& what, const std::string& path, int err) {
    return what + " '" + path + "': " + std::strerror(err);
}

void fsyncPath(const std::string& path, bool directory) {
    const int fd =
        ::open(path.c_str(), (directory ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC);
    if (fd < 0) {
        const int err = errno;
        if (directory) return; // best effort for the directory
        throw std::runtime_error(sysError("cannot open written file", path, err));
    }
    if (::fsync(fd) != 0) {
        const int err = errno;
        ::close(fd);
        // Some filesystems cannot fsync directories (EINVAL): the file itself is durable.
        if (directory && (err == EINVAL || err == EBADF)) return;
        throw std::runtime_error(sysError("cannot fsync", path, err));
    }
    if (::close(fd) != 0 && !directory) {
        const int err = errno;
        throw std::runtime_error(sysError("cannot close", path, err));
    }
}

void signalHandler(int sig) {
    const int savedErrno = errno;
    removeInFlightTempFiles();
    errno = savedErrno;
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

} // namespace

/// NAME_MAX of Linux file systems: a temp name never exceeds it.
constexpr std::size_t kNameMax = 255;

/// 8 hex digits naming this machine: a temp file of another machine (a farm writing to a shared
/// file system) is never taken for one of a dead process here.
std::string hostTag() {
    char host[256] = "";
    ::gethostname(host, sizeof host - 1);
    std::uint32_t h = 2166136261u; // FNV-1a
    for (const char* c = host; *c; ++c) h = (h ^ std::uint8_t(*c)) * 16777619u;
    char buf[16];
    std::snprintf(buf, sizeof buf, "%08x", h);
    return buf;
}

std::string makeTempPath(const std::string& finalPath) {
    const fs::path p(finalPath);
    const std::string suffix = ".tmp-" + hostTag() + "-" + std::to_string(::getpid()) + "-" +
                               std::to_string(g_counter.fetch_add(1));
    std::string base = p.filename().string();
    const std::size_t room = kNameMax - 1 - suffix.size();
    if (base.size() > room) base.resize(room); // a long name: its prefix (within NAME_MAX)
    return (p.parent_path() / ("." + base + suffix)).string();
}

std::size_t removeStaleTempFiles(const std::vector<std::string>& finalPaths) {
    std::map<fs::path, std::set<std::string>> byDir;
    for (const std::string& f : finalPaths) {
        const fs::path p(f);
        byDir[p.has_parent_path() ? p.parent_path() : fs::path(".")].insert(p.filename().string());
    }
    const std::string host = hostTag();
    std::size_t removed = 0;
    for (const auto& [dir, names] : byDir) {
        std::error_code ec;
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
            const std::string n = it->path().filename().string();
            // .<name>.tmp-<host>-<pid>-<counter>
            const std::size_t at = n.rfind(".tmp-");
            if (n.size() < 2 || n[0] != '.' || at == std::string::npos || at < 1) continue;
            const std::string base = n.substr(1, at - 1), rest = n.substr(at + 5);
            const std::size_t d1 = rest.find('-'), d2 = rest.find('-', d1 + 1);
            if (d1 == std::string::npos || d2 == std::string::npos) continue;
            if (rest.substr(0, d1) != host) continue;
            const std::string pidText = rest.substr(d1 + 1, d2 - d1 - 1);
            if (pidText.empty() || pidText.find_first_not_of("0123456789") != std::string::npos)
                continue;
            const bool named = names.count(base) > 0 ||
                               (n.size() == kNameMax &&
                                std::any_of(names.begin(), names.end(), [&](const std::string& f) {
                                    return f.rfind(base, 0) == 0;
                                }));
            if (!named) continue;
            const pid_t pid = pid_t(std::stol(pidText));
            if (pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue; // alive
            if (::unlink(it->path().c_str()) == 0) ++removed;
        }
    }
    return removed;
}

void writeAtomically(const std::string& finalPath,
                     const std::function<void(const std::string& tempPath)>& writer) {
    if (finalPath.empty()) throw std::runtime_error("writeAtomically: empty output path");
    const fs::path target(finalPath);
    if (!target.has_filename())
        throw std::runtime_error("output path '" + finalPath + "' names a directory, not a file");
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    if (target.has_parent_path()) {
        std::error_code ec;
        fs::create_directories(dir, ec);
        if (ec)
            throw std::runtime_error(sysError("cannot create directory", dir.string(), ec.value()));
    }
    {
        std::error_code ec;
        if (fs::is_directory(target, ec))
            throw std::runtime_error("cannot write '" + finalPath + "': it is a directory");
    }

    const std::string temp = makeTempPath(finalPath);
    const int slot = registerTemp(temp);
    try {
        writer(temp);
        // tests/test_stability.cpp: a signal between writing and renaming (the handler removes
        // the temp file, so the fsync below fails)
        if (const char* f = std::getenv("NIMBUS_TEST_FAULT");
            f && std::string(f) == "signal-in-write")
            std::raise(SIGTERM);
        fsyncPath(temp, false);
        if (::rename(temp.c_str(), finalPath.c_str()) != 0) {
            const int err = errno;
            throw std::runtime_error("cannot rename '" + temp + "' to '" + finalPath +
                                     "': " + std::strerror(err));
        }
    } catch (...) {
        ::unlink(temp.c_str());
        unregisterTemp(slot);
        throw;
    }
    unregisterTemp(slot);
    fsyncPath(dir.string(), true);
}

void removeInFlightTempFiles() noexcept {
    for (int i = 0; i < kSlots; ++i) {
        int expected = kActive;
        if (g_slots[i].state.compare_exchange_strong(expected, kRemoving)) {
            ::unlink(g_slots[i].path);
            g_slots[i].state.store(kRemoved);
        }
    }
}

std::size_t inFlightTempFileCount() noexcept {
    std::size_t n = 0;
    for (int i = 0; i < kSlots; ++i)
        if (g_slots[i].state.load() == kActive) ++n;
    return n;
}

void installTempFileCleanupOnSignals() {
    struct sigaction sa {};
    sa.sa_handler = signalHandler;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(sig, &sa, nullptr);
}

} // namespace nimbus::io
