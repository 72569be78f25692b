/// @file vdb_isolate.h
/// @brief Internal to plugin/vdb (and its tests): the two ways loadVdbGrid() reads a grid, the
///        check of a finished NanoVDB grid, and a test hook for the child process.
///
/// loadVdbGrid() dispatches on VdbLoadOptions::isolate:
///  - loadVdbGridInProcess() reads and converts the grid in the calling process (vdb_reader.cpp,
///    the only translation unit that includes OpenVDB's reading headers);
///  - loadVdbGridIsolated() forks a child process that runs loadVdbGridInProcess() and sends the
///    result back through a pipe (vdb_isolate.cpp). Whatever happens inside OpenVDB's reader
///    (a crash on corrupted tree data, an endless loop, a giant allocation) then ends the child,
///    not the caller, and becomes a VdbError naming the file, the grid and what happened.
#pragma once

#include <cstdint>
#include <cstring>
#include <type_traits>
#include <functional>
#include <memory>
#include <string>

#include "plugin/vdb/vdb_reader.h"

namespace nimbus::vdb::detail {

/// Held (shared) by this thread while it is inside OpenVDB in this process: every entry point
/// of plugin/vdb that calls OpenVDB in process takes one. The fork of a reading process
/// (runIsolated) takes the same lock exclusively, so no thread of the caller is inside OpenVDB
/// holding one of its locks (its grid registry's, say) when the child is forked: the child's copy
/// of such a lock would stay locked, and the child would wait for it until its time limit.
/// Nested sections on one thread take the lock once; in a forked child the sections are free (it
/// has one thread). Another library's use of OpenVDB in the same process is not covered.
class OpenVdbSection {
  public:
    OpenVdbSection();
    ~OpenVdbSection();
    OpenVdbSection(const OpenVdbSection&) = delete;
    OpenVdbSection& operator=(const OpenVdbSection&) = delete;

  private:
    bool locked_ = false;
};

/// Reads and converts in this process (no fork), then checks the NanoVDB grid with
/// checkNanoGrid() unless @p checkGrid is false (the isolated child: its parent checks what it
/// receives). @throws VdbError as loadVdbGrid().
LoadedVdbGrid loadVdbGridInProcess(const VdbLoadOptions& options, bool checkGrid = true);

/// The VdbError message for a grid that checkNanoGrid() rejected: "<path>: grid "<name>": the
/// converted NanoVDB grid is invalid (<problem>): the file is corrupt".
std::string invalidGridMessage(const LoadedVdbGrid& g, const std::string& problem);

/// Reads and converts in a forked child process. @throws VdbError as loadVdbGrid(), plus the
/// failures of the child itself (a signal, an abnormal exit, the time limit, an invalid reply).
LoadedVdbGrid loadVdbGridIsolated(const VdbLoadOptions& options);

/// Byte records for the replies of child processes (runIsolated): plain values and strings.
class Encoder {
  public:
    template <class T> void pod(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes.append(reinterpret_cast<const char*>(&v), sizeof v);
    }
    void str(const std::string& s) {
        pod(std::uint64_t(s.size()));
        bytes += s;
    }
    std::string bytes;
};

class Decoder {
  public:
    explicit Decoder(const std::string& b) : p_(b.data()), end_(b.data() + b.size()) {}
    template <class T> T pod() {
        static_assert(std::is_trivially_copyable_v<T>);
        T v{};
        if (std::size_t(end_ - p_) < sizeof v) {
            ok_ = false;
            return v;
        }
        std::memcpy(&v, p_, sizeof v);
        p_ += sizeof v;
        return v;
    }
    std::string str() {
        const auto n = pod<std::uint64_t>();
        if (!ok_ || n > std::uint64_t(end_ - p_)) {
            ok_ = false;
            return {};
        }
        std::string s(p_, std::size_t(n));
        p_ += n;
        return s;
    }
    /// Every byte read, none missing, none left over.
    bool complete() const { return ok_ && p_ == end_; }

  private:
    const char* p_;
    const char* end_;
    bool ok_ = true;
};

/// What the work of a child process returns (runIsolated): its metadata bytes and one bulk
/// buffer (`bulkBytes` bytes at `bulk`, kept alive by `owner`).
struct ChildReply {
    std::string meta;
    std::shared_ptr<const void> owner;
    const void* bulk = nullptr;
    std::uint64_t bulkBytes = 0;
};

/// What runIsolated() received: the child's metadata and its bulk buffer, unchecked.
struct IsolatedReply {
    std::string meta;
    nanovdb::HostBuffer bulk;
};

/// The machinery of loadVdbGridIsolated() for any reader: forks a child process limited as
/// "Isolation" in vdb_reader.h says (address space, no core dumps, OOM score, time limit of
/// options.timeoutSeconds, captured stderr), runs @p work there inside a one-thread TBB arena and
/// sends its reply back. A VdbError thrown by @p work reaches the caller with its message; a
/// crash, a hang, an exhausted memory limit or a garbled reply becomes a VdbError that starts
/// with `<options.path>: grid "<options.gridName>": `. A reply whose bulk buffer is smaller than
/// @p minBulkBytes (at least 1) or larger than the memory limit is refused; @p bulkName names
/// the buffer in messages ("a grid"). The caller decodes and checks what it receives.
IsolatedReply runIsolated(const VdbLoadOptions& options, const std::function<ChildReply()>& work,
                          std::uint64_t minBulkBytes, const char* bulkName);

/// Checks that @p g.handle holds one well-formed float NanoVDB grid that is safe to traverse:
/// its header, every node offset inside the buffer and pointing at a node of the right level,
/// a finite transform, finite non-negative values and finite node statistics, and node and
/// voxel counts that agree with @p g. Returns "" when it is valid, otherwise what is wrong.
/// Linear in the size of the grid (about 1 ms per 10 MB).
std::string checkNanoGrid(const LoadedVdbGrid& g);

/// Counts one read in vdbReadCount()/vdbRecentReads() (the velocity reader uses it too).
void recordVdbRead(const std::string& path, const std::string& gridName, int gridsRead);

/// openvdb::initialize(), then OpenVDB's log4cplus appender replaced by one that writes to
/// stderr (OpenVDB's wrote to stdout) without terminal colours (plugin/vdb/vdb_logging.cpp):
/// its warnings read " WARN: ..." in a log, in process as in the reading child. Idempotent and
/// thread-safe; every reader calls it.
void initializeOpenVdb();

/// Test hook: when set, the child process calls it once it has begun (its TBB arena running, the
/// parent told), before it reads anything (tests use it to simulate a crash, a hang, an abnormal
/// exit or a garbled reply). Not thread-safe: set it only while no isolated load runs. nullptr
/// (the default) disables it.
using IsolatedChildHook = void (*)(const VdbLoadOptions& options, int replyFd);
void setIsolatedChildHookForTests(IsolatedChildHook hook);
/// Test hook: called in the child before its start (before its TBB arena): a hook that waits
/// here stands for a child stuck on a lock it inherited (VdbLoadOptions::startSeconds).
void setIsolatedStartHookForTests(IsolatedChildHook hook);

} // namespace nimbus::vdb::detail
