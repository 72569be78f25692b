/// @file vdb_bake_detail.h
/// @brief Pieces shared by the two translation units that build grids to write
///        (vdb_writer.cpp, vdb_level_set.cpp). Includes OpenVDB: not for other files.
#pragma once

#include <openvdb/openvdb.h>

#include <string>

#include "plugin/vdb/vdb_error.h"
#include "plugin/vdb/vdb_writer.h"

namespace nimbus::vdb::detail {

/// An empty grid (background 0) made by OpenVDB's grid registry inside libopenvdb. Calling
/// GridT::create() here would instantiate Grid<T>'s whole vtable in this translation unit (OpenVDB
/// 10 does not instantiate Grid explicitly): ~10-15 s of compile time per grid type.
template <class GridT> typename GridT::Ptr newGrid() {
    typename GridT::Ptr grid =
        openvdb::gridPtrCast<GridT>(openvdb::GridBase::createGrid(GridT::gridType()));
    if (!grid) throw VdbError("OpenVDB cannot create a grid of type " + GridT::gridType());
    return grid;
}

/// Name, class, the voxel-centre transform (vdb_writer.h) and Nimbus' grid metadata.
void placeGrid(openvdb::FloatGrid& grid, const std::string& name, openvdb::GridClass cls,
               glm::vec3 worldOrigin, glm::vec3 voxelSize);

/// The level set @p spec describes (vdb_level_set.cpp); @p path names the file in errors.
openvdb::FloatGrid::Ptr buildLevelSet(const std::string& path, const LevelSetBake& spec,
                                      VdbBakeStats& stats);

} // namespace nimbus::vdb::detail
