// `nimbus bake` of an SDF cloud: the VDB it writes holds the field's density at the voxel
// centres (the example scene, coarse voxels).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <nanovdb/NanoVDB.h>

#include "core/fields/field.h"
#include "core/sdf/sdf.h"
#include "plugin/io/scene_file.h"
#include "plugin/vdb/vdb_reader.h"
#include "test_util.h"

TEST(SdfBakeCli, BakedSdfCloudReadsBackAsTheFieldItSampled) {
    TempDir dir;
    const std::string scene = NIMBUS_SOURCE_DIR "/examples/scenes/sdf_cloud.toml";
    const CliRun r =
        runNimbus("bake " + scene + " -o " + (dir / "s.####.vdb").string() + " --voxel 0.25");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    nimbus::vdb::VdbLoadOptions opt;
    opt.path = (dir / "s.0001.vdb").string();
    nimbus::vdb::LoadedVdbGrid g = nimbus::vdb::loadVdbGrid(opt);
    EXPECT_EQ(g.gridClass, "fog volume");
    EXPECT_GT(g.activeVoxelCount, 1000u);
    const nimbus::io::SceneFile f = nimbus::io::loadSceneFile(scene);
    const nimbus::Field field = nimbus::makeField(f.scene.field, 0.0f);
    auto acc = g.grid()->getAccessor();
    const nanovdb::CoordBBox bbox = g.grid()->indexBBox();
    int nonzero = 0, checked = 0;
    for (int k = bbox.min()[2]; k <= bbox.max()[2]; k += 3)
        for (int j = bbox.min()[1]; j <= bbox.max()[1]; j += 2)
            for (int i = bbox.min()[0]; i <= bbox.max()[0]; i += 2) {
                const nanovdb::Vec3f w = g.grid()->indexToWorldF(nanovdb::Vec3f(i, j, k));
                const float expect = field.density(nimbus::vec3(w[0], w[1], w[2]));
                ASSERT_NEAR(acc.getValue(nanovdb::Coord(i, j, k)), expect, 1e-5f)
                    << i << "," << j << "," << k;
                nonzero += expect > 0.0f;
                ++checked;
            }
    EXPECT_GT(nonzero, 100);
    RecordProperty("voxels_checked", std::to_string(checked));
}

// `nimbus bake --level-set` of SDF solids: OpenVDB narrow-band level sets, read back through the
// reader's level-set-to-fog conversion (inside: -distance / background, clamped to [0, 1]).
namespace {

/// A scene with one [[solid]] (its node tables given) and a tiny homogeneous field.
std::string solidScene(const std::string& nodes) {
    return "frames = \"1\"\n[field]\nkind = \"homogeneous\"\nbounds_min = [-0.1, -0.1, -0.1]\n"
           "bounds_max = [0.1, 0.1, 0.1]\n[[solid]]\n" +
           nodes;
}

nimbus::vdb::LoadedVdbGrid readLevelSet(const std::string& path) {
    nimbus::vdb::VdbLoadOptions opt;
    opt.path = path;
    opt.gridName = "surface";
    opt.levelsetToFog = true;
    return nimbus::vdb::loadVdbGrid(opt);
}

/// The fog value (inside ramp) at the voxel centre nearest world point @p w.
float fogAt(const nimbus::vdb::LoadedVdbGrid& g, nimbus::vec3 w) {
    const nanovdb::Vec3f i = g.grid()->worldToIndexF(nanovdb::Vec3f(w.x, w.y, w.z));
    return g.grid()->getAccessor().getValue(
        nanovdb::Coord(int(std::lround(i[0])), int(std::lround(i[1])), int(std::lround(i[2]))));
}

/// Mean | |grad d| - 1 | over the voxels whose six neighbours all lie inside the inner band
/// (0 < fog < 1), by central differences of the fog ramp (d = -fog * background).
double eikonalError(const nimbus::vdb::LoadedVdbGrid& g, float band, int& count) {
    auto acc = g.grid()->getAccessor();
    const nanovdb::CoordBBox bb = g.grid()->indexBBox();
    const float voxel = g.voxelSize.x;
    double sum = 0.0;
    count = 0;
    for (int k = bb.min()[2] + 1; k < bb.max()[2]; ++k)
        for (int j = bb.min()[1] + 1; j < bb.max()[1]; ++j)
            for (int i = bb.min()[0] + 1; i < bb.max()[0]; ++i) {
                float f[6];
                bool inBand = true;
                for (int n = 0; n < 6; ++n) {
                    nanovdb::Coord c(i, j, k);
                    c[n / 2] += n % 2 ? 1 : -1;
                    f[n] = acc.getValue(c);
                    inBand = inBand && f[n] > 0.02f && f[n] < 0.98f;
                }
                if (!inBand) continue;
                const nimbus::vec3 grad(f[1] - f[0], f[3] - f[2], f[5] - f[4]);
                sum += std::abs(double(glm::length(grad)) * band / (2.0 * voxel) - 1.0);
                ++count;
            }
    return count ? sum / count : 1e9;
}

} // namespace

TEST(SdfBakeCli, SphereLevelSetHoldsTheDistanceToItsSurface) {
    TempDir dir;
    const std::string scene = (dir / "s.toml").string();
    writeText(scene, solidScene("[[solid.node]]\ntype = \"sphere\"\nradius = 1.0\n"));
    const CliRun r = runNimbus("bake " + scene + " -o " + (dir / "s.vdb").string() +
                               " --level-set --voxel 0.05");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("re-distanced"), std::string::npos) << r.output;
    const nimbus::vdb::LoadedVdbGrid g = readLevelSet((dir / "s.vdb").string());
    EXPECT_EQ(g.gridClass, "level set");
    const float voxel = 0.05f, band = 3.0f * voxel;
    // along many directions: the inner ramp is (1 - r) / band, 1 deeper, 0 outside
    double worst = 0.0;
    int checked = 0;
    for (int n = 0; n < 200; ++n) {
        const float z = 1.0f - 2.0f * (float(n) + 0.5f) / 200.0f, phi = 2.39996f * float(n);
        const float s = std::sqrt(1.0f - z * z);
        const nimbus::vec3 dir(s * std::cos(phi), s * std::sin(phi), z);
        for (float rr : {0.3f, 0.8f, 0.9f, 0.93f, 0.96f, 0.99f, 1.02f, 1.1f}) {
            const nanovdb::Vec3f idx =
                g.grid()->worldToIndexF(nanovdb::Vec3f(rr * dir.x, rr * dir.y, rr * dir.z));
            const nanovdb::Vec3f c(std::round(idx[0]), std::round(idx[1]), std::round(idx[2]));
            const nanovdb::Vec3f w = g.grid()->indexToWorldF(c);
            const float r0 = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
            const float expect = glm::clamp((1.0f - r0) / band, 0.0f, 1.0f);
            const float got = fogAt(g, nimbus::vec3(w[0], w[1], w[2]));
            worst = std::max(worst, double(std::abs(got - expect)) * band / voxel);
            ++checked;
        }
    }
    // measured 0.149 voxels at worst (2 voxels deep: OpenVDB's mesh-to-volume propagates the
    // distance from the triangles outward), 0.5 would be a surface a voxel off
    EXPECT_LT(worst, 0.25) << "largest error, in voxels";
    RecordProperty("worst_error_voxels", std::to_string(worst));
    RecordProperty("points", std::to_string(checked));
}

TEST(SdfBakeCli, DisplacedSolidIsReDistancedWhenTheBoxHoldsIt) {
    // a sphere displaced by Perlin noise: its tree value is no distance (|grad| != 1); the
    // rebuilt band is one (|grad d| = 1), the band the box cuts keeps the tree's values
    TempDir dir;
    const std::string scene = (dir / "d.toml").string();
    writeText(scene, solidScene("[[solid.node]]\ntype = \"sphere\"\nradius = 1.0\n"
                                "displace = 0.12\nnoise = \"perlin\"\nfrequency = 2.5\n"
                                "octaves = 2\nseed = 3\n"));
    const std::string whole = (dir / "whole.vdb").string(), cut = (dir / "cut.vdb").string();
    CliRun r = runNimbus("bake " + scene + " -o " + whole + " --level-set --voxel 0.04");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    r = runNimbus("bake " + scene + " -o " + cut +
                  " --level-set --voxel 0.04 --box=-2,-2,-2,2,2,0.9");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("the box cuts the surface"), std::string::npos) << r.output;
    const float band = 3.0f * 0.04f;
    int nWhole = 0, nCut = 0;
    const double eWhole = eikonalError(readLevelSet(whole), band, nWhole);
    const double eCut = eikonalError(readLevelSet(cut), band, nCut);
    EXPECT_GT(nWhole, 1000);
    EXPECT_GT(nCut, 1000);
    EXPECT_LT(eWhole, 0.05) << "mean | |grad d| - 1 | of the re-distanced band";
    EXPECT_GT(eCut, 2.0 * eWhole) << "the tree's own values should be further from a distance";
    RecordProperty("eikonal_error_rebuilt", std::to_string(eWhole));
    RecordProperty("eikonal_error_tree", std::to_string(eCut));
}

TEST(SdfBakeCli, TerrainCutByTheBoxKeepsItsInsideAndOutside) {
    // the example's displaced ground and mountains, clipped to a box: every voxel centre whose
    // tree value is more than a voxel from 0 lies on the side its sign says (the flood fill)
    TempDir dir;
    const std::string scene = NIMBUS_SOURCE_DIR "/examples/scenes/sdf_terrain.toml";
    const std::string out = (dir / "t.vdb").string();
    const CliRun r = runNimbus("bake " + scene + " -o " + out +
                               " --level-set --voxel 0.2 --box=-12,-3,-4,12,5,22");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const nimbus::vdb::LoadedVdbGrid g = readLevelSet(out);
    const nimbus::io::SceneFile f = nimbus::io::loadSceneFile(scene);
    const nimbus::SdfTree tree = nimbus::flattenSdf(f.scene.solids.at(0).root);
    int inside = 0, outside = 0, wrong = 0;
    for (int n = 0; n < 20000; ++n) {
        const float u = float((n * 7919) % 20000) / 20000.0f, v = float(n) / 20000.0f;
        const float w = float((n * 104729) % 20000) / 20000.0f;
        const nimbus::vec3 q(-11.5f + 23.0f * u, -2.5f + 7.0f * w, -3.5f + 25.0f * v);
        // the voxel centre nearest q, where the bake took its value
        const nanovdb::Vec3f idx = g.grid()->worldToIndexF(nanovdb::Vec3f(q.x, q.y, q.z));
        const nanovdb::Vec3f c = g.grid()->indexToWorldF(
            nanovdb::Vec3f(std::round(idx[0]), std::round(idx[1]), std::round(idx[2])));
        const nimbus::vec3 p(c[0], c[1], c[2]);
        const float d = tree.distance(p);
        if (std::abs(d) < 0.2f) continue;
        const bool in = fogAt(g, p) > 0.0f; // the inner ramp -d / band, 1 deeper
        inside += d < 0.0f;
        outside += d > 0.0f;
        wrong += in != (d < 0.0f);
    }
    EXPECT_GT(inside, 1000);
    EXPECT_GT(outside, 1000);
    EXPECT_EQ(wrong, 0);
}

TEST(SdfBakeCli, LevelSetErrorsNameWhatIsMissing) {
    TempDir dir;
    const std::string terrain = NIMBUS_SOURCE_DIR "/examples/scenes/sdf_terrain.toml";
    CliRun r = runNimbus("bake " + terrain + " -o " + (dir / "t.vdb").string() + " --level-set");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.output.find("[[solid]] 1 is unbounded"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("--box"), std::string::npos) << r.output;
    r = runNimbus("bake " NIMBUS_SOURCE_DIR "/examples/scenes/gardner.toml -o " +
                  (dir / "g.vdb").string() + " --level-set");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.output.find("has none"), std::string::npos) << r.output;
    r = runNimbus("bake " + terrain + " -o " + (dir / "t.vdb").string() + " --box=0,0,0,1,1,1");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.output.find("apply to --level-set"), std::string::npos) << r.output;
    r = runNimbus("bake " + terrain + " -o " + (dir / "t.vdb").string() +
                  " --level-set --box=0,0,0,1,-1,1");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.output.find("each min below its max"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir / "t.vdb"));
}
