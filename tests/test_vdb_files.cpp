/// @file test_vdb_files.cpp
/// @brief loadVdbGrid() on real third-party VDB files (../shared/data/vdb, see its README):
///        every file gets the behaviour it deserves. Skips when that folder is absent.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <nanovdb/NanoVDB.h> // SampleFromVoxels.h does not include it itself
#include <nanovdb/util/SampleFromVoxels.h>

#include "plugin/vdb/vdb_reader.h"
#include "tests/test_util.h"
#include "tests/vdb_test_util.h"

using namespace nimbus::vdb;
namespace fs = std::filesystem;

namespace {

/// Sum and count of the active leaf values of a NanoVDB grid (leaves are contiguous).
struct LeafSummary {
    double sum = 0.0;
    std::uint64_t count = 0;
    bool statsAreBounds = true; ///< every leaf's min/max bound its active values
};
LeafSummary summarize(const nanovdb::FloatGrid& grid) {
    LeafSummary s;
    const auto& tree = grid.tree();
    const auto* leaves = tree.getFirstLeaf();
    for (std::uint32_t i = 0; i < tree.nodeCount(0); ++i) {
        const auto& leaf = leaves[i];
        for (std::uint32_t n = 0; n < 512; ++n) {
            if (!leaf.isActive(n)) continue;
            const float v = leaf.getValue(n);
            s.sum += v;
            ++s.count;
            if (v > leaf.maximum() || v < leaf.minimum()) s.statsAreBounds = false;
        }
    }
    return s;
}

glm::vec3 apply(const glm::mat4& m, glm::vec3 p) {
    return glm::vec3(m * glm::vec4(p, 1.0f));
}

class VdbRealFiles : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = NIMBUS_SHARED_VDB_DIR;
        if (!fs::is_directory(dir_)) {
            GTEST_SKIP() << "the shared VDB test files are not here (" << dir_
                         << " is absent): real third-party VDB tests skipped";
        }
    }
    std::string file(const std::string& name) const {
        std::string p = (fs::path(dir_) / name).string();
        if (!fs::exists(p)) ADD_FAILURE() << "missing shared test file " << p;
        return p;
    }
    std::vector<char> bytes(const std::string& path) const {
        std::ifstream in(path, std::ios::binary);
        return std::vector<char>(std::istreambuf_iterator<char>(in), {});
    }
    std::string writeBytes(const std::string& name, const char* data, std::size_t n) const {
        std::string p = (tmp_ / name).string();
        std::ofstream out(p, std::ios::binary);
        out.write(data, std::streamsize(n));
        return p;
    }

    std::string dir_;
    TempDir tmp_{"vdbfiles"};
};

} // namespace

TEST_F(VdbRealFiles, OpenVdbSmoke1HalfFloatV222Loads) {
    const auto t0 = std::chrono::steady_clock::now();
    LoadedVdbGrid g = loadVdbGrid({.path = file("openvdb_smoke1.vdb")});
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    // open + read + sanitise + NanoVDB conversion, in a child process
    RecordProperty("smoke1_load_ms", std::to_string(ms));

    EXPECT_EQ(g.fileVersion, 222u);
    EXPECT_EQ(g.libraryVersion, "1.1");
    EXPECT_EQ(g.sourceValueType, "half");
    EXPECT_EQ(g.gridClass, "fog volume");
    EXPECT_EQ(g.gridName, "density");
    EXPECT_EQ(g.activeVoxelCount, 1049275u);
    EXPECT_EQ(g.activeTileCount, 0u);
    EXPECT_EQ(g.gridsRead, 1);
    EXPECT_TRUE(g.warnings.empty()) << g.warnings.front();
    EXPECT_NEAR(g.maxValue, 5.71484f, 1e-4f);
    EXPECT_GT(g.minValue, 0.0f);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(g.voxelSize[a], 0.476f, 5e-4f) << a;
    EXPECT_EQ(g.indexMin, glm::ivec3(1, 2, 1));
    EXPECT_EQ(g.indexMax, glm::ivec3(111, 223, 112));

    const nanovdb::FloatGrid* nano = g.grid();
    ASSERT_NE(nano, nullptr);
    EXPECT_EQ(nano->activeVoxelCount(), 1049275u);
    EXPECT_TRUE(nano->hasMinMax());
    EXPECT_FLOAT_EQ(nano->tree().root().maximum(), g.maxValue);
    LeafSummary s = summarize(*nano);
    EXPECT_EQ(s.count, 1049275u);
    EXPECT_NEAR(s.sum, 171500.0, 1.0); // OpenVDB's own sum of the active values: 171500 (6 digits)
    EXPECT_TRUE(s.statsAreBounds) << "a leaf's min/max does not bound its values: no majorant";

    // World bounds = the cells of the index bounds [1-0.5, 111+0.5] ... through the transform.
    const glm::vec3 lo = apply(g.worldFromIndex, glm::vec3(0.5f, 1.5f, 0.5f));
    const glm::vec3 hi = apply(g.worldFromIndex, glm::vec3(111.5f, 223.5f, 112.5f));
    for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(g.worldBounds.lo[a], lo[a], 1e-4f) << a;
        EXPECT_NEAR(g.worldBounds.hi[a], hi[a], 1e-4f) << a;
    }
    // indexFromWorld really is the inverse.
    const glm::vec3 ijk(17.0f, 200.0f, 3.0f);
    const glm::vec3 back = apply(g.indexFromWorld, apply(g.worldFromIndex, ijk));
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(back[a], ijk[a], 1e-3f);
}

TEST_F(VdbRealFiles, UsdSmokeFrame1IsEmptyAndLoadsWithAWarning) {
    LoadedVdbGrid g = loadVdbGrid({.path = file("usd_smoke_000001.vdb")});
    EXPECT_TRUE(g.empty());
    EXPECT_EQ(g.activeVoxelCount, 0u);
    ASSERT_NE(g.grid(), nullptr);
    EXPECT_EQ(g.grid()->activeVoxelCount(), 0u);
    EXPECT_TRUE(g.worldBounds.empty());
    ASSERT_EQ(g.warnings.size(), 1u);
    EXPECT_TRUE(contains(g.warnings[0], "usd_smoke_000001.vdb: grid \"density\": is empty"));
    EXPECT_EQ(g.gridsInFile, 4);
    EXPECT_EQ(g.gridsRead, 1);
    // Sampling an empty grid gives 0 everywhere.
    auto acc = g.grid()->getAccessor();
    EXPECT_EQ(acc.getValue(nanovdb::Coord(3, 4, 5)), 0.0f);
}

TEST_F(VdbRealFiles, MantaflowSelectsDensityAndReadsOnlyThatGrid) {
    const std::string path = file("blender_mantaflow_fluid_data_0001.vdb");
    LoadedVdbGrid g = loadVdbGrid({.path = path});
    EXPECT_EQ(g.fileVersion, 224u);
    EXPECT_EQ(g.libraryVersion, "12.0");
    EXPECT_EQ(g.sourceValueType, "half");
    EXPECT_EQ(g.gridsInFile, 8);
    ASSERT_EQ(g.gridsInFileInfo.size(), 8u);
    EXPECT_NE(g.gridsInFileInfo[0].name, "density") << "density should not be the first grid";
    EXPECT_EQ(g.gridsRead, 1);
    EXPECT_EQ(g.activeVoxelCount, 1016u);
    EXPECT_GT(g.maxValue, 0.0f);
    const LeafSummary before = summarize(*g.grid());

    // Proof that no other grid's data is read: overwrite every byte of every other grid (its
    // metadata, transform, topology and voxels) with garbage; density must load identically.
    std::vector<char> data = bytes(path);
    int wiped = 0;
    for (const VdbGridInfo& info : g.gridsInFileInfo) {
        if (info.name == "density") continue;
        ASSERT_LE(info.dataEnd, data.size());
        ASSERT_LT(info.dataBegin, info.dataEnd);
        for (std::uint64_t b = info.dataBegin; b < info.dataEnd; ++b) data[b] = char(0xA5);
        ++wiped;
    }
    EXPECT_EQ(wiped, 7);
    const std::string wipedPath = writeBytes("others_wiped.vdb", data.data(), data.size());
    LoadedVdbGrid w = loadVdbGrid({.path = wipedPath});
    EXPECT_EQ(w.gridsRead, 1);
    EXPECT_EQ(w.activeVoxelCount, g.activeVoxelCount);
    const LeafSummary after = summarize(*w.grid());
    EXPECT_EQ(after.count, before.count);
    EXPECT_EQ(after.sum, before.sum);
    // ... and the wiped file really is broken for the other grids.
    // (quickly: the scan of the grid's header refuses garbage lengths before OpenVDB sees them).
    EXPECT_TRUE(contains(loadError({.path = wipedPath, .gridName = "temperature"}),
                         "grid \"temperature\": corrupted file"));
}

TEST_F(VdbRealFiles, MantaflowVectorGridIsRefusedAsDensity) {
    std::string msg =
        loadError({.path = file("blender_mantaflow_fluid_data_0001.vdb"), .gridName = "velocity"});
    EXPECT_TRUE(contains(msg, "blender_mantaflow_fluid_data_0001.vdb: grid \"velocity\": "));
    EXPECT_TRUE(contains(msg, "vec3"));
    EXPECT_TRUE(contains(msg, "vector grid"));
}

TEST_F(VdbRealFiles, MissingGridNameListsTheGridsThatExist) {
    std::string msg =
        loadError({.path = file("blender_mantaflow_fluid_data_0001.vdb"), .gridName = "densty"});
    EXPECT_TRUE(contains(msg, "grid \"densty\": no grid of that name"));
    EXPECT_TRUE(contains(msg, "the file has 8 grids"));
    for (const char* g : {"color_b (half)", "density (half)", "flame (half)", "shadow (half)",
                          "temperature (half)", "velocity (vec3h)"}) {
        EXPECT_TRUE(contains(msg, g));
    }
    EXPECT_TRUE(contains(msg, "did you mean \"density\"?"));

    msg = loadError({.path = file("usd_smoke_000001.vdb"), .gridName = "smoke"});
    EXPECT_TRUE(contains(msg, "the file has 4 grids: density (float), shadow (float), "
                              "velocity (vec3s), obstacles (int32)")); // file order
    msg = loadError({.path = file("usd_smoke_000001.vdb"), .gridName = "obstacles"});
    EXPECT_TRUE(contains(msg, "holds int32 values"));
}

TEST_F(VdbRealFiles, GafferLevelSetIsRefusedUnlessConverted) {
    const std::string path = file("gaffer_sphere.vdb");
    std::string msg = loadError({.path = path, .gridName = "ls_sphere"});
    EXPECT_TRUE(contains(msg, "gaffer_sphere.vdb: grid \"ls_sphere\": is a level set"));
    EXPECT_TRUE(contains(msg, "Set levelset_to_fog = true in the scene's [field]"));
    // The default grid name is not there: the message names the level set that is.
    msg = loadError({.path = path});
    EXPECT_TRUE(contains(msg, "ls_sphere (half)"));

    LoadedVdbGrid g = loadVdbGrid({.path = path, .gridName = "ls_sphere", .levelsetToFog = true});
    EXPECT_EQ(g.gridClass, "level set");
    EXPECT_EQ(g.fileVersion, 222u);
    EXPECT_FLOAT_EQ(g.maxValue, 1.0f);
    EXPECT_GE(g.minValue, 0.0f);
    EXPECT_GT(g.activeTileCount, 0u) << "sdfToFogVolume fills the interior with active tiles";
    EXPECT_EQ(g.negativeCount, 0u);
    // Inside the sphere (radius ~3 world units, voxel 0.05): density 1, also through the
    // interior tiles; far outside: 0.
    auto acc = g.grid()->getAccessor();
    auto trilinear = nanovdb::createSampler<1>(acc);
    for (glm::vec3 p : {glm::vec3(0.0f), glm::vec3(1.0f, -1.0f, 0.5f), glm::vec3(-2.0f, 0, 0)}) {
        const glm::vec3 ijk = apply(g.indexFromWorld, p);
        EXPECT_FLOAT_EQ(trilinear(nanovdb::Vec3f(ijk.x, ijk.y, ijk.z)), 1.0f)
            << p.x << "," << p.y << "," << p.z;
    }
    EXPECT_EQ(acc.getValue(nanovdb::Coord(100, 0, 0)), 0.0f);
    // The active values, tiles included, are bounded by the node statistics.
    EXPECT_FLOAT_EQ(g.grid()->tree().root().maximum(), 1.0f);
}

TEST_F(VdbRealFiles, DaichiDoubleGridLoadsAsFloat) {
    LoadedVdbGrid g = loadVdbGrid({.path = file("daichi_smoke.vdb")});
    EXPECT_EQ(g.sourceValueType, "double");
    EXPECT_EQ(g.activeVoxelCount, 524288u);
    EXPECT_EQ(g.indexMin, glm::ivec3(0, 0, 0));
    EXPECT_EQ(g.indexMax, glm::ivec3(127, 63, 63));
    EXPECT_NEAR(g.maxValue, 1.0f, 1e-6f);
    EXPECT_GE(g.minValue, 0.0f);
    const glm::vec3 origin = apply(g.worldFromIndex, glm::vec3(0.0f));
    EXPECT_EQ(origin, glm::vec3(-64.0f, -32.0f, 0.0f));
    EXPECT_TRUE(summarize(*g.grid()).statsAreBounds);
}

TEST_F(VdbRealFiles, UsdDensityAndHeatPicksHeatByName) {
    const std::string path = file("usd_densityAndHeat.vdb");
    LoadedVdbGrid heat = loadVdbGrid({.path = path, .gridName = "heat"});
    EXPECT_EQ(heat.gridName, "heat");
    EXPECT_EQ(heat.activeVoxelCount, 5224u);
    EXPECT_NEAR(heat.maxValue, 0.759538f, 1e-5f);
    EXPECT_EQ(heat.gridClass, "unknown");
    LoadedVdbGrid density = loadVdbGrid({.path = path});
    EXPECT_EQ(density.activeVoxelCount, 6124u);
    EXPECT_NEAR(density.maxValue, 0.997509f, 1e-5f);
}

TEST_F(VdbRealFiles, UsdSmokeFrame2HonoursNonUniformVoxels) {
    LoadedVdbGrid g = loadVdbGrid({.path = file("usd_smoke_000002.vdb")});
    EXPECT_EQ(g.activeVoxelCount, 71983u);
    const glm::vec3 expected(0.1326f, 0.1329f, 0.1317f);
    for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(g.voxelSize[a], expected[a], 5e-5f) << a;
        // The index axes of worldFromIndex carry the same lengths (no rotation here).
        EXPECT_NEAR(g.worldFromIndex[a][a], expected[a], 5e-5f) << a;
    }
    EXPECT_GT(g.voxelSize.y, g.voxelSize.x);
    EXPECT_GT(g.voxelSize.x, g.voxelSize.z);
    // One index step along each axis moves by that axis' own voxel size.
    const glm::vec3 w0 = apply(g.worldFromIndex, glm::vec3(1, 1, 11));
    const glm::vec3 w1 = apply(g.worldFromIndex, glm::vec3(2, 2, 12));
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(w1[a] - w0[a], g.voxelSize[a], 1e-6f);
    EXPECT_NEAR(apply(g.worldFromIndex, glm::vec3(0.0f)).x, -3.45f, 0.01f);
}

TEST_F(VdbRealFiles, HoudiniDragonAndGafferFogSphereLoad) {
    LoadedVdbGrid dragon = loadVdbGrid({.path = file("vpt_dragon.vdb")});
    EXPECT_EQ(dragon.activeVoxelCount, 19660u);
    EXPECT_NEAR(dragon.voxelSize.x, 0.1f, 1e-6f);
    EXPECT_NEAR(dragon.maxValue, 1.0f, 1e-6f);
    EXPECT_TRUE(contains(dragon.creator, "Houdini"));
    EXPECT_TRUE(dragon.warnings.empty());

    LoadedVdbGrid sphere = loadVdbGrid({.path = file("gaffer_fogsphere_small.vdb")});
    EXPECT_EQ(sphere.activeVoxelCount, 465u);
    EXPECT_EQ(sphere.fileVersion, 223u);
    EXPECT_EQ(sphere.indexMin, glm::ivec3(-5, -4, -5));
    EXPECT_EQ(sphere.indexMax, glm::ivec3(5, 4, 5));
    const glm::vec3 c = apply(sphere.worldFromIndex, glm::vec3(0.0f));
    EXPECT_NEAR(c.y, 2.0f, 1e-6f);
    // Trilinear sampling at a voxel centre returns that voxel's value.
    auto acc = sphere.grid()->getAccessor();
    auto trilinear = nanovdb::createSampler<1>(acc);
    EXPECT_FLOAT_EQ(trilinear(nanovdb::Vec3f(0, 0, 0)), acc.getValue(nanovdb::Coord(0, 0, 0)));
    EXPECT_GT(acc.getValue(nanovdb::Coord(0, 0, 0)), 0.5f);
}

TEST_F(VdbRealFiles, EveryFileListsItsGrids) {
    struct Expect {
        const char* file;
        std::size_t grids;
    };
    for (Expect e : {Expect{"openvdb_smoke1.vdb", 1}, Expect{"usd_smoke_000001.vdb", 4},
                     Expect{"usd_smoke_000002.vdb", 1}, Expect{"usd_smoke_000003.vdb", 1},
                     Expect{"usd_densityAndHeat.vdb", 2}, Expect{"vpt_dragon.vdb", 1},
                     Expect{"blender_mantaflow_fluid_data_0001.vdb", 8},
                     Expect{"gaffer_fogsphere_small.vdb", 1}, Expect{"gaffer_sphere.vdb", 1},
                     Expect{"daichi_smoke.vdb", 1}}) {
        EXPECT_EQ(listVdbGrids(file(e.file)).size(), e.grids) << e.file;
    }
}

TEST_F(VdbRealFiles, TruncatedCopiesGiveAVdbErrorNotACrash) {
    for (const char* name : {"openvdb_smoke1.vdb", "blender_mantaflow_fluid_data_0001.vdb",
                             "vpt_dragon.vdb", "daichi_smoke.vdb"}) {
        const std::vector<char> data = bytes(file(name));
        ASSERT_GT(data.size(), 1000u);
        std::vector<std::size_t> cuts = {0, 1, 7, 8, 12, 20, 50, 100, 300, 1000};
        for (int i = 1; i < 16; ++i) cuts.push_back(data.size() * i / 16);
        cuts.push_back(data.size() - 1);
        for (std::size_t n : cuts) {
            const std::string p =
                writeBytes("cut_" + std::to_string(n) + "_" + name, data.data(), n);
            std::string msg = loadError({.path = p});
            EXPECT_TRUE(contains(msg, p)) << name << " cut at " << n;
            if (n > 1000) EXPECT_TRUE(contains(msg, "truncated")) << name << " cut at " << n;
        }
    }
}

TEST_F(VdbRealFiles, UsdSmokeIsAFrameSequence) {
    const std::string pattern = (fs::path(dir_) / "usd_smoke_######.vdb").string();
    VdbFrameFile f2 = resolveVdbFrame(pattern, 2);
    EXPECT_FALSE(f2.held);
    EXPECT_EQ(fs::path(f2.path).filename(), "usd_smoke_000002.vdb");
    VdbFrameFile f5 = resolveVdbFrame(pattern, 5, /*hold=*/true);
    EXPECT_TRUE(f5.held);
    EXPECT_EQ(f5.sourceFrame, 3);
    EXPECT_TRUE(contains(f5.warning, "usd_smoke_000005.vdb"));
    EXPECT_TRUE(contains(f5.warning, "holding frame 3"));
    LoadedVdbGrid g = loadVdbGrid({.path = f5.path});
    EXPECT_EQ(g.activeVoxelCount, 90197u);
}
