// [[solid]] in scene files: the tree and shading read, file:line errors, and a CLI render of
// examples/scenes/sdf_terrain.toml without NaN, its solid visible.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"
#include "test_util.h"

using namespace nimbus;
using nimbus::io::parseSceneText;
using nimbus::io::SceneError;

namespace {

std::string errorOf(const std::string& text) {
    try {
        parseSceneText(text, "test.toml", {});
        ADD_FAILURE() << "no SceneError for:\n" << text;
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(SdfSolidScene, ReadsTheTreeAndTheShading) {
    const auto f = parseSceneText(R"(
[[solid]]
albedo = [0.3, 0.2, 0.1]
softness = 9.0
penumbra = "improved"
ao_samples = 3
ao_step = 0.5
[[solid.node]]
type = "sphere"
radius = 2.0
translate = [0.0, 1.0, 0.0]
)",
                                  "test.toml", {});
    ASSERT_EQ(f.scene.solids.size(), 1u);
    const SolidDesc& s = f.scene.solids[0];
    EXPECT_EQ(s.shading.albedo, vec3(0.3f, 0.2f, 0.1f));
    EXPECT_EQ(s.shading.softness, 9.0f);
    EXPECT_EQ(s.shading.penumbra, Penumbra::Improved);
    EXPECT_EQ(s.shading.aoSamples, 3);
    EXPECT_EQ(s.shading.aoStep, 0.5f);
    EXPECT_EQ(s.root.kind, SdfKind::Sphere);
    EXPECT_EQ(s.root.radius, 2.0f);
    // the solid's distance through solidFromTree: 1 above the sphere's top
    const SdfSolid solid = solidFromTree(s.root, s.shading);
    EXPECT_NEAR(solid.distance(vec3(0.0f, 4.0f, 0.0f)), 1.0f, 1e-5f);
}

TEST(SdfSolidScene, ReportsMistakesWithTheirLines) {
    std::string e = errorOf("[[solid]]\nalbedo = [0.5, 0.5, 0.5]\n");
    EXPECT_TRUE(contains(e, "test.toml:1:1: solid[0]: needs its tree")) << e;
    e = errorOf("[[solid]]\nsoftnes = 2.0\n[[solid.node]]\ntype = \"sphere\"\n");
    EXPECT_TRUE(contains(e, "test.toml:2:1: unknown key \"solid.softnes\"")) << e;
    e = errorOf("[[solid]]\nao_step = -1.0\n[[solid.node]]\ntype = \"sphere\"\n");
    EXPECT_TRUE(contains(e, "test.toml:2:11: solid[0].ao_step: expected a number > 0")) << e;
    e = errorOf("[[solid]]\npenumbra = \"soft\"\n[[solid.node]]\ntype = \"sphere\"\n");
    EXPECT_TRUE(contains(e, "test.toml:2:12: solid[0].penumbra")) << e;
    e = errorOf("[[solid]]\n[[solid.node]]\ntype = \"sphere\"\nradius = -2\n");
    EXPECT_TRUE(contains(e, "test.toml:4:10: solid[0].node[0].radius: expected a number > 0")) << e;
}

TEST(SdfSolidScene, ExampleTerrainRendersWithoutNaN) {
    TempDir dir;
    const std::string out = (dir / "t.####.exr").string();
    const CliRun r =
        runNimbus("render " NIMBUS_SOURCE_DIR "/examples/scenes/sdf_terrain.toml "
                  "--set camera.width=64 --set camera.height=36 --set 'output.path=\"" +
                  out + "\"' --set 'output.preview=\"\"'");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const io::ExrImage img = io::readExr((dir / "t.0001.exr").string());
    ASSERT_EQ(img.width, 64);
    int ground = 0;
    const int g = img.channelIndex("G"), b = img.channelIndex("B");
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            for (size_t c = 0; c < img.channels.size(); ++c)
                ASSERT_TRUE(std::isfinite(img.at(x, y, int(c)))) << x << "," << y;
            // the terrain is brownish (blue below green), the sky and clouds are not
            ground += y > img.height / 2 && img.at(x, y, b) < img.at(x, y, g);
        }
    EXPECT_GT(ground, 64 * 36 / 4) << "the terrain fills the lower half";
}
