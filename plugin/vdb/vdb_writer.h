/// @file vdb_writer.h
/// @brief Baking densities into sparse OpenVDB fog volumes (the writing side of VDB support),
///        plus hand-built grids of any type for tests and tools.
///
/// Voxel-centre convention (the same as OpenVDB's and NanoVDB's): sample (i,j,k) is the density
/// AT the world point
///
///     p(i,j,k) = worldOrigin + (i, j, k) * voxelSize        (component-wise)
///
/// which is the centre of voxel (i,j,k); the voxel itself covers p +- voxelSize/2. So
/// `worldOrigin` is the centre of the first voxel, NOT the corner of the baked box: to bake the
/// box [lo, hi] with n voxels per axis, use voxelSize = (hi - lo) / n and
/// worldOrigin = lo + voxelSize / 2. The written transform is exactly this map (a
/// (Uniform)ScaleTranslateMap: scale voxelSize, translation worldOrigin), so every reader that
/// samples at voxel centres (OpenVDB, NanoVDB, Houdini, Blender) puts each value where it was
/// taken. loadVdbGrid() of the file returns worldFromIndex = translate(worldOrigin) *
/// scale(voxelSize) and the identical values.
///
/// The grid is a sparse FloatGrid of class "fog volume", background 0: only samples greater than
/// `backgroundTolerance` become active voxels (8^3 leaves are allocated only where there is
/// one); the others, negative samples included, are background 0. Files are written atomically
/// (io::writeAtomically: temp file, fsync, rename) with grid metadata `nimbus_version` and
/// `nimbus_sampling`, and file metadata `creator` = "Nimbus <version>".
///
/// @code
///   // a 64^3 bake of the unit cube, from a field evaluated in parallel at voxel centres
///   glm::vec3 vs(1.0f / 64.0f);
///   nimbus::vdb::bakeFogVdb("cloud.vdb", "density", glm::ivec3(64), glm::vec3(0.0f) + 0.5f * vs,
///                           vs, [&](glm::vec3 p) { return field.density(p); });
/// @endcode
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace nimbus::vdb {

/// What a bake wrote.
struct VdbBakeStats {
    std::uint64_t activeVoxelCount = 0; ///< samples > backgroundTolerance
    std::uint64_t leafCount = 0;        ///< 8^3 leaf nodes allocated
    float maxValue = 0.0f;              ///< largest sample
    float minValue = 0.0f;              ///< smallest active sample
    bool rebuilt = false;               ///< a level set re-distanced from its zero crossing
};

/// Writes the dense array @p dense (nx*ny*nz floats, x fastest: index i + nx*(j + ny*k)) as a
/// sparse fog-volume grid @p gridName to @p path (see the file comment for the voxel-centre
/// convention of @p worldOrigin and @p voxelSize). Runs in parallel over 8^3 blocks.
/// @throws VdbError (vdb_reader.h) for non-positive sizes, a non-finite origin or voxel size, a
///         negative tolerance, a NaN/Inf sample (naming its index) or a failed write.
VdbBakeStats writeFogVdb(const std::string& path, const std::string& gridName, int nx, int ny,
                         int nz, const float* dense, glm::vec3 worldOrigin, glm::vec3 voxelSize,
                         float backgroundTolerance = 0.0f);

/// As writeFogVdb(), but the densities come from @p density, called at every voxel centre
/// p(i,j,k) (computed in double, then rounded to float) concurrently from several threads (it
/// must be thread-safe); no dense array is allocated.
VdbBakeStats bakeFogVdb(const std::string& path, const std::string& gridName, glm::ivec3 resolution,
                        glm::vec3 worldOrigin, glm::vec3 voxelSize,
                        const std::function<float(glm::vec3 worldPos)>& density,
                        float backgroundTolerance = 0.0f);

/// A level set to bake (OpenVDB class "level set"): the signed distance to the surface where
/// @p distance is 0 (negative inside), stored in a narrow band of active voxels within
/// halfWidth voxels of the surface (values clamped to +-halfWidth * voxelSize, the background);
/// the inactive voxels inside are set to -background by a signed flood fill, as OpenVDB's own
/// level sets are. Voxel centres follow the convention of the file comment.
struct LevelSetBake {
    std::string name = "surface";
    glm::ivec3 resolution{0};
    glm::vec3 worldOrigin{0.0f}; ///< centre of voxel (0, 0, 0)
    float voxelSize = 0.0f;      ///< uniform (level sets are isotropic)
    float halfWidth = 3.0f;      ///< voxels each side of the surface (OpenVDB's default 3)
    /// Signed distance or a bound of it (negative inside); called concurrently.
    std::function<float(glm::vec3)> distance;
    /// A 1-Lipschitz function within @p slack of distance(), used to skip 8^3 blocks that lie
    /// wholly outside the band (evaluated once per block). Empty: distance() itself (then it
    /// must be 1-Lipschitz).
    std::function<float(glm::vec3)> bound;
    float slack = 0.0f;
    /// Re-distance the band from its zero crossing (openvdb::tools::levelSetRebuild: the surface
    /// is meshed and converted back), so that the values are true distances even where
    /// distance() is only a bound (smooth unions, displacement). Needs a closed surface: leave it
    /// off for a surface the bake box cuts (a ground plane), whose band keeps distance()'s values.
    bool rebuild = true;
};

/// A fog volume to bake, as bakeFogVdb() takes it.
struct FogBake {
    std::string name = "density";
    glm::ivec3 resolution{0};
    glm::vec3 worldOrigin{0.0f};
    glm::vec3 voxelSize{0.0f};
    std::function<float(glm::vec3)> density;
    float backgroundTolerance = 0.0f;
    /// When set, bakeVdb() also writes a velocity grid (`nimbus bake --velocity`) right after
    /// this fog volume: a vec3s grid named velocityName, cell-centred (grid class "unknown",
    /// vector_type "contravariant relative", is_in_world_space true: world units per second),
    /// with the fog's transform, holding velocity(p) at the voxel centres of every 8^3 block
    /// that holds an active density voxel and of the blocks next to those (26 neighbours,
    /// inside the baked box), all of them active: the active density voxels dilated by at
    /// least one voxel. Called concurrently; a NaN/Inf component is an error naming the voxel.
    std::function<glm::vec3(glm::vec3)> velocity;
    std::string velocityName = "velocity";
};

/// Bakes @p fogs and @p levelSets and writes them, in that order, to one file @p path
/// (atomically). Returns one VdbBakeStats per grid, in the same order (for a level set,
/// maxValue is the largest active distance and minValue the smallest; a fog's velocity grid
/// follows it in the file and in the stats, whose maxValue is then the largest speed |v| and
/// minValue the smallest).
/// @throws VdbError as bakeFogVdb(), and for a level set with a half width below 1, a
///         non-finite distance (naming the voxel) or no voxel in its band.
std::vector<VdbBakeStats> bakeVdb(const std::string& path, const std::vector<FogBake>& fogs,
                                  const std::vector<LevelSetBake>& levelSets);

/// A grid given voxel by voxel and tile by tile, for tests and tools that need what a bake does
/// not write: other value types and grid classes, arbitrary affine transforms, active tiles,
/// inactive values, NaN/Inf/negative values.
struct VdbGridSpec {
    std::string name = "density";
    /// "float", "half", "double", "vec3s", "vec3h" (vec3s saved as half), "vec3d", "int32"
    std::string valueType = "float";
    std::string gridClass = "fog volume"; ///< "fog volume", "level set", "unknown", "staggered"
    glm::dmat4 worldFromIndex{1.0};       ///< affine; column vectors (world = M * (ijk, 1))
    double background = 0.0;
    struct Voxel {
        glm::ivec3 ijk{0};
        double value = 0.0; ///< vec3 grids store (value, value, value) unless hasVector
        bool active = true;
        bool hasVector = false; ///< vec3 grids: store `vector` instead
        glm::dvec3 vector{0.0};
    };
    std::vector<Voxel> voxels;
    /// A tile at @p level: 1 covers the 8^3 voxels of a lower internal-node entry, 2 the 128^3
    /// of an upper internal-node entry, 3 the 4096^3 of a root entry; @p ijk is any voxel in it.
    struct Tile {
        glm::ivec3 ijk{0};
        int level = 1;
        double value = 0.0;
        bool active = true;
    };
    std::vector<Tile> tiles; ///< added before the voxels
};

/// Writes @p grids, in order, to @p path (atomically), with file metadata @p creator when not
/// empty. @throws VdbError for an unknown value type or class, or a failed write.
void writeVdbGrids(const std::string& path, const std::vector<VdbGridSpec>& grids,
                   const std::string& creator = "");

} // namespace nimbus::vdb
