/// @file vdb_writer.cpp
/// @brief writeFogVdb(), bakeFogVdb() and writeVdbGrids() (see vdb_writer.h). The only
///        translation unit that writes OpenVDB files.
#include "plugin/vdb/vdb_writer.h"
#include "plugin/vdb/vdb_isolate.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>

#include "plugin/io/atomic_file.h"
#include "plugin/vdb/vdb_bake_detail.h"
#include "plugin/vdb/vdb_error.h"

#ifndef NIMBUS_VERSION
#define NIMBUS_VERSION "unknown"
#endif

namespace nimbus::vdb {

namespace {

using detail::newGrid;
using LeafT = detail::FloatLeaf;

std::string vecText(glm::dvec3 v) {
    return "(" + std::to_string(v.x) + ", " + std::to_string(v.y) + ", " + std::to_string(v.z) +
           ")";
}

/// Writes @p grids to @p path through io::writeAtomically; OpenVDB errors become VdbError.
void writeFile(const std::string& path, const openvdb::GridCPtrVec& grids,
               const openvdb::MetaMap& fileMeta) {
    try {
        io::writeAtomically(path, [&](const std::string& tempPath) {
            openvdb::io::File file(tempPath);
            file.write(grids, fileMeta);
            file.close();
        });
    } catch (const std::exception& e) {
        throw VdbError(path + ": cannot write the VDB file: " + e.what());
    }
}

/// The bake: fills 8^3 leaves in parallel from @p sample(i, j, k), keeps the leaves with at least
/// one sample > tolerance.
/// When @p occupied is not null it receives one flag per 8^3 block (x fastest) that holds an
/// active voxel.
template <class SampleFn>
openvdb::FloatGrid::Ptr buildFog(const std::string& path, const std::string& gridName,
                                 glm::ivec3 res, glm::vec3 worldOrigin, glm::vec3 voxelSize,
                                 float tolerance, const SampleFn& sample, VdbBakeStats& stats,
                                 std::vector<char>* occupied = nullptr) {
    const std::string ctx = path + ": grid \"" + gridName + "\": ";
    if (gridName.empty()) throw VdbError(path + ": cannot bake a grid without a name");
    if (res.x < 1 || res.y < 1 || res.z < 1) {
        throw VdbError(ctx + "cannot bake a resolution of " + std::to_string(res.x) + " x " +
                       std::to_string(res.y) + " x " + std::to_string(res.z) +
                       " (every axis needs at least 1 voxel)");
    }
    for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(worldOrigin[a]) || !std::isfinite(voxelSize[a]) ||
            !(voxelSize[a] > 0.0f)) {
            throw VdbError(ctx + "cannot bake with origin " + vecText(worldOrigin) +
                           " and voxel size " + vecText(voxelSize) +
                           " (both finite, voxel size > 0)");
        }
    }
    if (!(tolerance >= 0.0f) || !std::isfinite(tolerance)) {
        throw VdbError(ctx + "background tolerance " + std::to_string(tolerance) +
                       " must be finite and >= 0");
    }
    openvdb::initialize();

    detail::BadSample bad;
    std::vector<std::unique_ptr<LeafT>> leaves =
        detail::buildLeaves(res, bad, [&](glm::ivec3 o) -> std::unique_ptr<LeafT> {
            std::unique_ptr<LeafT> leaf;
            for (int i = o.x; i < std::min(o.x + 8, res.x); ++i)
                for (int j = o.y; j < std::min(o.y + 8, res.y); ++j)
                    for (int k = o.z; k < std::min(o.z + 8, res.z); ++k) {
                        const float v = sample(i, j, k);
                        if (!std::isfinite(v)) {
                            bad.report(glm::ivec3(i, j, k), v);
                            return nullptr;
                        }
                        if (!(v > tolerance)) continue; // background: zero, small or negative
                        if (!leaf)
                            leaf =
                                std::make_unique<LeafT>(openvdb::Coord(o.x, o.y, o.z), 0.0f, false);
                        leaf->setValueOn(LeafT::coordToOffset(openvdb::Coord(i, j, k)), v);
                    }
            return leaf;
        });
    if (bad.seen()) {
        throw VdbError(ctx + "sample " + bad.where() + " is " + std::to_string(bad.value()) +
                       "; a density must be finite");
    }

    openvdb::FloatGrid::Ptr grid = newGrid<openvdb::FloatGrid>();
    stats = VdbBakeStats{};
    bool first = true;
    if (occupied) occupied->assign(leaves.size(), 0);
    for (std::size_t b = 0; b < leaves.size(); ++b) {
        std::unique_ptr<LeafT>& leaf = leaves[b];
        if (!leaf) continue;
        if (occupied) (*occupied)[b] = 1;
        ++stats.leafCount;
        stats.activeVoxelCount += leaf->onVoxelCount();
        for (auto v = leaf->cbeginValueOn(); v; ++v) {
            stats.maxValue = first ? *v : std::max(stats.maxValue, *v);
            stats.minValue = first ? *v : std::min(stats.minValue, *v);
            first = false;
        }
        grid->tree().addLeaf(leaf.release());
    }
    detail::placeGrid(*grid, gridName, openvdb::GRID_FOG_VOLUME, worldOrigin, voxelSize);
    return grid;
}

/// The velocity grid of a fog bake (FogBake::velocity): every voxel of the blocks that are
/// @p occupied or next to one, inside the box of @p res voxels.
openvdb::Vec3SGrid::Ptr buildVelocity(const std::string& path, const FogBake& f,
                                      const std::vector<char>& occupied, VdbBakeStats& stats) {
    using VecLeaf = openvdb::Vec3STree::LeafNodeType;
    const std::string ctx = path + ": grid \"" + f.velocityName + "\": ";
    if (f.velocityName.empty() || f.velocityName == f.name)
        throw VdbError(ctx + "the velocity grid needs a name of its own (the density grid is \"" +
                       f.name + "\")");
    const glm::ivec3 res = f.resolution, blocks = (res + 7) / 8;
    auto at = [&](glm::ivec3 b) {
        return occupied[std::size_t(b.x) +
                        std::size_t(blocks.x) * (std::size_t(b.y) + std::size_t(blocks.y) * b.z)];
    };
    const glm::dvec3 origin(f.worldOrigin), vs(f.voxelSize);
    std::vector<std::unique_ptr<VecLeaf>> leaves(occupied.size());
    detail::BadSample bad;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, occupied.size()), [&](const auto& r) {
        for (std::size_t n = r.begin(); n != r.end(); ++n) {
            if (bad.seen()) return;
            const glm::ivec3 b(int(n % blocks.x), int((n / blocks.x) % blocks.y),
                               int(n / (std::size_t(blocks.x) * blocks.y)));
            bool near = false;
            for (int dz = -1; dz <= 1 && !near; ++dz)
                for (int dy = -1; dy <= 1 && !near; ++dy)
                    for (int dx = -1; dx <= 1 && !near; ++dx) {
                        const glm::ivec3 c = b + glm::ivec3(dx, dy, dz);
                        near = glm::all(glm::greaterThanEqual(c, glm::ivec3(0))) &&
                               glm::all(glm::lessThan(c, blocks)) && at(c);
                    }
            if (!near) continue;
            const glm::ivec3 o = 8 * b;
            auto leaf = std::make_unique<VecLeaf>(openvdb::Coord(o.x, o.y, o.z),
                                                  openvdb::Vec3s(0.0f), false);
            for (int i = o.x; i < std::min(o.x + 8, res.x); ++i)
                for (int j = o.y; j < std::min(o.y + 8, res.y); ++j)
                    for (int k = o.z; k < std::min(o.z + 8, res.z); ++k) {
                        const glm::vec3 v =
                            f.velocity(glm::vec3(origin + glm::dvec3(i, j, k) * vs));
                        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
                            bad.report(glm::ivec3(i, j, k), glm::length(v));
                            return;
                        }
                        leaf->setValueOn(VecLeaf::coordToOffset(openvdb::Coord(i, j, k)),
                                         openvdb::Vec3s(v.x, v.y, v.z));
                    }
            leaves[n] = std::move(leaf);
        }
    });
    if (bad.seen()) {
        throw VdbError(ctx + "the velocity at voxel " + bad.where() +
                       " is not finite; a velocity must be finite");
    }
    openvdb::Vec3SGrid::Ptr grid = detail::newGrid<openvdb::Vec3SGrid>();
    stats = VdbBakeStats{};
    bool first = true;
    for (std::unique_ptr<VecLeaf>& leaf : leaves) {
        if (!leaf) continue;
        ++stats.leafCount;
        stats.activeVoxelCount += leaf->onVoxelCount();
        for (auto v = leaf->cbeginValueOn(); v; ++v) {
            const float speed = v->length();
            stats.maxValue = first ? speed : std::max(stats.maxValue, speed);
            stats.minValue = first ? speed : std::min(stats.minValue, speed);
            first = false;
        }
        grid->tree().addLeaf(leaf.release());
    }
    detail::placeGrid(*grid, f.velocityName, openvdb::GRID_UNKNOWN, f.worldOrigin, f.voxelSize);
    grid->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
    return grid;
}

openvdb::MetaMap nimbusFileMeta() {
    openvdb::MetaMap fileMeta;
    fileMeta.insertMeta("creator", openvdb::StringMetadata("Nimbus " NIMBUS_VERSION));
    return fileMeta;
}

template <class SampleFn>
VdbBakeStats bake(const std::string& path, const std::string& gridName, glm::ivec3 res,
                  glm::vec3 worldOrigin, glm::vec3 voxelSize, float tolerance,
                  const SampleFn& sample) {
    VdbBakeStats stats;
    openvdb::FloatGrid::Ptr grid =
        buildFog(path, gridName, res, worldOrigin, voxelSize, tolerance, sample, stats);
    writeFile(path, {grid}, nimbusFileMeta());
    return stats;
}

openvdb::GridClass parseClass(const std::string& path, const std::string& cls) {
    if (cls == "fog volume") return openvdb::GRID_FOG_VOLUME;
    if (cls == "level set") return openvdb::GRID_LEVEL_SET;
    if (cls == "unknown") return openvdb::GRID_UNKNOWN;
    if (cls == "staggered") return openvdb::GRID_STAGGERED;
    throw VdbError(path + ": unknown grid class \"" + cls +
                   "\" (fog volume, level set, unknown, staggered)");
}

openvdb::Coord coord(glm::ivec3 v) {
    return openvdb::Coord(v.x, v.y, v.z);
}

/// @p convert maps a scalar to a value; @p value maps a voxel to its value.
template <class GridT, class Convert, class Value>
openvdb::GridBase::Ptr buildGrid(const VdbGridSpec& spec, const Convert& convert,
                                 const Value& value) {
    typename GridT::Ptr grid = newGrid<GridT>();
    auto& tree = grid->tree();
    tree.root().setBackground(convert(spec.background), /*updateChildNodes=*/false);
    for (const VdbGridSpec::Tile& t : spec.tiles) {
        tree.addTile(openvdb::Index(t.level), coord(t.ijk), convert(t.value), t.active);
    }
    for (const VdbGridSpec::Voxel& v : spec.voxels) {
        if (v.active)
            tree.setValueOn(coord(v.ijk), value(v));
        else
            tree.setValueOff(coord(v.ijk), value(v));
    }
    return grid;
}

template <class GridT, class Convert>
openvdb::GridBase::Ptr buildGrid(const VdbGridSpec& spec, const Convert& convert) {
    return buildGrid<GridT>(spec, convert,
                            [&](const VdbGridSpec::Voxel& v) { return convert(v.value); });
}

} // namespace

namespace detail {

void placeGrid(openvdb::GridBase& grid, const std::string& name, openvdb::GridClass cls,
               glm::vec3 worldOrigin, glm::vec3 voxelSize) {
    grid.setName(name);
    grid.setGridClass(cls);
    grid.setSaveFloatAsHalf(false);
    grid.setIsInWorldSpace(true);
    const openvdb::Vec3d scale(voxelSize.x, voxelSize.y, voxelSize.z);
    const openvdb::Vec3d origin(worldOrigin.x, worldOrigin.y, worldOrigin.z);
    openvdb::math::MapBase::Ptr map;
    if (scale[0] == scale[1] && scale[1] == scale[2]) {
        map = std::make_shared<openvdb::math::UniformScaleTranslateMap>(scale[0], origin);
    } else {
        map = std::make_shared<openvdb::math::ScaleTranslateMap>(scale, origin);
    }
    grid.setTransform(std::make_shared<openvdb::math::Transform>(map));
    grid.insertMeta("nimbus_version", openvdb::StringMetadata(NIMBUS_VERSION));
    grid.insertMeta("nimbus_sampling",
                    openvdb::StringMetadata("voxel centres: sample (i,j,k) was taken at "
                                            "world origin + (i,j,k) * voxel size"));
}

} // namespace detail

VdbBakeStats writeFogVdb(const std::string& path, const std::string& gridName, int nx, int ny,
                         int nz, const float* dense, glm::vec3 worldOrigin, glm::vec3 voxelSize,
                         float backgroundTolerance) {
    if (!dense) throw VdbError(path + ": grid \"" + gridName + "\": no density array given");
    const std::size_t sx = std::size_t(std::max(nx, 0)), sxy = sx * std::size_t(std::max(ny, 0));
    return bake(path, gridName, glm::ivec3(nx, ny, nz), worldOrigin, voxelSize, backgroundTolerance,
                [&](int i, int j, int k) { return dense[std::size_t(i) + sx * j + sxy * k]; });
}

VdbBakeStats bakeFogVdb(const std::string& path, const std::string& gridName, glm::ivec3 resolution,
                        glm::vec3 worldOrigin, glm::vec3 voxelSize,
                        const std::function<float(glm::vec3 worldPos)>& density,
                        float backgroundTolerance) {
    if (!density) throw VdbError(path + ": grid \"" + gridName + "\": no density function");
    const glm::dvec3 origin(worldOrigin), vs(voxelSize);
    return bake(
        path, gridName, resolution, worldOrigin, voxelSize, backgroundTolerance,
        [&](int i, int j, int k) { return density(glm::vec3(origin + glm::dvec3(i, j, k) * vs)); });
}

std::vector<VdbBakeStats> bakeVdb(const std::string& path, const std::vector<FogBake>& fogs,
                                  const std::vector<LevelSetBake>& levelSets) {
    openvdb::GridCPtrVec grids;
    std::vector<VdbBakeStats> stats;
    for (const FogBake& f : fogs) {
        if (!f.density) throw VdbError(path + ": grid \"" + f.name + "\": no density function");
        const glm::dvec3 origin(f.worldOrigin), vs(f.voxelSize);
        stats.emplace_back();
        std::vector<char> occupied;
        grids.push_back(buildFog(
            path, f.name, f.resolution, f.worldOrigin, f.voxelSize, f.backgroundTolerance,
            [&](int i, int j, int k) {
                return f.density(glm::vec3(origin + glm::dvec3(i, j, k) * vs));
            },
            stats.back(), f.velocity ? &occupied : nullptr));
        if (f.velocity) {
            stats.emplace_back();
            grids.push_back(buildVelocity(path, f, occupied, stats.back()));
        }
    }
    for (const LevelSetBake& l : levelSets) {
        stats.emplace_back();
        grids.push_back(detail::buildLevelSet(path, l, stats.back()));
    }
    if (grids.empty()) throw VdbError(path + ": nothing to bake (no grid given)");
    writeFile(path, grids, nimbusFileMeta());
    return stats;
}

void writeVdbGrids(const std::string& path, const std::vector<VdbGridSpec>& grids,
                   const std::string& creator) {
    openvdb::initialize();
    openvdb::GridCPtrVec out;
    for (const VdbGridSpec& spec : grids) {
        openvdb::GridBase::Ptr g;
        const std::string& t = spec.valueType;
        if (t == "float" || t == "half") {
            g = buildGrid<openvdb::FloatGrid>(spec, [](double v) { return float(v); });
            g->setSaveFloatAsHalf(t == "half");
        } else if (t == "double") {
            g = buildGrid<openvdb::DoubleGrid>(spec, [](double v) { return v; });
        } else if (t == "vec3s" || t == "vec3h") {
            g = buildGrid<openvdb::Vec3SGrid>(
                spec, [](double v) { return openvdb::Vec3s(float(v), float(v), float(v)); },
                [](const VdbGridSpec::Voxel& v) {
                    const glm::dvec3 w = v.hasVector ? v.vector : glm::dvec3(v.value);
                    return openvdb::Vec3s(float(w.x), float(w.y), float(w.z));
                });
            g->setSaveFloatAsHalf(t == "vec3h");
        } else if (t == "vec3d") {
            g = buildGrid<openvdb::Vec3DGrid>(
                spec, [](double v) { return openvdb::Vec3d(v, v, v); },
                [](const VdbGridSpec::Voxel& v) {
                    const glm::dvec3 w = v.hasVector ? v.vector : glm::dvec3(v.value);
                    return openvdb::Vec3d(w.x, w.y, w.z);
                });
        } else if (t == "int32") {
            g = buildGrid<openvdb::Int32Grid>(spec, [](double v) { return std::int32_t(v); });
        } else {
            throw VdbError(path + ": grid \"" + spec.name + "\": unknown value type \"" + t +
                           "\" (float, half, double, vec3s, vec3h, vec3d, int32)");
        }
        g->setName(spec.name);
        g->setGridClass(parseClass(path, spec.gridClass));
        // glm stores columns and multiplies column vectors; OpenVDB multiplies row vectors:
        // the same 16 numbers in the same order (see vdb_reader.cpp toGlm).
        openvdb::Mat4d m;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) m(r, c) = spec.worldFromIndex[r][c];
        try {
            g->setTransform(openvdb::math::Transform::createLinearTransform(m));
        } catch (const std::exception& e) {
            throw VdbError(path + ": grid \"" + spec.name + "\": bad transform: " + e.what());
        }
        out.push_back(g);
    }
    openvdb::MetaMap fileMeta;
    if (!creator.empty()) fileMeta.insertMeta("creator", openvdb::StringMetadata(creator));
    writeFile(path, out, fileMeta);
}

} // namespace nimbus::vdb
