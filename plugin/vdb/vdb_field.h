/// @file vdb_field.h
/// @brief Binds the VDB grid a field description names, for one frame: resolves the per-frame
/// file (relative to the scene file), reads only the named grid, and hands core/ the NanoVDB
/// grid and its world bounds (a GridBinding, core/bindings.h).
#pragma once

#include <string>
#include <vector>

#include "core/bindings.h"
#include "core/scene.h"
#include "plugin/vdb/vdb_reader.h"

namespace nimbus::vdb {

/// Applies the environment variables of the nimbus command to @p o (unset ones leave it alone):
///  - NIMBUS_VDB_ISOLATE=0 reads grids in process (trusted files only; default 1: in a child
///    process, see "Isolation" in vdb_reader.h);
///  - NIMBUS_VDB_TIMEOUT=seconds, the time limit of that process (default 600);
///  - NIMBUS_VDB_MEMORY_LIMIT=<n>M or <n>G, the address space it may map beyond the caller's
///    (default: the machine's physical memory).
/// @throws VdbError naming the variable, its value and what is allowed.
void applyVdbEnvironment(VdbLoadOptions& o);

/// For field.kind = vdb: loads frame `frame` of field.vdb.path (relative paths are taken from
/// `sceneDir`) and returns the grid with its owner and bounds (an empty grid: null grid, empty
/// bounds). Other kinds get an empty binding. Warnings (empty grid, sanitised voxels, held
/// frames) are appended. Reads in a child process unless the environment says otherwise
/// (applyVdbEnvironment). @throws VdbError with file and grid.
GridBinding bindVdbField(const FieldDesc& field, const std::string& sceneDir, int frame,
                         std::vector<std::string>& warnings);

} // namespace nimbus::vdb
