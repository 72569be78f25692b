// Scene files with several volumes, instances, scatters, a ground and meshes; the CLI on them.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"
#include "test_util.h"

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

io::SceneFile parse(const std::string& text) {
    return io::parseSceneText(text, "s.toml");
}

std::string errorOf(const std::string& text) {
    try {
        parse(text);
    } catch (const io::SceneError& e) {
        return e.what();
    }
    return "(no error)";
}

const fs::path kData = NIMBUS_SHARED_VDB_DIR;

} // namespace

TEST(SceneInstances, InstancesVolumesGroundAndMeshesParse) {
    const io::SceneFile f = parse(R"(
[field]
kind = "homogeneous"
[[volume]]
name = "hero"
path = "hero.####.vdb"
grid = "smoke"
density = 2.0
hold = true
[[instance]]
volume = "hero"
translate = [1, 2, 3]
rotate = [0, 90, 0]
scale = [2, 2, 2]
density = 0.5
[[instance]]
[ground]
enabled = true
height = -1.5
albedo = [0.2, 0.3, 0.4]
holdout = true
[[mesh]]
path = "rock.obj"
scale = [3, 3, 3]
albedo = 0.6
)");
    const SceneDesc& s = f.scene;
    ASSERT_EQ(s.volumes.size(), 1u);
    EXPECT_EQ(s.volumes[0].name, "hero");
    EXPECT_EQ(s.volumes[0].field.kind, FieldKind::Vdb);
    EXPECT_EQ(s.volumes[0].field.vdb.grid, "smoke");
    EXPECT_EQ(s.volumes[0].field.vdb.density, 2.0f);
    EXPECT_TRUE(s.volumes[0].field.vdb.hold);
    ASSERT_EQ(s.instances.size(), 2u);
    EXPECT_EQ(s.instances[0].volume, 1);
    EXPECT_EQ(s.instances[0].translate, vec3(1, 2, 3));
    EXPECT_EQ(s.instances[0].rotate, vec3(0, 90, 0));
    EXPECT_EQ(s.instances[0].scale, vec3(2.0f));
    EXPECT_EQ(s.instances[0].density, 0.5f);
    EXPECT_EQ(s.instances[1].volume, 0); // "field" by default
    EXPECT_TRUE(s.ground.enabled);
    EXPECT_EQ(s.ground.height, -1.5f);
    EXPECT_TRUE(s.ground.material.holdout);
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.meshes[0].path, "rock.obj");
    EXPECT_EQ(s.meshes[0].material.albedo, vec3(0.6f));
}

TEST(SceneInstances, WithoutPlacementsEveryVolumeIsPlacedOnce) {
    const io::SceneFile f = parse(R"(
[[volume]]
name = "a"
path = "a.vdb"
[[volume]]
name = "b"
path = "b.vdb"
)");
    ASSERT_EQ(f.scene.instances.size(), 3u);
    for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(f.scene.instances[size_t(i)].volume, i);
        EXPECT_EQ(f.scene.instances[size_t(i)].translate, vec3(0.0f));
    }
    // no volumes, no placements: the field alone, as always
    EXPECT_TRUE(parse("").scene.instances.empty());
}

TEST(SceneInstances, ScatterIsDeterministicAndStaysInItsRanges) {
    const std::string text = R"(
[[scatter]]
count = 300
seed = 9
region_min = [-100, 2, -50]
region_max = [100, 3, 50]
scale = [0.5, 2.0]
rotate_y = [10, 20]
density = [0.2, 0.4]
)";
    const io::SceneFile a = parse(text), b = parse(text);
    ASSERT_EQ(a.scene.instances.size(), 300u);
    double meanX = 0.0;
    for (size_t i = 0; i < 300; ++i) {
        const InstanceDesc& d = a.scene.instances[i];
        EXPECT_EQ(d.translate, b.scene.instances[i].translate);
        EXPECT_GE(d.translate.x, -100.0f);
        EXPECT_LE(d.translate.x, 100.0f);
        EXPECT_GE(d.translate.y, 2.0f);
        EXPECT_LE(d.translate.y, 3.0f);
        EXPECT_GE(d.scale.x, 0.5f);
        EXPECT_LE(d.scale.x, 2.0f);
        EXPECT_EQ(d.scale.x, d.scale.z);
        EXPECT_GE(d.rotate.y, 10.0f);
        EXPECT_LE(d.rotate.y, 20.0f);
        EXPECT_GE(d.density, 0.2f);
        EXPECT_LE(d.density, 0.4f);
        meanX += d.translate.x / 300.0;
    }
    // uniform over [-100, 100]: mean 0, standard error 200 / sqrt(12 * 300) = 3.3
    EXPECT_NEAR(meanX, 0.0, 4.0 * 3.34);
    const io::SceneFile c = parse(text + "\n[[scatter]]\nseed = 10\ncount = 1\n");
    EXPECT_EQ(c.scene.instances.size(), 301u);
}

TEST(SceneInstances, MistakesAreReportedWithTheirPlace) {
    EXPECT_TRUE(contains(errorOf("[[instance]]\nvolume = \"hreo\"\n[[volume]]\nname = "
                                 "\"hero\"\npath = \"x.vdb\"\n"),
                         "s.toml:1:1: instance[0].volume: no volume \"hreo\" (did you mean "
                         "\"hero\"?)"));
    EXPECT_TRUE(contains(errorOf("[[instance]]\ntranslat = [0, 0, 0]\n"),
                         "s.toml:2:1: unknown key \"instance.translat\" (did you mean "
                         "\"translate\"?)"));
    EXPECT_TRUE(contains(errorOf("[[instance]]\nscale = [1, 0, 1]\n"),
                         "instance[0].scale[1]: expected a number > 0, found 0"));
    EXPECT_TRUE(contains(errorOf("[[volume]]\nname = \"a\"\n"), "volume[0]: `path` is required"));
    EXPECT_TRUE(contains(errorOf("[[volume]]\nname = \"field\"\npath = \"a.vdb\"\n"),
                         "\"field\" is the name of [field]"));
    EXPECT_TRUE(contains(errorOf("[[mesh]]\nalbedo = 0.5\n"), "mesh[0]: `path` is required"));
    EXPECT_TRUE(contains(errorOf("[[mesh]]\npath = \"a.obj\"\nalbedo = 1.5\n"),
                         "mesh[0].albedo: expected a number in [0, 1], found 1.5"));
    EXPECT_TRUE(contains(errorOf("instance = 3\n"), "instance: expected [[instance]] tables"));
    EXPECT_TRUE(contains(errorOf("[[scatter]]\nregion_min = [0, 0, 0]\nregion_max = [1, -1, 1]\n"),
                         "region_min must not exceed region_max"));
    EXPECT_TRUE(contains(errorOf("[ground]\nalbedo = [0.5, 0.5]\n"), "ground.albedo"));
}

TEST(SceneInstances, UnplacedVolumeIsNotReadAndSaysSo) {
    const io::SceneFile f = parse(
        "[[volume]]\nname = \"spare\"\npath = \"nowhere.vdb\"\n[[instance]]\nvolume = \"field\"\n");
    ASSERT_FALSE(f.warnings.empty());
    EXPECT_TRUE(contains(f.warnings[0], "volume \"spare\" is not placed"));
}

TEST(SceneInstances, CliRendersAScatteredVdbCloudscapeOverAGround) {
    if (!fs::is_directory(kData))
        GTEST_SKIP() << "shared VDB folder " << kData << " is absent: cloudscape CLI test skipped";
    const TempDir dir("cs");
    const fs::path scene = dir / "cs.toml";
    std::ofstream(scene) << "[camera]\nposition = [0, 40, -400]\nlook_at = [0, 40, 0]\nfov = 50\n"
                            "width = 48\nheight = 32\n[sun]\nelevation = 40\nazimuth = 30\n"
                            "[field]\nkind = \"vdb\"\npath = \""
                         << (kData / "openvdb_smoke1.vdb").string()
                         << "\"\n[[scatter]]\ncount = 12\nregion_min = [-150, 20, -50]\n"
                            "region_max = [150, 40, 50]\n[ground]\nenabled = true\nholdout = "
                            "true\n[render]\nstep = 1.0\nshadow_step = 2.0\nbackground = "
                            "\"transparent\"\n[output]\npath = \""
                         << (dir / "cs.####.exr").string() << "\"\n";
    const CliRun r = runNimbus("render " + scene.string() + " --progress none");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    auto img = io::readExr((dir / "cs.0001.exr").string());
    const int a = img.channelIndex("A");
    int cloud = 0;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 48; ++x) {
            const float v = img.at(x, y, a);
            ASSERT_TRUE(std::isfinite(v));
            cloud += v > 0.05f;
        }
    EXPECT_GT(cloud, 20) << "the plumes cover part of the frame";
    // the bottom row sees the holdout ground: transparent
    EXPECT_EQ(img.at(24, 31, a), 0.0f);
    // --explain names the instances and the skipping
    const CliRun e = runNimbus("render " + scene.string() + " --explain");
    EXPECT_TRUE(contains(e.output, "instances: 12 (instance boxes"));
    EXPECT_TRUE(contains(e.output, "surfaces: ground"));
}

TEST(SceneInstances, CliRefusesAMissingMeshNamingIt) {
    const TempDir dir("mesh");
    const fs::path scene = dir / "m.toml";
    std::ofstream(scene) << "[[mesh]]\npath = \"rock.obj\"\n[output]\npath = \""
                         << (dir / "m.####.exr").string() << "\"\n";
    const CliRun r = runNimbus("render " + scene.string() + " --progress none");
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, (dir / "rock.obj").string() + ": mesh file not found"));
    EXPECT_FALSE(fs::exists(dir / "m.0001.exr"));
}
