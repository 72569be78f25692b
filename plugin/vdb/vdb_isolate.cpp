/// @file vdb_isolate.cpp
/// @brief loadVdbGridIsolated(): the grid is read by the reader executable (a fork and an exec)
///        and sent back through a pipe; readerMain(), that executable's body; checkNanoGrid(),
///        the check of every NanoVDB grid a load returns (see vdb_isolate.h and "Isolation" in
///        vdb_reader.h). No OpenVDB headers here.
#include "plugin/vdb/vdb_isolate.h"

#include "plugin/io/object_folder.h"
#include "plugin/vdb/vdb_velocity.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <new>
#include <type_traits>
#include <vector>

#include <fcntl.h>
#include <poll.h>
#include <sys/mman.h> // memfd_create
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

namespace nimbus::vdb::detail {

namespace {

// ---------------------------------------------------------------------------------------------
// The reply: a fixed header, the metadata (every field of LoadedVdbGrid but the grid), the
// NanoVDB buffer as it is, and an end marker. The child writes it once, then _exit(0)s.

constexpr char kReplyMagic[8] = {'N', 'I', 'M', 'B', 'V', 'D', 'B', '1'};
constexpr char kReplyEnd[8] = {'N', 'I', 'M', 'B', 'V', 'E', 'N', 'D'};
constexpr std::uint64_t kMaxMetaBytes = 64u << 20; // warnings and grid names: far less

enum class ReplyKind : std::uint32_t {
    Loaded = 1,     ///< metadata + grid
    VdbError = 2,   ///< metadata = the message of a VdbError (a refusal or a read failure)
    OtherError = 3, ///< metadata = the what() of another exception
};

struct ReplyHeader {
    char magic[8];
    std::uint32_t kind;
    std::uint32_t reserved;
    std::uint64_t metaBytes;
    std::uint64_t gridBytes;
};

// A tripwire: a field added to LoadedVdbGrid must also be sent (encodeMeta/decodeMeta).
static_assert(sizeof(LoadedVdbGrid) == 544 || sizeof(void*) != 8,
              "LoadedVdbGrid changed: send the new field in encodeMeta() and decodeMeta(), "
              "then update this size");

std::string encodeMeta(const LoadedVdbGrid& g) {
    Encoder e;
    e.pod(g.worldFromIndex);
    e.pod(g.indexFromWorld);
    e.pod(g.voxelSize);
    e.pod(g.worldBounds);
    e.pod(g.indexMin);
    e.pod(g.indexMax);
    e.str(g.path);
    e.str(g.gridName);
    e.str(g.sourceValueType);
    e.str(g.gridClass);
    e.pod(g.fileVersion);
    e.str(g.libraryVersion);
    e.str(g.creator);
    e.pod(g.activeVoxelCount);
    e.pod(g.activeTileCount);
    e.pod(g.leafCount);
    e.pod(g.minValue);
    e.pod(g.maxValue);
    e.pod(g.gridsRead);
    e.pod(g.gridsInFile);
    e.pod(std::uint64_t(g.gridsInFileInfo.size()));
    for (const VdbGridInfo& i : g.gridsInFileInfo) {
        e.str(i.name);
        e.str(i.valueType);
        e.pod(i.dataBegin);
        e.pod(i.dataEnd);
    }
    e.pod(g.nonFiniteCount);
    e.pod(g.negativeCount);
    e.pod(g.inactiveNonZeroCount);
    e.pod(std::uint64_t(g.warnings.size()));
    for (const std::string& w : g.warnings) e.str(w);
    return std::move(e.bytes);
}

/// False when the bytes are not a complete metadata record.
bool decodeMeta(const std::string& bytes, LoadedVdbGrid& g) {
    Decoder d(bytes);
    g.worldFromIndex = d.pod<glm::mat4>();
    g.indexFromWorld = d.pod<glm::mat4>();
    g.voxelSize = d.pod<glm::vec3>();
    g.worldBounds = d.pod<nimbus::Box>();
    g.indexMin = d.pod<glm::ivec3>();
    g.indexMax = d.pod<glm::ivec3>();
    g.path = d.str();
    g.gridName = d.str();
    g.sourceValueType = d.str();
    g.gridClass = d.str();
    g.fileVersion = d.pod<std::uint32_t>();
    g.libraryVersion = d.str();
    g.creator = d.str();
    g.activeVoxelCount = d.pod<std::uint64_t>();
    g.activeTileCount = d.pod<std::uint64_t>();
    g.leafCount = d.pod<std::uint64_t>();
    g.minValue = d.pod<float>();
    g.maxValue = d.pod<float>();
    g.gridsRead = d.pod<int>();
    g.gridsInFile = d.pod<int>();
    const auto grids = d.pod<std::uint64_t>();
    if (grids > bytes.size() / 32) return false; // an entry takes at least 32 bytes
    g.gridsInFileInfo.resize(std::size_t(grids));
    for (VdbGridInfo& i : g.gridsInFileInfo) {
        i.name = d.str();
        i.valueType = d.str();
        i.dataBegin = d.pod<std::uint64_t>();
        i.dataEnd = d.pod<std::uint64_t>();
    }
    g.nonFiniteCount = d.pod<std::uint64_t>();
    g.negativeCount = d.pod<std::uint64_t>();
    g.inactiveNonZeroCount = d.pod<std::uint64_t>();
    const auto warnings = d.pod<std::uint64_t>();
    if (warnings > bytes.size() / 8) return false;
    g.warnings.resize(std::size_t(warnings));
    for (std::string& w : g.warnings) w = d.str();
    return d.complete();
}

// ---------------------------------------------------------------------------------------------
// The reader's side (readerMain) writes the reply.

/// Writes all of @p n bytes; false when the pipe broke.
bool writeAll(int fd, const void* data, std::size_t n) {
    const char* p = static_cast<const char*>(data);
    while (n > 0) {
        const ssize_t k = ::write(fd, p, n);
        if (k < 0) {
            if (errno == EINTR) continue;
            return false;
        }
        p += k;
        n -= std::size_t(k);
    }
    return true;
}

bool writeReply(int fd, ReplyKind kind, const std::string& meta, const void* bulk = nullptr,
                std::uint64_t bulkBytes = 0) {
    ReplyHeader h{};
    std::memcpy(h.magic, kReplyMagic, sizeof h.magic);
    h.kind = std::uint32_t(kind);
    h.metaBytes = meta.size();
    h.gridBytes = bulk ? bulkBytes : 0;
    return writeAll(fd, &h, sizeof h) && writeAll(fd, meta.data(), meta.size()) &&
           (!bulk || writeAll(fd, bulk, std::size_t(bulkBytes))) &&
           writeAll(fd, kReplyEnd, sizeof kReplyEnd);
}

// ---------------------------------------------------------------------------------------------
// The request: what the reader executable is asked to read (its stdin, a memory file).

constexpr char kRequestMagic[8] = {'N', 'I', 'M', 'B', 'R', 'E', 'Q', '1'};

enum class RequestKind : std::uint32_t {
    Grid = 1,     ///< a density grid: loadVdbGridInProcess
    Velocity = 2, ///< a velocity grid: loadVdbVelocityInProcess
};

std::uint64_t physicalMemory() {
    const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGESIZE);
    return pages > 0 && size > 0 ? std::uint64_t(pages) * std::uint64_t(size) : (16ull << 30);
}

/// The address space the reader may map beyond what it has mapped at its start.
std::uint64_t memoryBudget(const VdbLoadOptions& o) {
    return o.memoryLimitBytes ? o.memoryLimitBytes : physicalMemory();
}

void encodeRead(Encoder& e, RequestKind kind, const VdbLoadOptions& o) {
    e.bytes.append(kRequestMagic, sizeof kRequestMagic);
    e.pod(std::uint32_t(kind));
    e.str(o.path);
    e.str(o.gridName);
    e.pod(o.levelsetToFog);
    e.pod(memoryBudget(o));
}

/// Exit codes of the reader besides 0 (a reply was written).
constexpr int kChildWriteFailed = 101; ///< the pipe broke while the reply was written
constexpr int kChildBadRequest = 102;  ///< the request did not decode (not run by Nimbus?)
constexpr int kChildExecFailed = 127;  ///< the reader executable could not be run (the shell's)

/// The forked child, before it becomes the reader: limits itself and replaces its image by the
/// reader executable (execv). Only system calls from here on: the fork copied one thread of a
/// process whose other threads (TBB's workers, the caller's) may have held locks, memory
/// allocation's among them, so nothing that could take a lock runs before the exec. Everything
/// it needs was prepared before the fork. Never returns.
[[noreturn]] void execReader(const char* reader, char* const argv[], int requestFd, int replyFd,
                             int logFd, pid_t parent) {
    // Default dispositions, so that a crash ends the reader with its signal (the caller may have
    // its own handlers, and handlers do not survive the exec, but ignored signals do); a signal
    // blocked in the forking thread is unblocked. Ctrl-C and SIGTERM/SIGHUP sent to the whole
    // process group are the caller's to handle (the nimbus command finishes the load, then
    // stops): ignored here, and so in the reader. If the caller dies, so does the reader
    // (PR_SET_PDEATHSIG survives the exec).
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    for (int s :
         {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGTRAP, SIGSYS, SIGPIPE, SIGXFSZ, SIGXCPU}) {
        sigaction(s, &dfl, nullptr);
    }
    struct sigaction ign {};
    ign.sa_handler = SIG_IGN;
    for (int s : {SIGINT, SIGTERM, SIGHUP}) sigaction(s, &ign, nullptr);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(kChildWriteFailed);

    // The request becomes stdin, stdout/stderr go to the log, the reply pipe becomes fd 3 (all
    // first copied above 10: the caller may have closed its standard descriptors, and the pipe
    // may be one of them), and every other descriptor is closed: a copy of another load's pipe
    // held here would hide that load's end of file from its parent.
    const int request = fcntl(requestFd, F_DUPFD, 10);
    const int reply = fcntl(replyFd, F_DUPFD, 10);
    const int log = logFd >= 0 ? fcntl(logFd, F_DUPFD, 10) : fcntl(STDERR_FILENO, F_DUPFD, 10);
    if (request < 0 || reply < 0) _exit(kChildWriteFailed);
    if (dup2(request, STDIN_FILENO) < 0 || dup2(reply, 3) < 0) _exit(kChildWriteFailed);
    if (log >= 0) {
        dup2(log, STDOUT_FILENO);
        dup2(log, STDERR_FILENO);
    }
    close_range(4, ~0u, 0);
    lseek(STDIN_FILENO, 0, SEEK_SET);
    const rlimit noCore{0, 0};
    setrlimit(RLIMIT_CORE, &noCore); // a crash here is expected; no core file per corrupt file
    const rlimit fsize{16u << 20, 16u << 20}; // the log is the only file the reader writes
    setrlimit(RLIMIT_FSIZE, &fsize);
    // If the machine runs out of memory anyway, the kernel kills the reader, not the caller.
    const int oom = ::open("/proc/self/oom_score_adj", O_WRONLY | O_CLOEXEC);
    if (oom >= 0) {
        [[maybe_unused]] ssize_t w = ::write(oom, "1000", 4);
        ::close(oom);
    }
    execv(reader, argv);
    _exit(kChildExecFailed);
}

/// Reads all of a descriptor (the request) up to @p limit bytes.
bool readAll(int fd, std::string& out, std::size_t limit) {
    char buf[4096];
    for (;;) {
        const ssize_t k = ::read(fd, buf, sizeof buf);
        if (k < 0) {
            if (errno == EINTR) continue;
            return false;
        }
        if (k == 0) return true;
        if (out.size() + std::size_t(k) > limit) return false;
        out.append(buf, std::size_t(k));
    }
}

// ---------------------------------------------------------------------------------------------
// The parent.

using Clock = std::chrono::steady_clock;

std::string signalText(int sig) {
    switch (sig) {
    case SIGSEGV:
        return "SIGSEGV, segmentation fault";
    case SIGBUS:
        return "SIGBUS, bus error";
    case SIGABRT:
        return "SIGABRT, aborted";
    case SIGFPE:
        return "SIGFPE, arithmetic exception";
    case SIGILL:
        return "SIGILL, illegal instruction";
    case SIGTRAP:
        return "SIGTRAP, trap";
    case SIGSYS:
        return "SIGSYS, bad system call";
    case SIGKILL:
        return "SIGKILL";
    case SIGTERM:
        return "SIGTERM";
    case SIGINT:
        return "SIGINT";
    case SIGHUP:
        return "SIGHUP";
    case SIGPIPE:
        return "SIGPIPE";
    case SIGXFSZ:
        return "SIGXFSZ, file size limit exceeded";
    case SIGXCPU:
        return "SIGXCPU, CPU time limit exceeded";
    default:
        return "signal " + std::to_string(sig) + ", " + strsignal(sig);
    }
}

std::string mib(std::uint64_t bytes) {
    return std::to_string((bytes + (1u << 19)) >> 20) + " MiB";
}

/// The address space this process has mapped now (VmSize), in bytes.
std::uint64_t mappedBytes() {
    std::FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return 0;
    unsigned long long pages = 0;
    if (std::fscanf(f, "%llu", &pages) != 1) pages = 0;
    std::fclose(f);
    return std::uint64_t(pages) * std::uint64_t(sysconf(_SC_PAGESIZE));
}

/// `s` without terminal escape sequences (OpenVDB's log4cplus layout colours its warnings:
/// ESC [ 35 m ... ESC [ 0 m) and with other control characters but newlines made '?'.
std::string withoutEscapes(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
        const unsigned char c = (unsigned char)s[i];
        if (c == 0x1b) {
            // CSI: ESC [ parameters/intermediates (0x20-0x3f) then one final byte (0x40-0x7e);
            // any other escape: ESC and the byte after it
            if (i + 1 < s.size() && s[i + 1] == '[') {
                i += 2;
                while (i < s.size() && (unsigned char)s[i] >= 0x20 && (unsigned char)s[i] < 0x40)
                    ++i;
            } else {
                ++i;
            }
            continue;
        }
        out += c == '\n' || c == '\t' ? char(c) : c < 32 || c == 127 ? '?' : char(c);
    }
    return out;
}

/// The last lines the child wrote to its stdout/stderr (at most ~400 characters, one line,
/// printable), for a crash message. "" when it wrote nothing.
std::string logTail(int logFd) {
    if (logFd < 0) return "";
    struct stat st {};
    if (fstat(logFd, &st) != 0 || st.st_size <= 0) return "";
    const off_t from = std::max<off_t>(0, st.st_size - 400);
    std::string s(std::size_t(st.st_size - from), '\0');
    const ssize_t n = pread(logFd, s.data(), s.size(), from);
    if (n <= 0) return "";
    s.resize(std::size_t(n));
    s = withoutEscapes(s);
    while (!s.empty() && std::isspace((unsigned char)s.back())) s.pop_back();
    for (char& c : s)
        if (c == '\n' || c == '\t') c = ' ';
    return (from > 0 ? "..." : "") + s;
}

/// Copies what the child wrote to stdout/stderr (OpenVDB's warnings) to this process's stderr,
/// as the same load in process would have printed it, but one line at a time prefixed
/// "nimbus: openvdb (<file>): ", without OpenVDB's terminal colours, at most kForwardLines
/// lines of at most kForwardLineChars characters (the child may write up to 16 MB).
void forwardLog(int logFd, const std::string& path) {
    constexpr int kForwardLines = 20;
    constexpr std::size_t kForwardLineChars = 300;
    if (logFd < 0) return;
    struct stat st {};
    if (fstat(logFd, &st) != 0 || st.st_size <= 0) return;
    std::string text(std::size_t(std::min<off_t>(st.st_size, 64 << 10)), '\0');
    const ssize_t n = pread(logFd, text.data(), text.size(), 0);
    if (n <= 0) return;
    text.resize(std::size_t(n));
    text = withoutEscapes(text);
    std::string out;
    int lines = 0, more = 0;
    std::size_t at = 0;
    while (at < text.size()) {
        std::size_t end = text.find('\n', at);
        if (end == std::string::npos) end = text.size();
        std::string line = text.substr(at, end - at);
        at = end + 1;
        const std::size_t b = line.find_first_not_of(" \t");
        if (b == std::string::npos) continue;
        line = line.substr(b);
        while (!line.empty() && std::isspace((unsigned char)line.back())) line.pop_back();
        if (lines == kForwardLines) {
            ++more;
            continue;
        }
        if (line.size() > kForwardLineChars)
            line = line.substr(0, kForwardLineChars) + "... (" +
                   std::to_string(line.size() - kForwardLineChars) + " more characters)";
        out += "nimbus: openvdb (" + path + "): " + line + "\n";
        ++lines;
    }
    if (more > 0 || st.st_size > n)
        out += "nimbus: openvdb (" + path + "): ... " +
               (more > 0 ? std::to_string(more) + " more lines" : std::string("more")) +
               (st.st_size > n ? " (" + std::to_string(st.st_size) + " bytes in all)" : "") + "\n";
    writeAll(STDERR_FILENO, out.data(), out.size());
}

/// The child process as the parent sees it: reads its reply with a deadline, reaps it, and
/// kills it (SIGKILL) if it is still running when this object goes away.
class Child {
  public:
    Child(pid_t pid, int replyFd, Clock::time_point deadline)
        : pid_(pid), fd_(replyFd), deadline_(deadline) {}
    ~Child() {
        if (!reaped_) {
            ::kill(pid_, SIGKILL);
            while (waitpid(pid_, &status_, 0) < 0 && errno == EINTR) {
            }
        }
        ::close(fd_);
    }
    Child(const Child&) = delete;
    Child& operator=(const Child&) = delete;

    enum class Read { Ok, End, Timeout };

    /// Reads exactly @p n bytes of the reply. End: the pipe closed, or the child ended, first.
    Read read(void* dst, std::uint64_t n) {
        char* p = static_cast<char*>(dst);
        while (n > 0) {
            const auto left =
                std::chrono::duration_cast<std::chrono::milliseconds>(deadline_ - Clock::now())
                    .count();
            if (left <= 0) return Read::Timeout;
            // Poll in slices: another thread's fork can hold a copy of the pipe's write end, so
            // the end of the child is not always an end of file; check it between slices.
            pollfd pfd{fd_, POLLIN, 0};
            const int r = ::poll(&pfd, 1, reaped_ ? 0 : int(std::min<long long>(left, 100)));
            if (r < 0) {
                if (errno == EINTR) continue;
                return Read::End;
            }
            if (r == 0) {
                if (reaped_) return Read::End; // it ended and nothing more is in the pipe
                reap(false);
                continue;
            }
            const ssize_t k = ::read(fd_, p, std::size_t(std::min<std::uint64_t>(n, 1u << 20)));
            if (k < 0) {
                if (errno == EINTR || errno == EAGAIN) continue;
                return Read::End;
            }
            if (k == 0) return Read::End;
            p += k;
            n -= std::uint64_t(k);
        }
        return Read::Ok;
    }

    /// Waits for the child to end, until the deadline or @p until if that is earlier. False if
    /// it is still running.
    bool wait(Clock::time_point until = Clock::time_point::max()) {
        const Clock::time_point deadline = std::min(deadline_, until);
#ifdef SYS_pidfd_open
        // A pidfd becomes readable when the process ends: no polling interval to wait out.
        const int pidfd = int(::syscall(SYS_pidfd_open, pid_, 0));
        if (pidfd >= 0) {
            while (!reap(false)) {
                const auto left =
                    std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now())
                        .count();
                if (left <= 0) break;
                pollfd pfd{pidfd, POLLIN, 0};
                ::poll(&pfd, 1, int(std::min<long long>(left, 1000)));
            }
            ::close(pidfd);
            return reaped_;
        }
#endif
        for (int sleepUs = 100; !reaped_; sleepUs = std::min(sleepUs * 2, 20000)) {
            if (reap(false)) break;
            if (Clock::now() >= deadline) return false;
            ::usleep(useconds_t(sleepUs));
        }
        return true;
    }

    /// Kills the child (the time limit) and reaps it.
    void kill() {
        if (reaped_) return;
        ::kill(pid_, SIGKILL);
        reap(true);
    }

    bool reaped() const {
        return reaped_;
    }
    /// waitpid status; statusKnown() is false if someone else reaped it (SIGCHLD ignored).
    int status() const {
        return status_;
    }
    bool statusKnown() const {
        return statusKnown_;
    }

  private:
    bool reap(bool block) {
        for (;;) {
            const pid_t r = waitpid(pid_, &status_, block ? 0 : WNOHANG);
            if (r == pid_) {
                reaped_ = statusKnown_ = true;
                return true;
            }
            if (r == 0) return false;
            if (errno == EINTR) continue;
            reaped_ = true; // ECHILD: the caller ignores SIGCHLD, or reaped it itself
            statusKnown_ = false;
            return true;
        }
    }

    pid_t pid_;
    int fd_;
    Clock::time_point deadline_;
    bool reaped_ = false;
    bool statusKnown_ = false;
    int status_ = 0;
};

/// Closes a file descriptor when it goes out of scope.
struct Fd {
    int fd = -1;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

std::string secondsText(double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", s);
    return buf;
}

std::mutex gReaderMutex;
std::string gReaderForTests; // setReaderForTests

/// The folder of the executable or shared object this code was linked into, where the reader
/// ships beside it (its own address: a function of internal linkage, which no other object's
/// copy can stand in for).
std::string ownFolder() {
    return io::objectFolder(reinterpret_cast<const void*>(&ownFolder));
}

} // namespace

std::string findReader(std::string& tried) {
    std::vector<std::string> candidates;
    {
        std::lock_guard<std::mutex> lock(gReaderMutex);
        if (!gReaderForTests.empty()) candidates.push_back(gReaderForTests);
    }
    if (candidates.empty()) {
        if (const char* env = std::getenv("NIMBUS_VDB_READER"); env && *env) {
            candidates.push_back(env); // named: nothing else is tried
        } else {
            const std::string folder = ownFolder();
            if (!folder.empty()) candidates.push_back(folder + "/" + kReaderExecutable);
#ifdef NIMBUS_VDB_READER_BUILT
            candidates.push_back(NIMBUS_VDB_READER_BUILT); // the build tree's (tests, hosts)
#endif
        }
    }
    tried.clear();
    for (const std::string& c : candidates) {
        if (::access(c.c_str(), X_OK) == 0) return c;
        tried += (tried.empty() ? "" : ", ") + c + " (" + std::strerror(errno) + ")";
    }
    return {};
}

void setReaderForTests(const std::string& path) {
    std::lock_guard<std::mutex> lock(gReaderMutex);
    gReaderForTests = path;
}

IsolatedReply runIsolated(const VdbLoadOptions& options, const std::string& request,
                          std::uint64_t minBulkBytes, const char* bulkName) {
    const std::string ctx = options.path + ": grid \"" + options.gridName + "\": ";
    if (!(options.timeoutSeconds > 0.0) || !std::isfinite(options.timeoutSeconds)) {
        throw VdbError(ctx +
                       "the time limit of the reading process must be a positive number "
                       "of seconds (got " +
                       secondsText(options.timeoutSeconds) + ")");
    }
    std::string tried;
    const std::string reader = findReader(tried);
    if (reader.empty()) {
        throw VdbError(ctx + "cannot find the program that reads VDB files, " + kReaderExecutable +
                       " (tried " + tried +
                       "): it is built beside the nimbus command and libnimbus.so; name it with "
                       "NIMBUS_VDB_READER=path, or read trusted files in process "
                       "(VdbLoadOptions::isolate = false, NIMBUS_VDB_ISOLATE=0)");
    }
    const std::uint64_t budget = memoryBudget(options);
    const std::string memoryNote = "the reading process may map " + mib(budget) +
                                   " beyond what it maps at its start "
                                   "(VdbLoadOptions::memoryLimitBytes, "
                                   "NIMBUS_VDB_MEMORY_LIMIT for the nimbus command)";

    // The request, in a memory file that becomes the reader's stdin.
    Fd requestFile{::memfd_create("nimbus-vdb-request", MFD_CLOEXEC)};
    if (requestFile.fd < 0 || !writeAll(requestFile.fd, request.data(), request.size())) {
        throw VdbError(ctx +
                       "cannot write the request for the reading process: " + std::strerror(errno));
    }
    Fd log{::memfd_create("nimbus-vdb-reader-log", MFD_CLOEXEC)}; // -1: the reader's output
                                                                  // goes to our stderr
    const pid_t parent = getpid();
    const double timeout = std::min(options.timeoutSeconds, 1e7);
    const Clock::time_point deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                          std::chrono::duration<double>(timeout));
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) {
        throw VdbError(ctx +
                       "cannot create a pipe for the reading process: " + std::strerror(errno));
    }
    // Prepared before the fork: the child only makes system calls (execReader).
    const std::string arg0 = kReaderExecutable;
    char* const argv[] = {const_cast<char*>(arg0.c_str()), nullptr};
    const pid_t pid = ::fork();
    if (pid == 0) execReader(reader.c_str(), argv, requestFile.fd, fds[1], log.fd, parent);
    ::close(fds[1]);
    if (pid < 0) {
        const int err = errno;
        ::close(fds[0]);
        throw VdbError(ctx +
                       "cannot start the process that reads the grid (fork: " + std::strerror(err) +
                       "); reading in process instead is possible for trusted files "
                       "(VdbLoadOptions::isolate = false, NIMBUS_VDB_ISOLATE=0)");
    }
    Child child(pid, fds[0], deadline);
    // Read the reply; whatever is missing or wrong is judged after the child's end.
    ReplyHeader header{};
    std::string meta;
    nanovdb::HostBuffer grid;
    std::string invalid; // what is wrong with the reply ("" = nothing)
    Child::Read r = child.read(&header, sizeof header);
    if (r == Child::Read::Ok) {
        const auto kind = ReplyKind(header.kind);
        if (std::memcmp(header.magic, kReplyMagic, sizeof kReplyMagic) != 0) {
            invalid = "it does not start with the reply marker";
        } else if (kind != ReplyKind::Loaded && kind != ReplyKind::VdbError &&
                   kind != ReplyKind::OtherError) {
            invalid = "unknown reply kind " + std::to_string(header.kind);
        } else if (header.metaBytes > kMaxMetaBytes) {
            invalid = "it announces " + std::to_string(header.metaBytes) + " bytes of metadata";
        } else if (kind != ReplyKind::Loaded
                       ? header.gridBytes != 0
                       : header.gridBytes < std::max<std::uint64_t>(minBulkBytes, 1) ||
                             header.gridBytes > budget) {
            invalid = std::string("it announces ") + bulkName + " of " +
                      std::to_string(header.gridBytes) + " bytes";
        }
        if (invalid.empty()) {
            meta.resize(std::size_t(header.metaBytes));
            r = child.read(meta.data(), meta.size());
        }
        if (invalid.empty() && r == Child::Read::Ok && header.gridBytes > 0) {
            try {
                grid = nanovdb::HostBuffer::create(header.gridBytes);
            } catch (const std::bad_alloc&) {
                throw VdbError(ctx + "out of memory receiving " + bulkName + " (" +
                               mib(header.gridBytes) + ") from the reading process");
            }
            r = child.read(grid.data(), header.gridBytes);
        }
        if (invalid.empty() && r == Child::Read::Ok) {
            char end[sizeof kReplyEnd];
            r = child.read(end, sizeof end);
            if (r == Child::Read::Ok && std::memcmp(end, kReplyEnd, sizeof end) != 0)
                invalid = "it does not end with the end marker";
        }
    }
    if (r == Child::Read::End && invalid.empty()) invalid = "it is incomplete (short)";
    if (r == Child::Read::Ok && !invalid.empty() &&
        !child.wait(Clock::now() + std::chrono::seconds(1))) {
        // A garbled reply from a child that goes on (perhaps blocked writing the rest): stop it.
        child.kill();
        throw VdbError(ctx + "the process reading the grid sent an invalid reply: " + invalid +
                       " (it was stopped)");
    }
    if (r == Child::Read::Timeout || !child.wait()) {
        child.kill();
        throw VdbError(ctx + "the OpenVDB reader did not finish within " + secondsText(timeout) +
                       " s and was stopped (a corrupted file that makes it loop, or a grid too "
                       "large to read in that time); raise the limit with "
                       "VdbLoadOptions::timeoutSeconds (NIMBUS_VDB_TIMEOUT=seconds for the "
                       "nimbus command) if the file is sound");
    }

    const int status = child.status();
    std::string tail = logTail(log.fd);
    if (!tail.empty()) tail = "; its last output: \"" + tail + "\"";
    if (child.statusKnown() && WIFSIGNALED(status)) {
        const int sig = WTERMSIG(status);
        switch (sig) {
        case SIGSEGV:
        case SIGBUS:
        case SIGABRT:
        case SIGFPE:
        case SIGILL:
        case SIGTRAP:
        case SIGSYS:
            throw VdbError(ctx + "the OpenVDB reader crashed (" + signalText(sig) +
                           ") while reading the grid: the file is corrupt" +
                           (sig == SIGBUS ? " (or it was truncated while it was read)" : "") +
                           tail);
        case SIGKILL:
            throw VdbError(ctx +
                           "the process reading the grid was killed (SIGKILL): by the "
                           "kernel's out-of-memory killer (a grid too large for this "
                           "machine, or a corrupted file that claims one) or by another "
                           "process" +
                           tail);
        case SIGXFSZ:
            throw VdbError(ctx +
                           "the process reading the grid wrote more than 16 MiB of "
                           "messages and was stopped (SIGXFSZ): the file is corrupt?" +
                           tail);
        default:
            throw VdbError(ctx + "the process reading the grid was ended by " + signalText(sig) +
                           tail);
        }
    }
    if (child.statusKnown() && WIFEXITED(status) && WEXITSTATUS(status) != 0) {
        const int code = WEXITSTATUS(status);
        throw VdbError(ctx + "the process reading the grid exited with status " +
                       std::to_string(code) +
                       (code == kChildWriteFailed  ? " (it could not send its result)"
                        : code == kChildExecFailed ? " (" + reader + " could not be run)"
                        : code == kChildBadRequest
                            ? " (" + reader + " did not understand the request: not this build's?)"
                            : " (something in the OpenVDB reader called exit())") +
                       tail);
    }
    if (!invalid.empty()) {
        throw VdbError(ctx + "the process reading the grid sent an invalid reply: " + invalid +
                       tail);
    }

    forwardLog(log.fd, options.path);
    switch (ReplyKind(header.kind)) {
    case ReplyKind::VdbError:
        if (meta.find("out of memory") != std::string::npos)
            throw VdbError(meta + "; " + memoryNote);
        throw VdbError(meta); // a refusal or a read error: exactly as in process
    case ReplyKind::OtherError:
        throw VdbError(ctx + "OpenVDB could not read it: " + meta +
                       (meta == "out of memory" ? "; " + memoryNote : std::string()) +
                       " (a corrupted file?)");
    case ReplyKind::Loaded:
        break;
    }

    return IsolatedReply{std::move(meta), std::move(grid)};
}

std::string gridRequest(const VdbLoadOptions& options) {
    Encoder e;
    encodeRead(e, RequestKind::Grid, options);
    return std::move(e.bytes);
}

std::string velocityRequest(const VelocityLoadOptions& options) {
    Encoder e;
    encodeRead(e, RequestKind::Velocity, options.read);
    e.pod(options.layout);
    e.pod(options.scale);
    e.pod(options.maxCells);
    e.pod(options.extrapolate);
    return std::move(e.bytes);
}

int readerMain() {
    constexpr std::size_t kMaxRequestBytes = 1u << 20; // a path and a grid name: far less
    std::string request;
    if (!readAll(STDIN_FILENO, request, kMaxRequestBytes) ||
        request.compare(0, sizeof kRequestMagic, kRequestMagic, sizeof kRequestMagic) != 0) {
        std::fprintf(stderr,
                     "%s: reads one VDB grid for Nimbus, which runs it: not to be run by hand\n",
                     kReaderExecutable);
        return kChildBadRequest;
    }
    const std::string body = request.substr(sizeof kRequestMagic);
    Decoder d(body);
    const auto kind = RequestKind(d.pod<std::uint32_t>());
    VelocityLoadOptions velocity;
    VdbLoadOptions& o = velocity.read;
    o.path = d.str();
    o.gridName = d.str();
    o.levelsetToFog = d.pod<bool>();
    const auto budget = d.pod<std::uint64_t>();
    o.isolate = false;
    if (kind == RequestKind::Velocity) {
        velocity.layout = d.pod<VelocityLayout>();
        velocity.scale = d.pod<float>();
        velocity.maxCells = d.pod<std::uint64_t>();
        velocity.extrapolate = d.pod<bool>();
    }
    if (!d.complete() || (kind != RequestKind::Grid && kind != RequestKind::Velocity))
        return kChildBadRequest;
    // The address-space limit: the budget beyond what this process maps now (its libraries,
    // before any thread or grid). An allocation past it fails: std::bad_alloc, "out of memory".
    const std::uint64_t mapped = mappedBytes();
    rlimit as{};
    if (getrlimit(RLIMIT_AS, &as) == 0) {
        const rlim_t want = mapped + budget < mapped ? RLIM_INFINITY : rlim_t(mapped + budget);
        as.rlim_cur = std::min(as.rlim_cur, want);
        setrlimit(RLIMIT_AS, &as);
    }
    bool written = false;
    constexpr int replyFd = 3;
    try {
        ChildReply reply =
            kind == RequestKind::Grid ? gridChildReply(o) : velocityChildReply(velocity);
        written = writeReply(replyFd, ReplyKind::Loaded, reply.meta, reply.bulk, reply.bulkBytes);
    } catch (const VdbError& e) {
        written = writeReply(replyFd, ReplyKind::VdbError, e.what());
    } catch (const std::bad_alloc&) {
        written = writeReply(replyFd, ReplyKind::OtherError, "out of memory");
    } catch (const std::exception& e) {
        written = writeReply(replyFd, ReplyKind::OtherError, e.what());
    } catch (...) {
        written = writeReply(replyFd, ReplyKind::OtherError, "unknown exception");
    }
    // No static destructors: OpenVDB's and TBB's are not needed for a process that ends here.
    std::fflush(stdout);
    std::fflush(stderr);
    ::_exit(written ? 0 : kChildWriteFailed);
}

ChildReply gridChildReply(const VdbLoadOptions& options) {
    auto g = std::make_shared<LoadedVdbGrid>(loadVdbGridInProcess(options, /*checkGrid=*/false));
    const nanovdb::HostBuffer& buffer = g->handle.buffer();
    return ChildReply{encodeMeta(*g), g, buffer.data(), buffer.size()};
}

LoadedVdbGrid loadVdbGridIsolated(const VdbLoadOptions& options) {
    IsolatedReply reply =
        runIsolated(options, gridRequest(options), sizeof(nanovdb::GridData), "a grid");
    LoadedVdbGrid out;
    if (!decodeMeta(reply.meta, out)) {
        throw VdbError(options.path + ": grid \"" + options.gridName +
                       "\": the process reading the grid sent an invalid reply: its metadata "
                       "does not decode");
    }
    out.handle = nanovdb::GridHandle<nanovdb::HostBuffer>(std::move(reply.bulk));
    // Checked here, not in the child: what arrives is what the caller will traverse.
    const std::string problem = checkNanoGrid(out);
    if (!problem.empty()) throw VdbError(invalidGridMessage(out, problem));
    return out;
}

// ---------------------------------------------------------------------------------------------
// checkNanoGrid

namespace {

using Leaf = nanovdb::NanoLeaf<float>;
using Lower = nanovdb::NanoLower<float>;
using Upper = nanovdb::NanoUpper<float>;
using Root = nanovdb::NanoRoot<float>;

bool sound(float v) {
    return std::isfinite(v) && v >= 0.0f;
}

/// The nodes of one level: a contiguous array inside the buffer.
template <class NodeT> struct NodeArray {
    const std::uint8_t* first = nullptr;
    std::uint64_t count = 0;
    /// Whether p is exactly the address of one of the nodes.
    bool holds(const void* p) const {
        const auto* b = static_cast<const std::uint8_t*>(p);
        if (count == 0 || b < first) return false;
        const std::uint64_t off = std::uint64_t(b - first);
        return off % sizeof(NodeT) == 0 && off / sizeof(NodeT) < count;
    }
    const NodeT& operator[](std::uint64_t i) const {
        return *reinterpret_cast<const NodeT*>(first + i * sizeof(NodeT));
    }
};

std::string at(const char* what, std::uint64_t i) {
    return std::string(what) + " #" + std::to_string(i);
}

/// The tiles and children of an internal node.
template <class NodeT, class ChildT>
std::string checkInternal(const NodeT& node, const NodeArray<ChildT>& children, const char* what,
                          std::uint64_t index) {
    const auto* data = node.data();
    if (!std::isfinite(data->mMinimum) || !std::isfinite(data->mMaximum))
        return at(what, index) + " has non-finite statistics";
    for (std::uint32_t n = 0; n < NodeT::SIZE; ++n) {
        if (data->mChildMask.isOn(n)) {
            if (!children.holds(data->getChild(n)))
                return at(what, index) + " has a child offset outside the grid";
        } else if (!sound(data->mTable[n].value)) {
            return at(what, index) + " has a tile value that is not a finite density";
        }
    }
    return "";
}

} // namespace

std::string invalidGridMessage(const LoadedVdbGrid& g, const std::string& problem) {
    return g.path + ": grid \"" + g.gridName + "\": the converted NanoVDB grid is invalid (" +
           problem + "): the file is corrupt (file format version " +
           std::to_string(g.fileVersion) + ", written by OpenVDB " + g.libraryVersion + ")";
}

std::string checkNanoGrid(const LoadedVdbGrid& g) {
    const nanovdb::HostBuffer& buffer = g.handle.buffer();
    const std::uint8_t* base = buffer.data();
    const std::uint64_t size = buffer.size();
    using GridT = nanovdb::NanoGrid<float>;
    using TreeT = nanovdb::NanoTree<float>;
    if (!base || size < sizeof(GridT) + sizeof(TreeT) + sizeof(Root))
        return "a buffer of " + std::to_string(size) + " bytes is too small for a grid";
    if (reinterpret_cast<std::uintptr_t>(base) % NANOVDB_DATA_ALIGNMENT != 0)
        return "the buffer is not aligned";
    const auto* gd = reinterpret_cast<const nanovdb::GridData*>(base);
    if (gd->mMagic != NANOVDB_MAGIC_NUMBER) return "no NanoVDB magic number";
    if (gd->mGridType != nanovdb::GridType::Float) return "not a float grid";
    if (gd->mGridCount != 1 || gd->mGridIndex != 0) return "not exactly one grid";
    if (gd->mGridSize != size)
        return "it claims " + std::to_string(gd->mGridSize) + " bytes in a buffer of " +
               std::to_string(size);
    if (gd->mBlindMetadataCount != 0) return "unexpected blind data";
    const nanovdb::Map& map = gd->mMap;
    for (float v : map.mMatF)
        if (!std::isfinite(v)) return "a non-finite transform";
    for (float v : map.mInvMatF)
        if (!std::isfinite(v)) return "a non-finite transform";
    for (float v : map.mVecF)
        if (!std::isfinite(v)) return "a non-finite transform";
    for (double v : map.mMatD)
        if (!std::isfinite(v)) return "a non-finite transform";
    for (double v : map.mInvMatD)
        if (!std::isfinite(v)) return "a non-finite transform";
    for (double v : map.mVecD)
        if (!std::isfinite(v)) return "a non-finite transform";

    const auto* grid = reinterpret_cast<const GridT*>(base);
    const TreeT& tree = grid->tree();
    const auto* td = reinterpret_cast<const nanovdb::TreeData<3>*>(&tree);
    const std::uint64_t treeOff = std::uint64_t(reinterpret_cast<const std::uint8_t*>(td) - base);
    if (treeOff + sizeof(TreeT) > size) return "the tree lies outside the buffer";

    // Node arrays: aligned and inside the buffer.
    auto array = [&](int level, std::uint64_t nodeSize, std::uint64_t count,
                     const std::uint8_t*& first) -> std::string {
        first = nullptr;
        if (count == 0) return "";
        const std::uint64_t off = td->mNodeOffset[level];
        if (off % NANOVDB_DATA_ALIGNMENT != 0 || off > size || treeOff + off > size ||
            count > (size - treeOff - off) / nodeSize)
            return "the nodes of level " + std::to_string(level) + " lie outside the buffer";
        first = base + treeOff + off;
        return "";
    };
    NodeArray<Leaf> leaves;
    NodeArray<Lower> lowers;
    NodeArray<Upper> uppers;
    leaves.count = td->mNodeCount[0];
    lowers.count = td->mNodeCount[1];
    uppers.count = td->mNodeCount[2];
    for (const std::string& e : {array(0, sizeof(Leaf), leaves.count, leaves.first),
                                 array(1, sizeof(Lower), lowers.count, lowers.first),
                                 array(2, sizeof(Upper), uppers.count, uppers.first)}) {
        if (!e.empty()) return e;
    }
    const std::uint64_t rootOff = td->mNodeOffset[3];
    if (rootOff % NANOVDB_DATA_ALIGNMENT != 0 || rootOff > size || treeOff + rootOff > size ||
        size - treeOff - rootOff < sizeof(Root))
        return "the root node lies outside the buffer";
    const auto* root = reinterpret_cast<const nanovdb::RootData<Upper>*>(base + treeOff + rootOff);
    using Tile = nanovdb::RootData<Upper>::Tile;
    if (root->mTableSize > (size - treeOff - rootOff - sizeof(Root)) / sizeof(Tile))
        return "the root's tiles lie outside the buffer";
    if (!std::isfinite(root->mBackground) || root->mBackground != 0.0f)
        return "the background is not 0";
    if (!std::isfinite(root->mMinimum) || !std::isfinite(root->mMaximum))
        return "the root has non-finite statistics";

    if (leaves.count != g.leafCount)
        return std::to_string(leaves.count) + " leaves where the tree had " +
               std::to_string(g.leafCount);
    if (td->mVoxelCount != g.activeVoxelCount)
        return std::to_string(td->mVoxelCount) + " active voxels where the tree had " +
               std::to_string(g.activeVoxelCount);

    for (std::uint32_t i = 0; i < root->mTableSize; ++i) {
        const Tile* t = root->tile(i);
        if (t->isChild()) {
            if (!uppers.holds(root->getChild(t))) return "a root tile points outside the grid";
        } else if (!sound(t->value)) {
            return "a root tile value is not a finite density";
        }
    }
    for (std::uint64_t i = 0; i < uppers.count; ++i) {
        std::string e = checkInternal(uppers[i], lowers, "upper internal node", i);
        if (!e.empty()) return e;
    }
    for (std::uint64_t i = 0; i < lowers.count; ++i) {
        std::string e = checkInternal(lowers[i], leaves, "lower internal node", i);
        if (!e.empty()) return e;
    }
    for (std::uint64_t i = 0; i < leaves.count; ++i) {
        const auto* d = leaves[i].data();
        if (!std::isfinite(d->mMinimum) || !std::isfinite(d->mMaximum))
            return at("leaf", i) + " has non-finite statistics";
        for (std::uint32_t n = 0; n < Leaf::SIZE; ++n) {
            const float v = d->mValues[n];
            if (!sound(v)) return at("leaf", i) + " holds a value that is not a finite density";
            if (v > d->mMaximum && d->mValueMask.isOn(n))
                return at("leaf", i) + " holds a value above its maximum";
        }
    }
    return "";
}

} // namespace nimbus::vdb::detail
