/// @file vdb_isolate.h
/// @brief Internal to plugin/vdb (and its tests): the two ways loadVdbGrid() reads a grid, the
///        reader executable's body, and the check of a finished NanoVDB grid.
///
/// loadVdbGrid() dispatches on VdbLoadOptions::isolate:
///  - loadVdbGridInProcess() reads and converts the grid in the calling process (vdb_reader.cpp,
///    the only translation unit that includes OpenVDB's reading headers);
///  - loadVdbGridIsolated() runs the reader executable, nimbus-vdb-reader (a fork and an exec:
///    the child starts as a new program, with none of the caller's threads, locks or TBB state),
///    which runs loadVdbGridInProcess() and sends the result back through a pipe
///    (vdb_isolate.cpp). Whatever happens inside OpenVDB's reader (a crash on corrupted tree
///    data, an endless loop, a giant allocation) then ends the child, not the caller, and becomes
///    a VdbError naming the file, the grid and what happened.
#pragma once

#include <cstdint>
#include <cstring>
#include <type_traits>
#include <memory>
#include <string>

#include "plugin/vdb/vdb_reader.h"

namespace nimbus::vdb {
struct VelocityLoadOptions; // vdb_velocity.h
} // namespace nimbus::vdb

namespace nimbus::vdb::detail {

/// Reads and converts in this process (no fork), then checks the NanoVDB grid with
/// checkNanoGrid() unless @p checkGrid is false (the isolated child: its parent checks what it
/// receives). @throws VdbError as loadVdbGrid().
LoadedVdbGrid loadVdbGridInProcess(const VdbLoadOptions& options, bool checkGrid = true);

/// The VdbError message for a grid that checkNanoGrid() rejected: "<path>: grid "<name>": the
/// converted NanoVDB grid is invalid (<problem>): the file is corrupt".
std::string invalidGridMessage(const LoadedVdbGrid& g, const std::string& problem);

/// Reads and converts in the reader process. @throws VdbError as loadVdbGrid(), plus the
/// failures of the child itself (a signal, an abnormal exit, the time limit, an invalid reply,
/// a reader executable that cannot be found or run).
LoadedVdbGrid loadVdbGridIsolated(const VdbLoadOptions& options);

/// The reader executable's file name. It is looked for (findReader) where NIMBUS_VDB_READER
/// names it, else beside the executable or shared object this code is linked into (the nimbus
/// command, libnimbus.so), else where the build tree put it.
inline constexpr const char* kReaderExecutable = "nimbus-vdb-reader";

/// The reader executable to run: the first candidate above that is executable, or "" with
/// @p tried listing each candidate and why it was not.
std::string findReader(std::string& tried);

/// Test hook: run this executable as the reader instead ("" = look for it as findReader says).
/// Tests run a reader that crashes, hangs or garbles its reply (tests/vdb_reader_for_tests.cpp).
void setReaderForTests(const std::string& path);

/// The reader executable's body (plugin/vdb/reader_main.cpp calls it): reads the request on
/// stdin (what the caller encoded with gridRequest or velocityRequest), reads the grid in process
/// and writes the reply on descriptor 3. Returns or exits with 0 when a reply was written (a
/// VdbError is a reply), 101 when the pipe broke, 102 when the request did not decode.
int readerMain();

/// The requests runIsolated sends: a density grid, a velocity grid.
std::string gridRequest(const VdbLoadOptions& options);
std::string velocityRequest(const VelocityLoadOptions& options);

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

/// What the reader sends back: its metadata bytes and one bulk buffer (`bulkBytes` bytes at
/// `bulk`, kept alive by `owner`).
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
/// options.timeoutSeconds, captured stderr) that execs the reader executable with @p request on
/// its stdin, and receives its reply. A VdbError of the reader reaches the caller with its
/// message; a crash, a hang, an exhausted memory limit or a garbled reply becomes a VdbError
/// that starts with `<options.path>: grid "<options.gridName>": `. A reply whose bulk buffer is
/// smaller than @p minBulkBytes (at least 1) or larger than the memory limit is refused;
/// @p bulkName names the buffer in messages ("a grid"). The caller decodes and checks what it
/// receives.
IsolatedReply runIsolated(const VdbLoadOptions& options, const std::string& request,
                          std::uint64_t minBulkBytes, const char* bulkName);

/// What the reader sends for a density grid and for a velocity grid (vdb_velocity.cpp).
ChildReply gridChildReply(const VdbLoadOptions& options);
ChildReply velocityChildReply(const VelocityLoadOptions& options);

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

} // namespace nimbus::vdb::detail
