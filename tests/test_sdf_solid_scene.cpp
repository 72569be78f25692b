// [[solid]] in scene files: the tree and shading read, file:line errors, and a CLI render of
// examples/scenes/sdf_terrain.toml without NaN, its solid visible.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"
#include "core/camera.h"
#include "render_util.h"
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

namespace {

// The area-sun scene: a sphere (radius 1, centre 3 above the ground) and a ground plane, both
// white solids; a sun of angular diameter 5 degrees at 45 degrees elevation from +x, no sky, no
// cloud (a homogeneous box far away). The camera looks straight down on the sphere's shadow, an
// ellipse centred at x = -3 whose penumbra is about 0.37 wide (7 pixels).
std::string areaSunScene(const std::string& integrator, float softness) {
    return R"(
[camera]
position = [-3.0, 10.0, 0.0]
look_at = [-3.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = 12.0
width = 48
height = 32
[sun]
direction = [1.0, 1.0, 0.0]
angular_diameter = 5.0
[sky]
kind = "none"
[field]
kind = "homogeneous"
bounds_min = [50.0, 50.0, 50.0]
bounds_max = [51.0, 51.0, 51.0]
[render]
integrator = ")" +
           integrator +
           R"("
spp = 64
max_depth = 1
[[solid]]
albedo = [1.0, 1.0, 1.0]
ao_samples = 0
softness = )" +
           std::to_string(softness) +
           R"(
[[solid.node]]
type = "sphere"
radius = 1.0
translate = [0.0, 3.0, 0.0]
[[solid]]
albedo = [1.0, 1.0, 1.0]
ao_samples = 0
softness = 0.0
[[solid.node]]
type = "plane"
normal = [0.0, 1.0, 0.0]
offset = 0.0
)";
}

/// The exact radiance of each pixel of the area-sun scene: (albedo / pi) times the sun's
/// irradiance over the part of its disc that the ground point sees past the sphere (cosine
/// weighted, normalised so a point facing the whole disc receives the irradiance), averaged over
/// 4 x 4 points of the pixel and 48^2 stratified directions of the disc.
std::vector<double> exactAreaSunImage(const SceneDesc& s) {
    const Camera cam(s.camera);
    const double alpha = 0.5 * double(s.sun.angularDiameter) * 3.14159265358979 / 180.0;
    const double cosA = std::cos(alpha);
    const glm::dvec3 w = glm::normalize(glm::dvec3(s.sun.direction));
    const glm::dvec3 t = glm::normalize(glm::cross(w, glm::dvec3(0.0, 0.0, 1.0)));
    const glm::dvec3 b = glm::cross(w, t);
    const glm::dvec3 c(0.0, 3.0, 0.0);
    std::vector<double> out;
    const int n = 48, sub = 4;
    for (int py = 0; py < s.camera.height; ++py)
        for (int px = 0; px < s.camera.width; ++px) {
            double sum = 0.0;
            for (int sy = 0; sy < sub; ++sy)
                for (int sx = 0; sx < sub; ++sx) {
                    const Ray r = cam.generate(float(px) + (float(sx) + 0.5f) / float(sub),
                                               float(py) + (float(sy) + 0.5f) / float(sub));
                    const glm::dvec3 p =
                        glm::dvec3(r.o) - glm::dvec3(r.d) * (double(r.o.y) / r.d.y);
                    double lit = 0.0;
                    for (int i = 0; i < n; ++i)
                        for (int j = 0; j < n; ++j) {
                            const double ct = 1.0 - (1.0 - cosA) * (i + 0.5) / n;
                            const double st = std::sqrt(std::max(0.0, 1.0 - ct * ct));
                            const double ph = 6.283185307179586 * (j + 0.5) / n;
                            const glm::dvec3 d =
                                ct * w + st * std::cos(ph) * t + st * std::sin(ph) * b;
                            const glm::dvec3 oc = p - c;
                            const double bb = glm::dot(oc, d), q = glm::dot(oc, oc) - 1.0;
                            const bool hit =
                                bb * bb - q > 0.0 && -bb - std::sqrt(bb * bb - q) > 0.0;
                            if (!hit) lit += d.y; // cos to the ground's normal
                        }
                    sum += lit / double(n * n) * 2.0 / (1.0 + cosA);
                }
            const double L = sum / double(sub * sub) / 3.14159265358979;
            for (int ch = 0; ch < 3; ++ch) out.push_back(L);
        }
    return out;
}

} // namespace

TEST(SdfSolidScene, PathtracedAreaSunShadowIsTheExactPenumbra) {
    // pathtrace samples the sun's disc: its shadow of the sphere on the ground equals the exact
    // penumbra pixel by pixel (Z-test, alpha 0.01, 16 seeds x 64 spp); a point sun would put a
    // hard edge where the penumbra is
    const auto f = parseSceneText(areaSunScene("pathtrace", 0.0f), "area_sun.toml", {});
    Estimate exact = exactValues(exactAreaSunImage(f.scene));
    // the exact image's own error (4 x 4 points a pixel, 48^2 directions): a standard error of
    // 0.2% of a lit pixel
    for (double& v : exact.variance) v = std::pow(0.002 * 0.70710678 / 3.14159265358979, 2.0);
    const Estimate pt = renderSeeds(f.scene, 16);
    int penumbra = 0;
    for (size_t i = 0; i < exact.mean.size(); i += 3)
        penumbra += exact.mean[i] > 0.05 * 0.2251 && exact.mean[i] < 0.95 * 0.2251;
    EXPECT_GT(penumbra, 60) << "pixels inside the penumbra";
    EXPECT_TRUE(zTestPasses(pt, exact, 0.01));

    // march's soft shadow (k h / t) on the same view against that pathtraced penumbra, over the
    // pixels where it is in (5%, 95%) of a lit pixel (docs/sdf_solids.md)
    const double lit = 0.70710678 / 3.14159265358979;
    const double sinA = std::sin(2.5 * 3.14159265358979 / 180.0);
    for (const char* mode : {"classic", "improved"})
        for (double kf : {0.5, 1.0, 2.0}) {
            std::string text = areaSunScene("march", float(kf / sinA));
            text.replace(text.find("ao_samples = 0\nsoftness"), 0,
                         std::string("penumbra = \"") + mode + "\"\n");
            const auto m = parseSceneText(text, "area_sun_march.toml", {});
            const std::vector<double> v = frameValues(renderScene(m.scene));
            double sumAbs = 0.0, sum = 0.0, litErr = 0.0;
            int nPen = 0, nLit = 0;
            for (size_t i = 0; i < v.size(); i += 3) {
                const double ref = pt.mean[i];
                if (ref > 0.05 * lit && ref < 0.95 * lit) {
                    sumAbs += std::abs(v[i] - ref) / lit;
                    sum += (v[i] - ref) / lit;
                    ++nPen;
                } else if (exact.mean[i] > 0.999 * lit) {
                    litErr = std::max(litErr, std::abs(v[i] - ref) / lit);
                    ++nLit;
                }
            }
            const std::string key = std::string(mode) + "_k" + std::to_string(kf).substr(0, 3);
            RecordProperty(key + "_mean_abs_err", std::to_string(sumAbs / nPen));
            RecordProperty(key + "_mean_err", std::to_string(sum / nPen));
            RecordProperty(key + "_worst_lit_err", std::to_string(litErr));
            // fully lit ground is lit alike (pathtrace's noise: a few percent per pixel) when
            // k >= 1 / sin(alpha); a smaller k reaches 1 only at asin(1 / k) > alpha from the
            // tangent, darkening ground the whole disc lights (measured: 0.45-0.51 at 0.5)
            EXPECT_GT(nLit, 100);
            if (kf >= 1.0) EXPECT_LT(litErr, 0.1) << key;
            // the estimate leaves out the inner half of the penumbra: darker on average
            EXPECT_LT(sum / nPen, -0.05) << key;
        }
}
