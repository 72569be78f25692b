/// @file vdb_field.h
/// @brief Attaches the VDB grid a scene names to its field description, for one frame: resolves
/// the per-frame file (relative to the scene file), reads only the named grid, and hands core/
/// the NanoVDB grid and its world bounds.
#pragma once

#include <string>
#include <vector>

#include "core/scene.h"

namespace nimbus::vdb {

/// For field.kind = vdb: loads frame `frame` of field.vdb.path (relative paths are taken from
/// `sceneDir`) and fills nanoGrid, owner and bounds. Other kinds are left alone. Warnings (empty
/// grid, sanitised voxels, held frames) are appended. @throws VdbError with file and grid.
void attachVdbField(FieldDesc& field, const std::string& sceneDir, int frame,
                    std::vector<std::string>& warnings);

} // namespace nimbus::vdb
