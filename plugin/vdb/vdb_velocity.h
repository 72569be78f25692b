/// @file vdb_velocity.h
/// @brief Reading a velocity (vec3) grid from an OpenVDB file into a dense sim::VelocityGrid
///        (issue 13: Mantaflow's `velocity`, centred or staggered; read only when the scene
///        names it, `[field.advect] velocity`).
///
/// The grid is read exactly as loadVdbGrid() reads a density grid (vdb_reader.h): the file's
/// structure is scanned with every length checked first, only the named grid's tree is read,
/// and by default in the reader process with the same memory and time limits (a corrupt
/// file ends the reader, not the caller). Errors are VdbErrors that start with
/// `<path>: grid "<name>": `.
///
/// What is accepted:
///  - value types vec3s (float), vec3h (float stored as half: Mantaflow) and vec3d (converted
///    to float); every other type is refused, naming the type (a float grid: "a scalar grid").
///  - a missing name: the message lists the file's vec3 grids (or says it has none).
///  - transforms: axis-aligned with the same positive scale on the three axes (a translation
///    is fine); rotations, shears, non-uniform scales and frustums are refused (the advection's
///    grids are axis-aligned cubes, core/sim/advect.h).
///  - an empty grid (no active voxels) is refused: there is no velocity to advect with.
///
/// The dense grid covers the ACTIVE voxel bounding box [indexMin, indexMax] of the tree: cell
/// c = ijk - indexMin, and since OpenVDB's voxel ijk is centred at index ijk, the frame's origin
/// is the world position of index indexMin - 1/2 and its voxel size the transform's scale. Every
/// cell holds the tree's value there (inactive voxels inside the box keep their stored value,
/// usually 0), times VelocityLoadOptions::scale; NaN/Inf components become 0 (counted, one
/// warning). Outside the box sim::velocityAt clamps to the edge.
///
/// Layout: OpenVDB's staggered convention (GridClass GRID_STAGGERED, openvdb/Grid.h) puts the x
/// component of voxel ijk on its lower x face, index (i - 1/2, j, k), and so on: exactly
/// sim::VelocityGrid's staggered layout (v[c].x at origin + (c.x, c.y + 1/2, c.z + 1/2) h). So
/// values are copied as they are for both layouts; only the flag differs. VelocityLayout::Auto
/// takes staggered when the grid's class is "staggered" (Mantaflow writes that; its
/// `vector_type` metadata is absent, i.e. "invariant", so it says nothing), centred otherwise.
///
/// The dense grid takes 12 bytes per cell; boxes of more than maxCells cells are refused before
/// anything is allocated (the message names the grid, its box, its cell count and the limit).
///
/// @code
///   using namespace nimbus::vdb;
///   VelocityLoadOptions o;
///   o.read.path = "fluid_data_0001.vdb"; // o.read.gridName = "velocity" by default
///   LoadedVelocityGrid v = loadVdbVelocity(o);
///   sim::VelocityField f = v.staggered ? sim::staggeredGrid(v.grid) : sim::centredGrid(v.grid);
///   vec3 u = sim::velocityAt(f, p); // world units / s
/// @endcode
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/scene.h"
#include "core/sim/advect.h"
#include "plugin/vdb/vdb_reader.h"

namespace nimbus::vdb {

/// What to read.
struct VelocityLoadOptions {
    /// path, grid name (here "velocity" by default), isolation and its limits, as for density
    /// grids (levelsetToFog is ignored).
    VdbLoadOptions read = defaultRead();
    VelocityLayout layout = VelocityLayout::Auto; ///< Auto: the grid class decides
    float scale = 1.0f;                           ///< multiplies every component
    /// The most cells the dense grid may have (12 bytes each; 2^27 cells = 1.5 GiB).
    std::uint64_t maxCells = std::uint64_t(1) << 27;
    /// Inactive voxels inside the active box (OpenVDB's background: Mantaflow stores velocity
    /// only where its fluid was) take the mean of their known face neighbours, layer by layer
    /// outward from the active voxels, instead of the background's still air.
    bool extrapolate = true;

    static VdbLoadOptions defaultRead() {
        VdbLoadOptions o;
        o.gridName = "velocity";
        return o;
    }
};

/// A velocity grid read from a VDB file.
struct LoadedVelocityGrid {
    sim::VelocityGrid grid;      ///< dense, world units / s (scaled), over the active voxel box
    bool staggered = false;      ///< the layout used (Auto resolved)
    std::string path;            ///< the file
    std::string gridName;        ///< the grid's name in the file
    std::string sourceValueType; ///< "vec3s", "vec3h" or "vec3d" (as stored)
    std::string gridClass;       ///< as stored: "staggered", "unknown", "fog volume", ...
    std::string vectorType;      ///< OpenVDB's vector_type: "invariant" (also when absent), ...
    glm::ivec3 indexMin{0};      ///< the active voxel box, inclusive
    glm::ivec3 indexMax{-1};
    std::uint64_t activeVoxelCount = 0;
    std::uint64_t nonFiniteCount = 0;    ///< NaN/Inf components set to 0
    std::uint64_t extrapolatedCells = 0; ///< inactive cells filled from their neighbours
    float maxSpeed = 0.0f;               ///< largest |v| over the dense cells (scaled)
    int gridsRead = 0;                   ///< trees read from the file: 1
    std::vector<std::string> warnings;   ///< "<path>: grid "<name>": ..."
};

/// Reads options.read.gridName from options.read.path (see the file comment), in a child process
/// unless options.read.isolate is false. Thread-safe. Counted by vdbReadCount()/vdbRecentReads().
/// @throws VdbError for every refusal and failure.
LoadedVelocityGrid loadVdbVelocity(const VelocityLoadOptions& options);

/// The velocity grid a field's `[field.advect]` names, for one frame: when field.advect.enabled
/// and advect.wind == AdvectWind::Grid, resolves advect.velocityPath for @p frame (a per-frame
/// pattern like density paths, relative paths from @p sceneDir; a missing frame is held from an
/// earlier one when the field's vdb.hold is set), reads advect.velocityGrid with advect.layout
/// and advect.velocityScale (applyVdbEnvironment's isolation settings) and stores the grid and
/// its layout in @p velocity / @p staggered. Otherwise nothing is read and both are reset
/// (null, false). Warnings are appended. @throws VdbError with file and grid.
void bindVdbVelocity(const FieldDesc& field, const std::string& sceneDir, int frame,
                     std::shared_ptr<const sim::VelocityGrid>& velocity, bool& staggered,
                     std::vector<std::string>& warnings);

namespace detail {
/// loadVdbVelocity() in the calling process (vdb_reader.cpp).
LoadedVelocityGrid loadVdbVelocityInProcess(const VelocityLoadOptions& options);
} // namespace detail

} // namespace nimbus::vdb
