/// @file test_vdb_reader.cpp
/// @brief loadVdbGrid() on hand-built grids with answers known in advance: transforms, value
///        types, grid classes, active tiles, NaN/Inf/negative values, and broken files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <nanovdb/NanoVDB.h> // SampleFromVoxels.h does not include it itself
#include <nanovdb/util/SampleFromVoxels.h>

#include "plugin/vdb/vdb_reader.h"
#include "plugin/vdb/vdb_writer.h"
#include "tests/test_util.h"
#include "tests/vdb_test_util.h"

using namespace nimbus::vdb;
namespace fs = std::filesystem;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

std::string joined(const std::vector<std::string>& lines) {
    std::string s;
    for (const std::string& l : lines) s += l + "\n";
    return s;
}

class VdbReader : public ::testing::Test {
  protected:
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    std::string write(const std::string& name, const std::vector<VdbGridSpec>& grids) const {
        std::string p = path(name);
        writeVdbGrids(p, grids);
        return p;
    }
    std::string writeBytes(const std::string& name, const std::vector<char>& data) const {
        std::string p = path(name);
        std::ofstream out(p, std::ios::binary);
        out.write(data.data(), std::streamsize(data.size()));
        return p;
    }
    std::vector<char> bytes(const std::string& p) const {
        std::ifstream in(p, std::ios::binary);
        return std::vector<char>(std::istreambuf_iterator<char>(in), {});
    }
    TempDir dir_{"vdbreader"};
};

VdbGridSpec::Voxel voxel(int i, int j, int k, double v, bool active = true) {
    return VdbGridSpec::Voxel{glm::ivec3(i, j, k), v, active};
}

float valueAt(const LoadedVdbGrid& g, int i, int j, int k) {
    return g.grid()->getAccessor().getValue(nanovdb::Coord(i, j, k));
}

} // namespace

TEST_F(VdbReader, ScaleRotationTranslationTransformRoundTrips) {
    // worldFromIndex = T * R * S: non-uniform scale, a rotation about a skew axis, a far offset.
    const glm::dvec3 scale(0.5, 2.0, 0.25);
    const glm::dvec3 axis = glm::normalize(glm::dvec3(1.0, 2.0, 3.0));
    const glm::dvec3 offset(1000.0, -50.0, 7.0);
    const glm::dmat4 M = glm::translate(glm::dmat4(1.0), offset) *
                         glm::rotate(glm::dmat4(1.0), glm::radians(30.0), axis) *
                         glm::scale(glm::dmat4(1.0), scale);
    VdbGridSpec spec;
    spec.worldFromIndex = M;
    spec.voxels = {voxel(0, 0, 0, 1.0), voxel(-3, 5, 9, 0.5), voxel(40, -7, 2, 0.25)};
    LoadedVdbGrid g = loadVdbGrid({.path = write("xform.vdb", {spec})});
    EXPECT_TRUE(g.warnings.empty()) << joined(g.warnings);

    for (glm::ivec3 ijk :
         {glm::ivec3(0), glm::ivec3(-3, 5, 9), glm::ivec3(40, -7, 2), glm::ivec3(100, 200, -300)}) {
        const glm::dvec3 expected = glm::dvec3(M * glm::dvec4(glm::dvec3(ijk), 1.0));
        const glm::vec3 world = glm::vec3(g.worldFromIndex * glm::vec4(glm::vec3(ijk), 1.0f));
        const glm::vec3 index = glm::vec3(g.indexFromWorld * glm::vec4(glm::vec3(expected), 1.0f));
        // NanoVDB's own (double) map agrees.
        const nanovdb::Vec3d nanoWorld =
            g.grid()->indexToWorld(nanovdb::Vec3d(ijk.x, ijk.y, ijk.z));
        for (int a = 0; a < 3; ++a) {
            EXPECT_NEAR(world[a], expected[a], 1e-6 * std::abs(expected[a]) + 1e-4) << a;
            EXPECT_NEAR(index[a], float(ijk[a]), 2e-3f) << a; // float inverse at |world| ~ 1000
            EXPECT_NEAR(nanoWorld[a], expected[a], 1e-9) << a;
        }
    }
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(g.voxelSize[a], float(scale[a]), 1e-6f) << a;

    // World bounds: the transformed corners of the cells of index box [-3,40]x[-7,5]x[0,9].
    glm::dvec3 lo(1e30), hi(-1e30);
    for (int c = 0; c < 8; ++c) {
        glm::dvec3 ijk(c & 1 ? 40.5 : -3.5, c & 2 ? 5.5 : -7.5, c & 4 ? 9.5 : -0.5);
        glm::dvec3 w = glm::dvec3(M * glm::dvec4(ijk, 1.0));
        lo = glm::min(lo, w);
        hi = glm::max(hi, w);
    }
    for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(g.worldBounds.lo[a], lo[a], 1e-3) << a;
        EXPECT_NEAR(g.worldBounds.hi[a], hi[a], 1e-3) << a;
    }
    EXPECT_EQ(valueAt(g, -3, 5, 9), 0.5f);
}

TEST_F(VdbReader, NanInfAndNegativeValuesAreSanitisedAndCounted) {
    VdbGridSpec spec;
    spec.voxels = {voxel(0, 0, 0, kNaN),       voxel(1, 0, 0, kInf),       voxel(2, 0, 0, -kInf),
                   voxel(3, 0, 0, -0.5),       voxel(4, 0, 0, -2.0),       voxel(5, 0, 0, 0.3),
                   voxel(6, 0, 0, 0.7, false), voxel(7, 0, 0, kNaN, false)};
    spec.tiles = {VdbGridSpec::Tile{glm::ivec3(64, 64, 64), 1, kNaN, true},
                  VdbGridSpec::Tile{glm::ivec3(96, 64, 64), 1, -1.0, true}};
    LoadedVdbGrid g = loadVdbGrid({.path = write("nan.vdb", {spec})});
    EXPECT_EQ(g.nonFiniteCount, 4u); // NaN, +Inf, -Inf voxels and the NaN tile
    EXPECT_EQ(g.negativeCount, 3u);  // -0.5, -2 and the -1 tile
    EXPECT_EQ(g.inactiveNonZeroCount, 2u);
    const std::string w = joined(g.warnings);
    EXPECT_TRUE(contains(w, "nan.vdb: grid \"density\": 4 NaN/Inf value(s) replaced by 0"));
    EXPECT_TRUE(contains(w, "3 negative value(s) clamped to 0 (most negative -2"));
    EXPECT_TRUE(contains(w, "2 inactive voxel/tile value(s)"));
    for (int i = 0; i < 8; ++i) EXPECT_EQ(valueAt(g, i, 0, 0), i == 5 ? 0.3f : 0.0f) << i;
    EXPECT_EQ(valueAt(g, 66, 66, 66), 0.0f);
    EXPECT_EQ(valueAt(g, 99, 66, 66), 0.0f);
    EXPECT_FLOAT_EQ(g.maxValue, 0.3f);
    EXPECT_EQ(g.minValue, 0.0f);
    EXPECT_FLOAT_EQ(g.grid()->tree().root().maximum(), 0.3f);
    // No NaN anywhere a trilinear lookup can reach.
    auto acc = g.grid()->getAccessor();
    auto trilinear = nanovdb::createSampler<1>(acc);
    for (float x = -1.0f; x < 9.0f; x += 0.25f) {
        EXPECT_TRUE(std::isfinite(trilinear(nanovdb::Vec3f(x, 0.3f, 0.1f)))) << x;
    }
}

TEST_F(VdbReader, NonZeroBackgroundIsSetToZeroWithAWarning) {
    VdbGridSpec spec;
    spec.background = 0.25;
    spec.voxels = {voxel(0, 0, 0, 1.0)};
    LoadedVdbGrid g = loadVdbGrid({.path = write("bg.vdb", {spec})});
    EXPECT_TRUE(contains(joined(g.warnings), "background value 0.25"));
    EXPECT_EQ(valueAt(g, 1, 0, 0), 0.0f);    // inactive voxel of the same leaf
    EXPECT_EQ(valueAt(g, 5000, 0, 0), 0.0f); // outside every node
    EXPECT_EQ(g.grid()->tree().background(), 0.0f);
}

TEST_F(VdbReader, ActiveTilesAreSampledAndBoundedByNodeStatistics) {
    VdbGridSpec spec;
    spec.tiles = {VdbGridSpec::Tile{glm::ivec3(16, 16, 16), 1, 2.0, true},     // 16..23, 8^3
                  VdbGridSpec::Tile{glm::ivec3(200, 200, 200), 2, 0.5, true}}; // 128..255
    spec.voxels = {voxel(24, 16, 16, 1.0)};
    LoadedVdbGrid g = loadVdbGrid({.path = write("tiles.vdb", {spec})});
    EXPECT_EQ(g.activeTileCount, 2u);
    EXPECT_EQ(g.activeVoxelCount, 512u + 128u * 128u * 128u + 1u);
    EXPECT_EQ(g.grid()->activeVoxelCount(), g.activeVoxelCount);
    EXPECT_EQ(g.indexMin, glm::ivec3(16));
    EXPECT_EQ(g.indexMax, glm::ivec3(255));
    EXPECT_FLOAT_EQ(g.worldBounds.lo.x, 15.5f);
    EXPECT_FLOAT_EQ(g.worldBounds.hi.x, 255.5f);

    auto acc = g.grid()->getAccessor();
    EXPECT_EQ(acc.getValue(nanovdb::Coord(20, 20, 20)), 2.0f);
    EXPECT_EQ(acc.getValue(nanovdb::Coord(23, 23, 23)), 2.0f);
    EXPECT_EQ(acc.getValue(nanovdb::Coord(200, 130, 255)), 0.5f);
    EXPECT_EQ(acc.getValue(nanovdb::Coord(127, 130, 200)), 0.0f);
    EXPECT_TRUE(acc.isActive(nanovdb::Coord(130, 130, 130)));
    auto trilinear = nanovdb::createSampler<1>(acc);
    EXPECT_FLOAT_EQ(trilinear(nanovdb::Vec3f(20.3f, 18.6f, 21.0f)), 2.0f);     // inside the tile
    EXPECT_FLOAT_EQ(trilinear(nanovdb::Vec3f(23.5f, 16.0f, 16.0f)), 1.5f);     // tile | voxel
    EXPECT_FLOAT_EQ(trilinear(nanovdb::Vec3f(15.5f, 20.0f, 20.0f)), 1.0f);     // empty | tile
    EXPECT_FLOAT_EQ(trilinear(nanovdb::Vec3f(127.75f, 150.f, 150.f)), 0.375f); // empty | tile

    // Majorants: the root and the upper node see the tiles' values.
    EXPECT_FLOAT_EQ(g.grid()->tree().root().maximum(), 2.0f);
    const auto* upper = g.grid()->tree().getFirstUpper();
    ASSERT_EQ(g.grid()->tree().nodeCount(2), 1u);
    EXPECT_FLOAT_EQ(upper->maximum(), 2.0f);
    EXPECT_EQ(upper->minimum(), 0.5f);
}

TEST_F(VdbReader, DoubleAndHalfGridsLoadAsFloat) {
    VdbGridSpec d;
    d.valueType = "double";
    d.voxels = {voxel(0, 0, 0, 0.25), voxel(1, 0, 0, 1e-3), voxel(2, 0, 0, 1e300)};
    LoadedVdbGrid gd = loadVdbGrid({.path = write("double.vdb", {d})});
    EXPECT_EQ(gd.sourceValueType, "double");
    EXPECT_EQ(valueAt(gd, 0, 0, 0), 0.25f);
    EXPECT_EQ(valueAt(gd, 1, 0, 0), float(1e-3));
    EXPECT_EQ(valueAt(gd, 2, 0, 0), 0.0f) << "1e300 is Inf as a float: sanitised";
    EXPECT_EQ(gd.nonFiniteCount, 1u);

    VdbGridSpec h;
    h.valueType = "half";
    h.voxels = {voxel(0, 0, 0, 0.1), voxel(0, 1, 0, 3.0)};
    LoadedVdbGrid gh = loadVdbGrid({.path = write("half.vdb", {h})});
    EXPECT_EQ(gh.sourceValueType, "half");
    EXPECT_NE(valueAt(gh, 0, 0, 0), 0.1f) << "stored as 16 bits";
    EXPECT_NEAR(valueAt(gh, 0, 0, 0), 0.1f, 1e-4f);
    EXPECT_EQ(valueAt(gh, 0, 1, 0), 3.0f);
    EXPECT_TRUE(gh.warnings.empty()) << joined(gh.warnings);
}

TEST_F(VdbReader, GridClassesLevelSetRefusedUnknownAccepted) {
    VdbGridSpec ls;
    ls.name = "surface";
    ls.gridClass = "level set";
    ls.background = 0.3;
    ls.voxels = {voxel(0, 0, 0, -0.1), voxel(1, 0, 0, 0.1)};
    VdbGridSpec unknown;
    unknown.name = "density";
    unknown.gridClass = "unknown";
    unknown.voxels = {voxel(0, 0, 0, 1.0)};
    const std::string p = write("classes.vdb", {ls, unknown});

    std::string msg = loadError({.path = p, .gridName = "surface"});
    EXPECT_TRUE(contains(msg, "classes.vdb: grid \"surface\": is a level set"));
    EXPECT_TRUE(contains(msg, "Set levelset_to_fog = true in the scene's [field]"));
    LoadedVdbGrid fog = loadVdbGrid({.path = p, .gridName = "surface", .levelsetToFog = true});
    EXPECT_EQ(fog.gridClass, "level set");
    EXPECT_LE(fog.maxValue, 1.0f);
    EXPECT_GE(fog.minValue, 0.0f);
    EXPECT_GT(valueAt(fog, 0, 0, 0), 0.0f) << "inside (negative distance) is dense";
    EXPECT_EQ(valueAt(fog, 1, 0, 0), 0.0f) << "outside is empty";

    LoadedVdbGrid g = loadVdbGrid({.path = p});
    EXPECT_EQ(g.gridClass, "unknown");
    EXPECT_TRUE(g.warnings.empty()) << joined(g.warnings);
    EXPECT_EQ(g.gridsInFile, 2);
    EXPECT_EQ(g.gridsRead, 1);
}

TEST_F(VdbReader, VectorAndIntegerGridsAreRefusedMissingNamesListed) {
    VdbGridSpec density, temperature, vel, flags;
    density.voxels = {voxel(0, 0, 0, 1.0)};
    temperature.name = "temperature";
    temperature.valueType = "double";
    vel.name = "vel";
    vel.valueType = "vec3s";
    vel.voxels = {voxel(0, 0, 0, 1.0)};
    flags.name = "flags";
    flags.valueType = "int32";
    const std::string p = write("many.vdb", {density, temperature, vel, flags});

    std::string msg = loadError({.path = p, .gridName = "vel"});
    EXPECT_TRUE(contains(msg, "many.vdb: grid \"vel\": holds vec3s values (a vector grid"));
    msg = loadError({.path = p, .gridName = "flags"});
    EXPECT_TRUE(contains(msg, "grid \"flags\": holds int32 values"));
    msg = loadError({.path = p, .gridName = "Density"});
    EXPECT_TRUE(contains(msg, "many.vdb: grid \"Density\": no grid of that name"));
    EXPECT_TRUE(contains(msg, "the file has 4 grids: density (float), temperature (double), "
                              "vel (vec3s), flags (int32)"));
    EXPECT_TRUE(contains(msg, "did you mean \"density\"?"));
    msg = loadError({.path = p, .gridName = "smoke"});
    EXPECT_FALSE(contains(msg, "did you mean")) << "no suggestion for an unrelated name";

    std::vector<VdbGridInfo> list = listVdbGrids(p);
    ASSERT_EQ(list.size(), 4u);
    EXPECT_EQ(list[2].name, "vel");
    EXPECT_EQ(list[2].valueType, "vec3s");
}

TEST_F(VdbReader, OnlyTheNamedGridIsRead) {
    VdbGridSpec a, b, c;
    a.name = "a";
    a.voxels = {voxel(0, 0, 0, 1.0)};
    b.name = "b";
    for (int i = 0; i < 40; ++i) b.voxels.push_back(voxel(i, i, i, 0.5));
    c.name = "c";
    c.voxels = {voxel(5, 5, 5, 3.0)};
    const std::string p = write("three.vdb", {a, b, c});
    LoadedVdbGrid g = loadVdbGrid({.path = p, .gridName = "b"});
    EXPECT_EQ(g.gridsRead, 1);
    EXPECT_EQ(g.gridsInFile, 3);
    EXPECT_EQ(g.activeVoxelCount, 40u);

    // Wipe the bytes of grids a and c: b still loads identically, a does not.
    std::vector<char> data = bytes(p);
    for (const VdbGridInfo& info : g.gridsInFileInfo) {
        if (info.name == "b") continue;
        for (std::uint64_t i = info.dataBegin; i < info.dataEnd; ++i) data[i] = char(0x5A);
    }
    const std::string wiped = writeBytes("wiped.vdb", data);
    LoadedVdbGrid w = loadVdbGrid({.path = wiped, .gridName = "b"});
    EXPECT_EQ(w.activeVoxelCount, 40u);
    for (int i = 0; i < 40; ++i) EXPECT_EQ(valueAt(w, i, i, i), 0.5f);
    EXPECT_TRUE(contains(loadError({.path = wiped, .gridName = "a"}), "corrupted file"));
}

TEST_F(VdbReader, EmptyGridLoadsEmptyWithAWarning) {
    VdbGridSpec spec;
    LoadedVdbGrid g = loadVdbGrid({.path = write("empty.vdb", {spec})});
    EXPECT_TRUE(g.empty());
    ASSERT_NE(g.grid(), nullptr);
    EXPECT_TRUE(g.worldBounds.empty());
    EXPECT_GT(g.indexMin.x, g.indexMax.x);
    ASSERT_EQ(g.warnings.size(), 1u);
    EXPECT_TRUE(contains(g.warnings[0], "empty.vdb: grid \"density\": is empty"));
}

TEST_F(VdbReader, MissingEmptyDirectoryAndRandomFilesGiveVdbErrors) {
    std::string msg = loadError({.path = path("nope.vdb")});
    EXPECT_TRUE(contains(msg, path("nope.vdb") + ": cannot open the file"));
    msg = loadError({.path = writeBytes("zero.vdb", {})});
    EXPECT_TRUE(contains(msg, "zero.vdb: the file is empty"));
    msg = loadError({.path = dir_.string()});
    EXPECT_TRUE(contains(msg, "is a directory"));

    std::mt19937 rng(12345);
    for (std::size_t size : {5u, 100u, 4096u, 100000u}) {
        std::vector<char> junk(size);
        for (char& c : junk) c = char(rng());
        const std::string p = writeBytes("random_" + std::to_string(size) + ".vdb", junk);
        msg = loadError({.path = p});
        EXPECT_TRUE(contains(msg, p + ": not a VDB file")) << size;
    }
    // A valid VDB magic number and version followed by garbage.
    for (int seed = 0; seed < 20; ++seed) {
        std::vector<char> junk(2000);
        std::mt19937 r(seed);
        for (char& c : junk) c = char(r());
        const std::int64_t magic = 0x56444220;
        const std::uint32_t version = 224;
        std::memcpy(junk.data(), &magic, 8);
        std::memcpy(junk.data() + 8, &version, 4);
        const std::string p = writeBytes("magic_" + std::to_string(seed) + ".vdb", junk);
        msg = loadError({.path = p});
        EXPECT_TRUE(contains(msg, p)) << seed;
    }
}

TEST_F(VdbReader, EveryTruncationOfAHandBuiltFileIsAVdbError) {
    VdbGridSpec a, b;
    a.name = "temperature";
    for (int i = 0; i < 300; ++i) a.voxels.push_back(voxel(i % 37, i % 11, i, 0.01 * i));
    b.voxels = a.voxels;
    const std::vector<char> data = bytes(write("full.vdb", {a, b}));
    ASSERT_GT(data.size(), 500u);
    for (std::size_t n = 0; n < data.size(); n += std::max<std::size_t>(1, data.size() / 97)) {
        const std::string p =
            writeBytes("cut.vdb", std::vector<char>(data.begin(), data.begin() + n));
        EXPECT_TRUE(contains(loadError({.path = p}), p)) << "cut at " << n;
    }
    // The whole file loads.
    EXPECT_EQ(loadVdbGrid({.path = writeBytes("whole.vdb", data)}).activeVoxelCount, 300u);
}
