/// @file test_vdb_velocity.cpp
/// @brief Velocity (vec3) grids from VDB files (plugin/vdb/vdb_velocity.h): known linear fields
///        written with OpenVDB (centred and staggered) read back exactly; Mantaflow's staggered
///        `velocity`; the refusals and their messages; the binding of `[field.advect]` grids;
///        and `nimbus bake --velocity` (the field's wind written beside its density).
#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/scene.h"
#include "core/sim/advect.h"
#include "plugin/vdb/vdb_isolate.h"
#include "plugin/vdb/vdb_reader.h"
#include "plugin/vdb/vdb_velocity.h"
#include "plugin/vdb/vdb_writer.h"
#include "test_util.h"
#include "tests/vdb_test_util.h"

using namespace nimbus;
using namespace nimbus::vdb;

namespace {

/// The known field: v(p) = A p + b (world units / s), linear, so trilinear interpolation of
/// exact samples reproduces it exactly (up to float rounding).
vec3 linearVelocity(glm::dvec3 p) {
    const glm::dvec3 v(0.5 * p.x - 0.25 * p.y + 1.0, 0.125 * p.x + 0.75 * p.z - 2.0,
                       -0.375 * p.y + 0.25 * p.z + 0.5);
    return vec3(v);
}

constexpr double kVoxel = 0.5;
const glm::dvec3 kTranslation(10.0, -3.0, 2.0);

glm::dvec3 worldOf(glm::dvec3 ijk) {
    return kTranslation + kVoxel * ijk;
}

/// A grid over index box [lo, hi] of the known field: centred (values at voxel centres) or
/// staggered (x on the voxel's lower x face, index (i - 1/2, j, k), and so on).
VdbGridSpec linearGrid(const std::string& name, bool staggered, const std::string& type,
                       glm::ivec3 lo = glm::ivec3(-3, 2, 5), glm::ivec3 hi = glm::ivec3(6, 9, 12)) {
    VdbGridSpec g;
    g.name = name;
    g.valueType = type;
    g.gridClass = staggered ? "staggered" : "unknown";
    g.worldFromIndex = glm::dmat4(kVoxel);
    g.worldFromIndex[3] = glm::dvec4(kTranslation, 1.0);
    for (int k = lo.z; k <= hi.z; ++k)
        for (int j = lo.y; j <= hi.y; ++j)
            for (int i = lo.x; i <= hi.x; ++i) {
                VdbGridSpec::Voxel v;
                v.ijk = glm::ivec3(i, j, k);
                v.hasVector = true;
                const glm::dvec3 c(i, j, k);
                if (staggered) {
                    v.vector = glm::dvec3(linearVelocity(worldOf(c - glm::dvec3(0.5, 0, 0))).x,
                                          linearVelocity(worldOf(c - glm::dvec3(0, 0.5, 0))).y,
                                          linearVelocity(worldOf(c - glm::dvec3(0, 0, 0.5))).z);
                } else {
                    v.vector = glm::dvec3(linearVelocity(worldOf(c)));
                }
                g.voxels.push_back(v);
            }
    return g;
}

VdbGridSpec densityGrid() {
    VdbGridSpec g;
    g.name = "density";
    g.voxels.push_back({glm::ivec3(0), 1.0});
    return g;
}

std::string loadError(const VelocityLoadOptions& o) {
    try {
        loadVdbVelocity(o);
    } catch (const VdbError& e) {
        return e.what();
    }
    ADD_FAILURE() << "no VdbError for " << o.read.path << " grid " << o.read.gridName;
    return "";
}

VelocityLoadOptions options(const std::string& path, const std::string& grid = "velocity") {
    VelocityLoadOptions o;
    o.read.path = path;
    o.read.gridName = grid;
    return o;
}

/// Max |velocityAt - linearVelocity| over a lattice of points inside index box [lo+1, hi-1]
/// (the interpolation stencil of every point lies inside the grid for both layouts).
float maxError(const LoadedVelocityGrid& g, glm::ivec3 lo, glm::ivec3 hi, int& count) {
    const sim::VelocityField f =
        g.staggered ? sim::staggeredGrid(g.grid) : sim::centredGrid(g.grid);
    EXPECT_STREQ(sim::validate(f), "");
    float err = 0.0f;
    count = 0;
    for (double z = lo.z + 1; z <= hi.z - 1; z += 0.37)
        for (double y = lo.y + 1; y <= hi.y - 1; y += 0.41)
            for (double x = lo.x + 1; x <= hi.x - 1; x += 0.43) {
                const glm::dvec3 p = worldOf(glm::dvec3(x, y, z));
                const vec3 d = sim::velocityAt(f, vec3(p)) - linearVelocity(p);
                err = std::max(err, glm::length(d));
                ++count;
            }
    return err;
}

} // namespace

TEST(VdbVelocity, CentredLinearFieldReadsBackExactly) {
    TempDir dir;
    const std::string path = (dir / "v.vdb").string();
    writeVdbGrids(path, {densityGrid(), linearGrid("vel", false, "vec3s")});
    const LoadedVelocityGrid g = loadVdbVelocity(options(path, "vel"));
    EXPECT_FALSE(g.staggered);
    EXPECT_EQ(g.gridClass, "unknown");
    EXPECT_EQ(g.sourceValueType, "vec3s");
    EXPECT_EQ(g.grid.res, ivec3(10, 8, 8));
    EXPECT_EQ(g.indexMin, glm::ivec3(-3, 2, 5));
    EXPECT_FLOAT_EQ(g.grid.frame.voxelSize, 0.5f);
    // cell 0 spans index [-3.5, -2.5] etc.: origin = world(indexMin - 1/2)
    EXPECT_NEAR(glm::length(g.grid.frame.origin - vec3(worldOf(glm::dvec3(-3.5, 1.5, 4.5)))), 0.0f,
                1e-6f);
    EXPECT_EQ(g.gridsRead, 1);
    int n = 0;
    const float err = maxError(g, glm::ivec3(-3, 2, 5), glm::ivec3(6, 9, 12), n);
    EXPECT_GT(n, 1000);
    EXPECT_LT(err, 2e-5f) << "over " << n << " points";
    RecordProperty("max_error", std::to_string(err));
}

TEST(VdbVelocity, StaggeredLinearFieldIsDetectedByItsClassAndReadsBackExactly) {
    TempDir dir;
    const std::string path = (dir / "v.vdb").string();
    writeVdbGrids(path, {linearGrid("velocity", true, "vec3s")});
    const LoadedVelocityGrid g = loadVdbVelocity(options(path));
    EXPECT_TRUE(g.staggered);
    EXPECT_EQ(g.gridClass, "staggered");
    int n = 0;
    const float err = maxError(g, glm::ivec3(-3, 2, 5), glm::ivec3(6, 9, 12), n);
    EXPECT_LT(err, 2e-5f) << "over " << n << " points";

    // Read as centred (layout forced), the same values sit half a cell off: a clear error of
    // about |dv/dx| h / 2 on the x component.
    VelocityLoadOptions o = options(path);
    o.layout = VelocityLayout::Centred;
    const LoadedVelocityGrid c = loadVdbVelocity(o);
    EXPECT_FALSE(c.staggered);
    EXPECT_GT(maxError(c, glm::ivec3(-3, 2, 5), glm::ivec3(6, 9, 12), n), 0.1f);
}

TEST(VdbVelocity, DoubleAndHalfGridsScaleAndReadInProcessTheSame) {
    TempDir dir;
    const std::string path = (dir / "v.vdb").string();
    writeVdbGrids(path, {linearGrid("vd", false, "vec3d"), linearGrid("vh", true, "vec3h")});
    VelocityLoadOptions o = options(path, "vd");
    o.scale = 2.0f;
    const LoadedVelocityGrid d = loadVdbVelocity(o);
    EXPECT_EQ(d.sourceValueType, "vec3d");
    o.read.isolate = false;
    const LoadedVelocityGrid inProcess = loadVdbVelocity(o);
    ASSERT_EQ(d.grid.v.size(), inProcess.grid.v.size());
    EXPECT_EQ(d.grid.v, inProcess.grid.v); // the child's reply carries the same bits
    const sim::VelocityField f = sim::centredGrid(d.grid);
    const glm::dvec3 p = worldOf(glm::dvec3(1.3, 5.2, 8.7));
    EXPECT_NEAR(glm::length(sim::velocityAt(f, vec3(p)) - 2.0f * linearVelocity(p)), 0.0f, 1e-4f);

    const LoadedVelocityGrid h = loadVdbVelocity(options(path, "vh"));
    EXPECT_EQ(h.sourceValueType, "vec3h");
    EXPECT_TRUE(h.staggered);
    int n = 0;
    EXPECT_LT(maxError(h, glm::ivec3(-3, 2, 5), glm::ivec3(6, 9, 12), n), 0.05f); // half floats
}

TEST(VdbVelocity, InactiveVoxelsTakeTheirNeighboursVelocityLayerByLayer) {
    // a uniform wind stored only in two separated slabs of a 12 x 6 x 6 box (x 0-1 and 10-11):
    // the voxels between are the background, (0, 0, 0)
    TempDir dir;
    const std::string path = (dir / "sparse.vdb").string();
    VdbGridSpec g;
    g.name = "velocity";
    g.valueType = "vec3s";
    g.worldFromIndex = glm::dmat4(kVoxel);
    g.worldFromIndex[3] = glm::dvec4(kTranslation, 1.0);
    const glm::dvec3 wind(1.5, -0.5, 2.0);
    for (int k = 0; k < 6; ++k)
        for (int j = 0; j < 6; ++j)
            for (int i : {0, 1, 10, 11}) {
                VdbGridSpec::Voxel v;
                v.ijk = glm::ivec3(i, j, k);
                v.hasVector = true;
                v.vector = wind;
                g.voxels.push_back(v);
            }
    writeVdbGrids(path, {g});
    VelocityLoadOptions o = options(path);
    const LoadedVelocityGrid filled = loadVdbVelocity(o);
    o.extrapolate = false;
    const LoadedVelocityGrid still = loadVdbVelocity(o);
    ASSERT_EQ(filled.grid.res, ivec3(12, 6, 6));
    EXPECT_EQ(filled.extrapolatedCells, 8u * 6u * 6u); // x = 2 .. 9
    EXPECT_EQ(still.extrapolatedCells, 0u);
    int zeros = 0;
    for (size_t i = 0; i < filled.grid.v.size(); ++i) {
        // the mean of equal neighbours is the wind itself, in every layer
        EXPECT_EQ(filled.grid.v[i], vec3(wind)) << "cell " << i;
        zeros += still.grid.v[i] == vec3(0.0f);
    }
    EXPECT_EQ(zeros, 8 * 6 * 6);
}

TEST(VdbVelocity, MantaflowVelocityIsStaggeredAndSensible) {
    const std::string path =
        std::string(NIMBUS_SHARED_VDB_DIR) + "/blender_mantaflow_fluid_data_0001.vdb";
    if (!std::filesystem::exists(path)) {
        GTEST_SKIP() << "the shared VDB test files are not here (" << path
                     << " is absent): the Mantaflow velocity test is skipped";
    }
    const std::uint64_t before = vdbReadCount();
    const LoadedVelocityGrid g = loadVdbVelocity(options(path));
    EXPECT_EQ(vdbReadCount(), before + 1);
    EXPECT_EQ(g.gridsRead, 1); // only `velocity`'s tree, of the file's 9 grids
    EXPECT_EQ(g.gridClass, "staggered");
    EXPECT_EQ(g.vectorType, "invariant"); // Mantaflow writes no vector_type
    EXPECT_EQ(g.sourceValueType, "vec3h");
    EXPECT_TRUE(g.staggered);
    EXPECT_EQ(g.indexMin, glm::ivec3(5, 5, 5));
    EXPECT_EQ(g.indexMax, glm::ivec3(18, 18, 19));
    EXPECT_EQ(g.grid.res, ivec3(14, 14, 15));
    EXPECT_EQ(g.activeVoxelCount, 1016u);
    EXPECT_NEAR(g.grid.frame.voxelSize, 1.0f / 6.0f, 1e-6f);
    EXPECT_NEAR(glm::length(g.grid.frame.origin - vec3(4.5f / 6.0f)), 0.0f, 1e-5f);
    double sum = 0.0;
    float maxSpeed = 0.0f;
    int moving = 0;
    for (const vec3& v : g.grid.v) {
        ASSERT_TRUE(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z));
        const float s = glm::length(v);
        sum += s;
        maxSpeed = std::max(maxSpeed, s);
        moving += s > 0.0f;
    }
    EXPECT_FLOAT_EQ(maxSpeed, g.maxSpeed);
    EXPECT_GT(maxSpeed, 0.1f);
    EXPECT_LT(maxSpeed, 100.0f);
    std::printf("Mantaflow velocity: %dx%dx%d cells of %g, origin (%g, %g, %g), %d moving, "
                "|v| mean %.4f max %.4f (file units / s)\n",
                g.grid.res.x, g.grid.res.y, g.grid.res.z, double(g.grid.frame.voxelSize),
                double(g.grid.frame.origin.x), double(g.grid.frame.origin.y),
                double(g.grid.frame.origin.z), moving, sum / double(g.grid.v.size()),
                double(maxSpeed));
    RecordProperty("max_speed", std::to_string(maxSpeed));

    // its missing-name message lists the vec3 grids
    const std::string msg = loadError(options(path, "vel"));
    EXPECT_TRUE(contains(msg, "blender_mantaflow_fluid_data_0001.vdb: grid \"vel\": no grid of "
                              "that name; its vec3 grids: velocity (vec3h)"));
    // and a density named as velocity is refused as a scalar grid
    EXPECT_TRUE(contains(loadError(options(path, "density")),
                         "grid \"density\": holds half values (a scalar grid"));
}

TEST(VdbVelocity, RefusalsNameTheFileTheGridAndWhatWasFound) {
    TempDir dir;
    const std::string path = (dir / "v.vdb").string();
    writeVdbGrids(path, {densityGrid(), linearGrid("wind", false, "vec3s"),
                         linearGrid("flow", true, "vec3d")});

    std::string msg = loadError(options(path, "velocity"));
    EXPECT_TRUE(contains(msg, path + ": grid \"velocity\": no grid of that name; its vec3 grids: "
                                     "wind (vec3s), flow (vec3d)"));
    msg = loadError(options(path, "density"));
    EXPECT_TRUE(contains(msg, path + ": grid \"density\": holds float values (a scalar grid, e.g. "
                                     "a density); a velocity grid must hold vec3s"));
    msg = loadError(options((dir / "missing.vdb").string()));
    EXPECT_TRUE(contains(msg, "missing.vdb: cannot open the file"));

    // a file without vec3 grids says so, and lists what it has
    const std::string scalar = (dir / "s.vdb").string();
    writeVdbGrids(scalar, {densityGrid()});
    EXPECT_TRUE(contains(loadError(options(scalar)),
                         "no grid of that name; the file has no vec3 (velocity) grids; the file "
                         "has 1 grid: density (float)"));

    // the dense-cell limit: names the grid, its box and the limit
    VelocityLoadOptions small = options(path, "wind");
    small.maxCells = 100;
    EXPECT_TRUE(contains(loadError(small), "grid \"wind\": its active voxels span a box of 10 x 8 "
                                           "x 8 = 640 cells, more than the limit of 100 cells"));

    // empty
    VdbGridSpec empty = linearGrid("velocity", false, "vec3s");
    empty.voxels.clear();
    const std::string emptyPath = (dir / "e.vdb").string();
    writeVdbGrids(emptyPath, {empty});
    EXPECT_TRUE(
        contains(loadError(options(emptyPath)), "grid \"velocity\": is empty (no active voxels)"));

    // rotated and non-uniformly scaled transforms
    VdbGridSpec rotated = linearGrid("velocity", false, "vec3s");
    rotated.worldFromIndex = glm::dmat4(glm::dvec4(0, 1, 0, 0), glm::dvec4(-1, 0, 0, 0),
                                        glm::dvec4(0, 0, 1, 0), glm::dvec4(0, 0, 0, 1));
    VdbGridSpec stretched = linearGrid("velocity", false, "vec3s");
    stretched.worldFromIndex = glm::dmat4(glm::dvec4(1, 0, 0, 0), glm::dvec4(0, 2, 0, 0),
                                          glm::dvec4(0, 0, 1, 0), glm::dvec4(0, 0, 0, 1));
    for (const VdbGridSpec& g : {rotated, stretched}) {
        const std::string p = (dir / "t.vdb").string();
        writeVdbGrids(p, {g});
        EXPECT_TRUE(contains(loadError(options(p)),
                             "(rotated, sheared, non-uniformly scaled or degenerate); a velocity "
                             "grid must be axis-aligned with one positive voxel size"));
    }
}

TEST(VdbVelocity, ACrashWhileReadingIsAnErrorOfTheChildProcess) {
    TempDir dir;
    const std::string path = (dir / "v.vdb").string();
    writeVdbGrids(path, {linearGrid("velocity", true, "vec3s")});
    useReaderForTests("segv");
    const std::string msg = loadError(options(path));
    useReaderForTests(nullptr);
    EXPECT_TRUE(contains(msg, path + ": grid \"velocity\": the OpenVDB reader crashed (SIGSEGV, "
                                     "segmentation fault) while reading the grid"));
    EXPECT_TRUE(contains(msg, "its last output: \"something went wrong at leaf 17\""));
    // a time limit that is not a number of seconds is refused by the same machinery
    VelocityLoadOptions o = options(path);
    o.read.timeoutSeconds = -1.0;
    EXPECT_TRUE(contains(loadError(o), "the time limit of the reading process must be a positive"));
}

TEST(VdbVelocity, BindingReadsOnlyWhenTheSceneNamesAGridAndResolvesFrames) {
    TempDir dir;
    writeVdbGrids((dir / "vel.0002.vdb").string(), {linearGrid("velocity", true, "vec3s")});
    FieldDesc field;
    field.kind = FieldKind::Cumulus;
    std::shared_ptr<const sim::VelocityGrid> v;
    bool staggered = true;
    std::vector<std::string> warnings;
    const std::uint64_t before = vdbReadCount();
    // not enabled, or another wind: nothing read, bindings reset
    field.advect.velocityPath = "vel.####.vdb";
    field.advect.wind = AdvectWind::Grid;
    bindVdbVelocity(field, dir.string(), 2, v, staggered, warnings);
    EXPECT_EQ(v, nullptr);
    EXPECT_FALSE(staggered);
    field.advect.enabled = true;
    field.advect.wind = AdvectWind::Uniform;
    bindVdbVelocity(field, dir.string(), 2, v, staggered, warnings);
    EXPECT_EQ(v, nullptr);
    EXPECT_EQ(vdbReadCount(), before);

    field.advect.wind = AdvectWind::Grid;
    field.advect.velocityScale = 3.0f;
    bindVdbVelocity(field, dir.string(), 2, v, staggered, warnings);
    ASSERT_NE(v, nullptr);
    EXPECT_TRUE(staggered);
    EXPECT_EQ(vdbReadCount(), before + 1);
    EXPECT_EQ(vdbRecentReads().back().path, (dir / "vel.0002.vdb").string());
    const glm::dvec3 p = worldOf(glm::dvec3(1.3, 5.2, 8.7));
    EXPECT_NEAR(
        glm::length(sim::velocityAt(sim::staggeredGrid(*v), vec3(p)) - 3.0f * linearVelocity(p)),
        0.0f, 1e-4f);

    // a frame whose file is missing names the pattern and the frame
    try {
        bindVdbVelocity(field, dir.string(), 3, v, staggered, warnings);
        ADD_FAILURE() << "frame 3 has no file";
    } catch (const VdbError& e) {
        EXPECT_TRUE(contains(e.what(), "vel.0003.vdb")) << e.what();
    }
}

// `nimbus bake --velocity`: an automaton with a sheared layered wind; the velocity grid holds
// the wind at its voxel centres and covers the density.
namespace {

const char* kWindScene = R"(frames = "1-2"
[field]
kind = "automaton"
resolution = [32, 8, 32]
bounds_min = [-8, 1, -8]
bounds_max = [8, 3, 8]
cover = 0.5
start_full = true

[[field.wind]]
altitude = 1.5
wind = [2, 0, 0.5]

[[field.wind]]
altitude = 2.5
wind = [8, 0, -1]
)";

/// The scene's layered wind, linear in altitude y and clamped outside the rows.
vec3 sceneWind(float y) {
    const float t = glm::clamp((y - 1.5f) / 1.0f, 0.0f, 1.0f);
    return glm::mix(vec3(2, 0, 0.5f), vec3(8, 0, -1), t);
}

std::string writeScene(const TempDir& dir, const std::string& text) {
    const std::string path = (dir / "scene.toml").string();
    std::ofstream(path) << text;
    return path;
}

} // namespace

TEST(VdbVelocityBake, VelocityGridHoldsTheWindAroundTheDensity) {
    TempDir dir;
    const std::string scene = writeScene(dir, kWindScene);
    const CliRun r = runNimbus("bake " + scene + " -o " + (dir / "c.####.vdb").string() +
                               " --voxel 0.5 --velocity");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "\"velocity\":")) << r.output;
    for (const char* file : {"c.0001.vdb", "c.0002.vdb"}) {
        const std::string path = (dir / file).string();
        const std::vector<VdbGridInfo> grids = listVdbGrids(path);
        ASSERT_EQ(grids.size(), 2u);
        EXPECT_EQ(grids[0].name, "density");
        EXPECT_EQ(grids[1].name, "velocity");
        EXPECT_EQ(grids[1].valueType, "vec3s");

        VelocityLoadOptions o = options(path);
        const LoadedVelocityGrid v = loadVdbVelocity(o);
        EXPECT_FALSE(v.staggered);
        EXPECT_EQ(v.gridClass, "unknown");
        EXPECT_EQ(v.vectorType, "contravariant relative");
        EXPECT_FLOAT_EQ(v.grid.frame.voxelSize, 0.5f);
        // every cell of the dense box (all active: whole 8^3 blocks) holds the wind at its centre
        int checked = 0;
        for (int z = 0; z < v.grid.res.z; ++z)
            for (int y = 0; y < v.grid.res.y; ++y)
                for (int x = 0; x < v.grid.res.x; ++x) {
                    const vec3 c =
                        v.grid.frame.origin + (vec3(x, y, z) + 0.5f) * v.grid.frame.voxelSize;
                    const vec3 got = v.grid.v[v.grid.index(x, y, z)];
                    ASSERT_NEAR(glm::length(got - sceneWind(c.y)), 0.0f, 1e-5f)
                        << file << " cell " << x << "," << y << "," << z;
                    ++checked;
                }
        EXPECT_GT(checked, 500);

        // the density's active voxels lie inside the velocity's, with a voxel to spare
        VdbLoadOptions d;
        d.path = path;
        const LoadedVdbGrid density = loadVdbGrid(d);
        ASSERT_FALSE(density.empty());
        const glm::ivec3 lo = glm::max(density.indexMin - 1, glm::ivec3(0));
        EXPECT_TRUE(glm::all(glm::lessThanEqual(v.indexMin, lo)));
        EXPECT_TRUE(glm::all(glm::greaterThanEqual(v.indexMax, density.indexMax)));
    }
}

TEST(VdbVelocityBake, WithoutTheFlagThereIsNoVelocityAndAStillFieldIsRefused) {
    TempDir dir;
    const std::string scene = writeScene(dir, kWindScene);
    CliRun r = runNimbus("bake " + scene + " -o " + (dir / "c.####.vdb").string() +
                         " --voxel 0.5 --frames 1");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const std::vector<VdbGridInfo> grids = listVdbGrids((dir / "c.0001.vdb").string());
    ASSERT_EQ(grids.size(), 1u);
    EXPECT_EQ(grids[0].name, "density");

    const std::string still =
        writeScene(dir, "frames = \"1\"\n[field]\nkind = \"homogeneous\"\nbounds_min = [0, 0, "
                        "0]\nbounds_max = [1, 1, 1]\n");
    r = runNimbus("bake " + still + " -o " + (dir / "h.####.vdb").string() +
                  " --voxel 0.25 --velocity");
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "--velocity writes the field's motion, and this field does not "
                                   "move"));
    EXPECT_FALSE(std::filesystem::exists(dir / "h.0001.vdb"));
}
