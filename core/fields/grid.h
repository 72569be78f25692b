/// @file grid.h
/// @brief A sparse density grid (NanoVDB, trilinear), loaded by the host (plugin/vdb) and
/// handed to core as a nanovdb::FloatGrid.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/bindings.h"
#include "core/scene.h"

namespace nimbus {

/// A dense copy of a box of a grid's voxels (x-major, z fastest, as a NanoVDB leaf): the values
/// the grid's accessor returns there, background included. Trilinear lookups whose 2x2x2 stencil
/// lies in the box read it instead of walking the tree.
struct DenseVoxels {
    std::vector<float> values;
    std::int32_t lo[3] = {0, 0, 0}; ///< index coordinate of values[0]
    std::int32_t size[3] = {0, 0, 0};
};

/// The most voxels a dense copy may hold (128 MiB of floats); larger grids stay sparse.
constexpr std::int64_t kDenseVoxelsMax = std::int64_t(1) << 25;

struct GridField {
    const void* grid = nullptr; ///< a nanovdb::FloatGrid, kept alive by the scene's bindings
    float scale = 1.0f;         ///< multiplies the grid values
    std::uint64_t serial = 0;   ///< unique per field made: keys the per-thread accessors
    /// the grid's index-to-world translation minus the binding's shift, rounded to float once
    /// (equals the map's own float translation when nothing is shifted)
    vec3 origin{0.0f};
    glm::dvec3 shift{0.0}; ///< GridBinding::shift
    /// The grid's voxels near its density, dense (null: the grid is larger than
    /// kDenseVoxelsMax within that box, or empty); lookups give the same values either way.
    std::shared_ptr<const DenseVoxels> dense;

    /// Density at world point p (p inside the field's bounds).
    float density(vec3 p) const;
    /// Upper bound over the world box b: the maxima of the tree nodes that overlap it.
    float majorant(const Box& b) const;
    /// A tight upper bound of the density over the world box b: the largest of the voxels its
    /// trilinear stencils read (not the maxima of whole tree nodes). False without a dense
    /// copy (majorant() is then the bound).
    bool voxelMajorant(const Box& b, float& m) const;
    /// Calls fn(ctx, worldBox, maxDensity) for every tree node that holds density (leaves, and
    /// internal nodes with active tiles), boxes grown by the trilinear support.
    void forEachDensityNode(void (*fn)(void*, const Box&, float), void* ctx) const;
};

/// World size of a voxel of the loaded grid `b` along each of its index axes (0 without a grid).
vec3 gridVoxelSize(const GridBinding& b);

/// A grid field of `v` over its loaded grid `b` (null grid: no density), with a dense copy of
/// its voxels when they fit kDenseVoxelsMax.
GridField makeGridField(const VdbFieldDesc& v, const GridBinding& b);

/// `b` with its world positions moved by -shift, computed in double from the grid's own map
/// (its bounds recomputed the same way, padded by one voxel as the host pads them).
GridBinding shiftedGrid(const GridBinding& b, glm::dvec3 shift);

} // namespace nimbus
