/// @file vdb_bake_detail.h
/// @brief Pieces shared by the two translation units that build grids to write
///        (vdb_writer.cpp, vdb_level_set.cpp). Includes OpenVDB: not for other files.
#pragma once

#include <openvdb/openvdb.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

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

using FloatLeaf = openvdb::FloatTree::LeafNodeType;

/// The first sample a parallel bake refused (a NaN, say): where and what it was.
class BadSample {
  public:
    bool seen() const { return bad_.load(std::memory_order_relaxed); }
    void report(glm::ivec3 ijk, float value) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!bad_.exchange(true)) ijk_ = ijk, value_ = value;
    }
    std::string where() const {
        return "(" + std::to_string(ijk_.x) + ", " + std::to_string(ijk_.y) + ", " +
               std::to_string(ijk_.z) + ")";
    }
    float value() const { return value_; }

  private:
    std::atomic<bool> bad_{false};
    std::mutex mutex_;
    glm::ivec3 ijk_{0};
    float value_ = 0.0f;
};

/// The leaves of a bake of @p res voxels: makeLeaf(origin) for every 8^3 block (origin a
/// multiple of 8), in parallel; null where it returns null. Stops early once @p bad has seen
/// a sample.
template <class MakeLeaf>
std::vector<std::unique_ptr<FloatLeaf>> buildLeaves(glm::ivec3 res, const BadSample& bad,
                                                    const MakeLeaf& makeLeaf) {
    const glm::ivec3 blocks = (res + 7) / 8;
    const std::size_t count = std::size_t(blocks.x) * blocks.y * blocks.z;
    std::vector<std::unique_ptr<FloatLeaf>> leaves(count);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count), [&](const auto& r) {
        for (std::size_t b = r.begin(); b != r.end(); ++b) {
            if (bad.seen()) return;
            leaves[b] = makeLeaf(8 * glm::ivec3(int(b % blocks.x), int((b / blocks.x) % blocks.y),
                                                int(b / (std::size_t(blocks.x) * blocks.y))));
        }
    });
    return leaves;
}

/// Name, class, the voxel-centre transform (vdb_writer.h) and Nimbus' grid metadata.
void placeGrid(openvdb::GridBase& grid, const std::string& name, openvdb::GridClass cls,
               glm::vec3 worldOrigin, glm::vec3 voxelSize);

/// The level set @p spec describes (vdb_level_set.cpp); @p path names the file in errors.
openvdb::FloatGrid::Ptr buildLevelSet(const std::string& path, const LevelSetBake& spec,
                                      VdbBakeStats& stats);

} // namespace nimbus::vdb::detail
