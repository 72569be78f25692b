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

#include <string>

#include "plugin/vdb/vdb_reader.h"

namespace nimbus::vdb::detail {

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

/// Checks that @p g.handle holds one well-formed float NanoVDB grid that is safe to traverse:
/// its header, every node offset inside the buffer and pointing at a node of the right level,
/// a finite transform, finite non-negative values and finite node statistics, and node and
/// voxel counts that agree with @p g. Returns "" when it is valid, otherwise what is wrong.
/// Linear in the size of the grid (about 1 ms per 10 MB).
std::string checkNanoGrid(const LoadedVdbGrid& g);

/// Test hook: when set, the child process calls it first, before it reads anything (tests use it
/// to simulate a crash, a hang, an abnormal exit or a garbled reply). Not thread-safe: set it
/// only while no isolated load runs. nullptr (the default) disables it.
using IsolatedChildHook = void (*)(const VdbLoadOptions& options, int replyFd);
void setIsolatedChildHookForTests(IsolatedChildHook hook);

} // namespace nimbus::vdb::detail
