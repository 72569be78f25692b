/// @file vdb_level_set.cpp
/// @brief Narrow-band level sets from a distance function (LevelSetBake, vdb_writer.h). Its own
///        translation unit: OpenVDB's LevelSetRebuild.h (meshing and mesh-to-volume) is the
///        slowest header Nimbus compiles.
#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>

#include "plugin/vdb/vdb_bake_detail.h"

namespace nimbus::vdb::detail {

namespace {

using LeafT = FloatLeaf;

std::string ijkText(glm::ivec3 v) {
    return "(" + std::to_string(v.x) + ", " + std::to_string(v.y) + ", " + std::to_string(v.z) +
           ")";
}

void measure(const openvdb::FloatGrid& grid, VdbBakeStats& stats) {
    stats.leafCount = grid.tree().leafCount();
    stats.activeVoxelCount = grid.tree().activeVoxelCount();
    bool first = true;
    for (auto v = grid.cbeginValueOn(); v; ++v) {
        stats.minValue = first ? *v : std::min(stats.minValue, *v);
        stats.maxValue = first ? *v : std::max(stats.maxValue, *v);
        first = false;
    }
}

} // namespace

openvdb::FloatGrid::Ptr buildLevelSet(const std::string& path, const LevelSetBake& spec,
                                      VdbBakeStats& stats) {
    const std::string ctx = path + ": level set \"" + spec.name + "\": ";
    if (spec.name.empty()) throw VdbError(path + ": cannot bake a level set without a name");
    const glm::ivec3 res = spec.resolution;
    if (res.x < 1 || res.y < 1 || res.z < 1) {
        throw VdbError(ctx + "cannot bake a resolution of " + ijkText(res) +
                       " (every axis needs at least 1 voxel)");
    }
    const float vs = spec.voxelSize;
    if (!std::isfinite(vs) || !(vs > 0.0f) || !std::isfinite(spec.worldOrigin.x) ||
        !std::isfinite(spec.worldOrigin.y) || !std::isfinite(spec.worldOrigin.z)) {
        throw VdbError(ctx + "needs a finite voxel size > 0 and a finite origin");
    }
    if (!(spec.halfWidth >= 1.0f) || !std::isfinite(spec.halfWidth)) {
        throw VdbError(ctx + "half width " + std::to_string(spec.halfWidth) +
                       " voxels: must be finite and >= 1");
    }
    if (!spec.distance) throw VdbError(ctx + "no distance function");
    if (!(spec.slack >= 0.0f) || !std::isfinite(spec.slack)) {
        throw VdbError(ctx + "the bound's slack must be finite and >= 0");
    }
    openvdb::initialize();

    const float band = spec.halfWidth * vs;
    const glm::dvec3 origin(spec.worldOrigin);
    const auto centre = [&](glm::dvec3 ijk) { return glm::vec3(origin + ijk * double(vs)); };
    const auto& bound = spec.bound ? spec.bound : spec.distance;
    const float slack = spec.bound ? spec.slack : 0.0f;
    // every voxel centre of a block lies within 3.5 sqrt(3) voxels of the block's centre
    const float blockRadius = 3.5f * std::sqrt(3.0f) * vs;

    BadSample bad;
    std::vector<std::unique_ptr<LeafT>> leaves =
        buildLeaves(res, bad, [&](glm::ivec3 o) -> std::unique_ptr<LeafT> {
            // the whole block farther than the band from the surface: nothing to store (the
            // flood fill gives its sign)
            const float c = bound(centre(glm::dvec3(o) + 3.5));
            if (std::isfinite(c) && std::abs(c) > band + blockRadius + slack) return nullptr;
            auto leaf = std::make_unique<LeafT>(openvdb::Coord(o.x, o.y, o.z), band, false);
            bool any = false;
            for (int i = o.x; i < std::min(o.x + 8, res.x); ++i)
                for (int j = o.y; j < std::min(o.y + 8, res.y); ++j)
                    for (int k = o.z; k < std::min(o.z + 8, res.z); ++k) {
                        const float d = spec.distance(centre(glm::dvec3(i, j, k)));
                        if (std::isnan(d)) {
                            bad.report(glm::ivec3(i, j, k), d);
                            return nullptr;
                        }
                        const openvdb::Index n = LeafT::coordToOffset(openvdb::Coord(i, j, k));
                        if (std::abs(d) < band) {
                            leaf->setValueOn(n, d);
                            any = true;
                        } else {
                            leaf->setValueOff(n, d < 0.0f ? -band : band);
                        }
                    }
            return any ? std::move(leaf) : nullptr;
        });
    if (bad.seen()) {
        throw VdbError(ctx + "the distance at voxel " + bad.where() + " is " +
                       std::to_string(bad.value()) + "; it must be a number");
    }

    openvdb::FloatGrid::Ptr grid = newGrid<openvdb::FloatGrid>();
    grid->tree().root().setBackground(band, /*updateChildNodes=*/false);
    bool any = false;
    for (std::unique_ptr<LeafT>& leaf : leaves) {
        if (!leaf) continue;
        grid->tree().addLeaf(leaf.release());
        any = true;
    }
    if (!any) {
        throw VdbError(ctx + "no voxel lies within " + std::to_string(spec.halfWidth) +
                       " voxels of the surface: the surface does not cross the bake box");
    }
    openvdb::tools::signedFloodFill(grid->tree());
    placeGrid(*grid, spec.name, openvdb::GRID_LEVEL_SET, spec.worldOrigin, glm::vec3(vs));
    stats = VdbBakeStats{};
    if (spec.rebuild) {
        openvdb::FloatGrid::Ptr rebuilt;
        try {
            rebuilt = openvdb::tools::levelSetRebuild(*grid, 0.0f, spec.halfWidth);
        } catch (const std::exception& e) {
            throw VdbError(ctx + "OpenVDB could not re-distance the level set: " + e.what());
        }
        if (!rebuilt || rebuilt->tree().activeVoxelCount() == 0) {
            throw VdbError(ctx + "re-distancing the level set left no voxel (a surface thinner "
                                 "than a voxel?); use finer voxels");
        }
        placeGrid(*rebuilt, spec.name, openvdb::GRID_LEVEL_SET, spec.worldOrigin, glm::vec3(vs));
        grid = rebuilt;
        stats.rebuilt = true;
    }
    measure(*grid, stats);
    return grid;
}

} // namespace nimbus::vdb::detail
