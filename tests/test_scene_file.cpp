/// @file test_scene_file.cpp
/// @brief Strict TOML scene files: values, defaults, every kind of error with its exact
///        file:line, --set overrides, warnings, and the generated reference (plugin/io).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/camera.h"
#include "plugin/io/scene_file.h"
#include "tests/test_util.h"

using namespace nimbus;
using nimbus::io::parseSceneText;
using nimbus::io::pixelNeutralSettings;
using nimbus::io::SceneError;
using nimbus::io::SceneFile;

namespace {

testing::AssertionResult startsWith(const std::string& text, const std::string& prefix) {
    if (text.rfind(prefix, 0) == 0) return testing::AssertionSuccess();
    return testing::AssertionFailure() << "expected prefix \"" << prefix << "\" in:\n" << text;
}

/// The SceneError message for @p text (source name "test.toml"), or "" plus a test failure.
std::string errorOf(const std::string& text, const std::vector<std::string>& overrides = {}) {
    try {
        parseSceneText(text, "test.toml", overrides);
        ADD_FAILURE() << "no SceneError for:\n" << text;
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

void expectVec(const vec3& v, float x, float y, float z, float tol = 0.0f) {
    EXPECT_NEAR(v.x, x, tol);
    EXPECT_NEAR(v.y, y, tol);
    EXPECT_NEAR(v.z, z, tol);
}

const char* kFullScene = R"(# a complete scene
color_space = "ACEScg"
frames = "1-48x2"

[camera]
position = [1, 2, -30]
look_at = [0, 3, 0]
up = [0, 1, 0]
fov = 60
width = 1920
height = 1080

[sun]
enabled = true
direction = [0, 2, 0]
irradiance = [3, 2.5, 2]
intensity = 2

[sky]
kind = "uniform"
zenith = [0.2, 0.4, 0.8]
ambient = 0.5

[medium]
sigma_s = 0.9
sigma_a = [0.01, 0.02, 0.03]
density_scale = 2.5
phase = "hg"
g = -0.3

[field]
kind = "cumulus"
bounds_min = [-50, 2, -50]
bounds_max = [50, 6, 50]
density = 3
coverage = 0.4
softness = 0.2
erosion = 0.5
height_a = 40
height_b = 3
base_period = 16
detail_period = 3
base_lattice = 8
detail_lattice = 6
base_octaves = 5
detail_octaves = 2
tower_spacing = 5
tower_radius = [1, 5]
tower_height = [0.5, 0.9]
tower_probability = 0.6
tower_anisotropy = 0.2
wind = [1, 0, 0.5]
detail_wind = [0, 0.1, 0]
seed = 4294967295
evaluation = "baked"
base_bake_resolution = 256
detail_bake_resolution = 32

[render]
step = 0.1
step_growth = 0.01
jitter = false
epsilon = 0.001
shadow_step = 0.2
shadow_growth = 0.5
skip_empty = false
majorant_cell = 0
inscatter = "powder"
inscatter_c = 3
inscatter_strength = 0.75
background = "transparent"
seed = 17
threads = 8
tile_size = 32
fps = 30

[output]
path = "renders/cloud.$F4.exr"
color_space = "lin_rec709"
aovs = ["depth", "transmittance"]
preview = "renders/cloud.####.png"
display = "sRGB"
view = "Un-tone-mapped"
)";

} // namespace

// ---------------------------------------------------------------- valid files and defaults

TEST(SceneFile, FullSceneParsesIntoTheStruct) {
    SceneFile f = parseSceneText(kFullScene, "full.toml");
    EXPECT_EQ(f.path, "full.toml");
    EXPECT_EQ(f.inputColorSpace, "ACEScg");
    EXPECT_EQ(f.frames, "1-48x2");
    const SceneDesc& s = f.scene;
    expectVec(s.camera.position, 1, 2, -30);
    expectVec(s.camera.lookAt, 0, 3, 0);
    expectVec(s.camera.up, 0, 1, 0);
    EXPECT_EQ(s.camera.fovY, 60.0f);
    EXPECT_EQ(s.camera.width, 1920);
    EXPECT_EQ(s.camera.height, 1080);

    EXPECT_TRUE(s.sun.enabled);
    expectVec(s.sun.direction, 0, 1, 0);           // normalised
    expectVec(s.sun.irradiance, 6.0f, 5.0f, 4.0f); // times intensity

    EXPECT_EQ(s.sky.kind, SkyKind::Uniform);
    expectVec(s.sky.zenith, 0.2f, 0.4f, 0.8f);
    EXPECT_EQ(s.sky.ambient, 0.5f);

    expectVec(s.medium.sigma_s, 0.9f, 0.9f, 0.9f); // grey shorthand
    expectVec(s.medium.sigma_a, 0.01f, 0.02f, 0.03f);
    EXPECT_EQ(s.medium.densityScale, 2.5f);
    EXPECT_EQ(s.medium.phase, PhaseKind::HenyeyGreenstein);
    EXPECT_EQ(s.medium.g, -0.3f);

    EXPECT_EQ(s.field.kind, FieldKind::Cumulus);
    const CumulusDesc& c = s.field.cumulus;
    expectVec(c.bounds.lo, -50, 2, -50);
    expectVec(c.bounds.hi, 50, 6, 50);
    EXPECT_EQ(c.density, 3.0f);
    EXPECT_EQ(c.coverage, 0.4f);
    EXPECT_EQ(c.softness, 0.2f);
    EXPECT_EQ(c.erosion, 0.5f);
    EXPECT_EQ(c.heightA, 40.0f);
    EXPECT_EQ(c.heightB, 3.0f);
    EXPECT_EQ(c.basePeriod, 16.0f);
    EXPECT_EQ(c.detailPeriod, 3.0f);
    EXPECT_EQ(c.baseLattice, 8);
    EXPECT_EQ(c.detailLattice, 6);
    EXPECT_EQ(c.baseOctaves, 5);
    EXPECT_EQ(c.detailOctaves, 2);
    EXPECT_EQ(c.towerSpacing, 5.0f);
    EXPECT_EQ(c.towerRadiusMin, 1.0f);
    EXPECT_EQ(c.towerRadiusMax, 5.0f);
    EXPECT_EQ(c.towerHeightMin, 0.5f);
    EXPECT_EQ(c.towerHeightMax, 0.9f);
    EXPECT_EQ(c.towerProbability, 0.6f);
    EXPECT_EQ(c.towerAnisotropy, 0.2f);
    expectVec(c.wind, 1, 0, 0.5f);
    expectVec(c.detailWind, 0, 0.1f, 0);
    EXPECT_EQ(c.seed, 4294967295u);
    EXPECT_EQ(c.eval, NoiseEval::Baked);
    EXPECT_EQ(c.baseBakeResolution, 256);
    EXPECT_EQ(c.detailBakeResolution, 32);

    const RenderDesc& r = s.render;
    EXPECT_EQ(r.step, 0.1f);
    EXPECT_EQ(r.stepGrowth, 0.01f);
    EXPECT_FALSE(r.jitter);
    EXPECT_EQ(r.epsilon, 0.001f);
    EXPECT_EQ(r.shadowStep, 0.2f);
    EXPECT_EQ(r.shadowGrowth, 0.5f);
    EXPECT_FALSE(r.skipEmpty);
    EXPECT_EQ(r.majorantCell, 0.0f);
    EXPECT_EQ(r.inScatter, InScatter::Powder);
    EXPECT_EQ(r.inScatterC, 3.0f);
    EXPECT_EQ(r.inScatterStrength, 0.75f);
    EXPECT_EQ(r.background, Background::Transparent);
    EXPECT_EQ(r.seed, 17u);
    EXPECT_EQ(r.threads, 8);
    EXPECT_EQ(r.tileSize, 32);
    EXPECT_EQ(r.fps, 30.0f);

    EXPECT_EQ(f.output.path, "renders/cloud.$F4.exr");
    EXPECT_EQ(f.output.colorSpace, "lin_rec709");
    EXPECT_TRUE(f.output.aovs.depth);
    EXPECT_TRUE(f.output.aovs.transmittance);
    EXPECT_EQ(f.output.preview, "renders/cloud.####.png");
    EXPECT_EQ(f.output.display, "sRGB");
    EXPECT_EQ(f.output.view, "Un-tone-mapped");

    // inscatter_c is ignored with "powder", majorant_cell with skip_empty = false
    ASSERT_EQ(f.warnings.size(), 2u);
    EXPECT_TRUE(startsWith(f.warnings[0], "full.toml:67:")) << f.warnings[0];
    EXPECT_TRUE(contains(f.warnings[0], "render.majorant_cell"));
    EXPECT_TRUE(startsWith(f.warnings[1], "full.toml:69:")) << f.warnings[1];
    EXPECT_TRUE(contains(f.warnings[1], "render.inscatter_c"));
}

TEST(SceneFile, MissingKeysTakeTheDefaults) {
    SceneFile f = parseSceneText("[render]\nstep = 0.5\n", "d.toml");
    const SceneDesc d;
    const io::OutputDesc o;
    EXPECT_EQ(f.scene.render.step, 0.5f);
    EXPECT_EQ(f.scene.render.shadowStep, d.render.shadowStep);
    EXPECT_EQ(f.scene.render.inScatter, d.render.inScatter);
    EXPECT_EQ(f.scene.camera.position, d.camera.position);
    EXPECT_EQ(f.scene.camera.fovY, d.camera.fovY);
    EXPECT_EQ(f.scene.camera.width, d.camera.width);
    EXPECT_EQ(f.scene.sun.direction, d.sun.direction);
    EXPECT_EQ(f.scene.sun.irradiance, d.sun.irradiance);
    EXPECT_EQ(f.scene.sky.kind, d.sky.kind);
    EXPECT_EQ(f.scene.medium.g, d.medium.g);
    EXPECT_EQ(f.scene.field.kind, d.field.kind);
    EXPECT_EQ(f.scene.field.cumulus.bounds.lo, d.field.cumulus.bounds.lo);
    EXPECT_EQ(f.scene.field.cumulus.towerRadiusMax, d.field.cumulus.towerRadiusMax);
    EXPECT_EQ(f.scene.field.cumulus.seed, d.field.cumulus.seed);
    EXPECT_EQ(f.output.path, o.path);
    EXPECT_EQ(f.output.colorSpace, o.colorSpace);
    EXPECT_EQ(f.output.view, o.view);
    EXPECT_EQ(f.frames, "1");
    EXPECT_EQ(f.inputColorSpace, "lin_rec709");
    EXPECT_TRUE(f.warnings.empty());
}

TEST(SceneFile, EmptyFileIsTheDefaultScene) {
    SceneFile f = parseSceneText("", "empty.toml");
    EXPECT_EQ(f.scene.render.step, SceneDesc{}.render.step);
    EXPECT_EQ(f.scene.field.cumulus.coverage, SceneDesc{}.field.cumulus.coverage);
    EXPECT_FALSE(f.output.aovs.depth);
}

TEST(SceneFile, HomogeneousField) {
    SceneFile f = parseSceneText(R"([field]
kind = "homogeneous"
bounds_min = [0, 0, 0]
bounds_max = [1, 2, 3]
density = 4
)",
                                 "h.toml");
    EXPECT_EQ(f.scene.field.kind, FieldKind::Homogeneous);
    expectVec(f.scene.field.homogeneous.box.lo, 0, 0, 0);
    expectVec(f.scene.field.homogeneous.box.hi, 1, 2, 3);
    EXPECT_EQ(f.scene.field.homogeneous.density, 4.0f);
    EXPECT_EQ(f.scene.field.cumulus.density, CumulusDesc{}.density); // untouched
}

TEST(SceneFile, SunFromElevationAndAzimuth) {
    auto dir = [](const std::string& el, const std::string& az) {
        return parseSceneText("[sun]\nelevation = " + el + "\nazimuth = " + az + "\n", "s.toml")
            .scene.sun.direction;
    };
    expectVec(dir("0", "90"), 1, 0, 0, 1e-6f);   // horizon, +x
    expectVec(dir("0", "0"), 0, 0, 1, 1e-6f);    // horizon, +z
    expectVec(dir("90", "123"), 0, 1, 0, 1e-6f); // zenith
    expectVec(dir("30", "-90"), -std::sqrt(3.0f) / 2, 0.5f, 0, 1e-6f);
}

TEST(SceneFile, IntegersAreAcceptedForNumbers) {
    SceneFile f = parseSceneText("[render]\nstep = 1\n[camera]\nfov = 90\n", "i.toml");
    EXPECT_EQ(f.scene.render.step, 1.0f);
    EXPECT_EQ(f.scene.camera.fovY, 90.0f);
}

TEST(SceneFile, FramesMayBeAnInteger) {
    EXPECT_EQ(parseSceneText("frames = 12\n", "f.toml").frames, "12");
}

TEST(SceneFile, LoadFromDisk) {
    std::filesystem::path p = std::filesystem::temp_directory_path() /
                              ("nimbus_scene_" + std::to_string(::getpid()) + ".toml");
    {
        std::ofstream out(p);
        out << "[camera]\nwidth = 320\n\n[render]\nstepp = 1\n";
    }
    try {
        io::loadSceneFile(p.string());
        ADD_FAILURE() << "no SceneError";
    } catch (const SceneError& e) {
        EXPECT_TRUE(startsWith(e.what(), p.string() + ":5:1:"));
        EXPECT_TRUE(contains(e.what(), "render.stepp"));
        EXPECT_TRUE(contains(e.what(), "did you mean \"step\""));
    }
    {
        std::ofstream out(p);
        out << "[camera]\nwidth = 320\n";
    }
    SceneFile f = io::loadSceneFile(p.string(), {"camera.height=200"});
    EXPECT_EQ(f.path, p.string());
    EXPECT_EQ(f.scene.camera.width, 320);
    EXPECT_EQ(f.scene.camera.height, 200);
    std::filesystem::remove(p);

    try {
        io::loadSceneFile(p.string());
        ADD_FAILURE() << "no SceneError for a missing file";
    } catch (const SceneError& e) {
        EXPECT_TRUE(startsWith(e.what(), p.string() + ": cannot read"));
    }
}

// ---------------------------------------------------------------- errors with file:line

TEST(SceneFileErrors, TomlSyntax) {
    std::string e = errorOf("[camera]\nfov = = 3\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "TOML syntax error"));
}

TEST(SceneFileErrors, UnknownTopLevelKey) {
    std::string e = errorOf("frames = \"1\"\ncolour_space = \"ACEScg\"\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:1: ")) << e;
    EXPECT_TRUE(contains(e, "unknown key \"colour_space\""));
    EXPECT_TRUE(contains(e, "did you mean \"color_space\""));
}

TEST(SceneFileErrors, UnknownSection) {
    std::string e = errorOf("[camera]\nfov = 40\n\n[cameras]\nfov = 40\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "\"cameras\""));
    EXPECT_TRUE(contains(e, "did you mean \"camera\""));
}

TEST(SceneFileErrors, UnknownNestedKey) {
    std::string e = errorOf("[render]\nstep = 0.1\nshadow_stepp = 0.2\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:1: ")) << e;
    EXPECT_TRUE(contains(e, "unknown key \"render.shadow_stepp\""));
    EXPECT_TRUE(contains(e, "did you mean \"shadow_step\""));
}

TEST(SceneFileErrors, UnknownSubTable) {
    std::string e = errorOf("[render]\nstep = 0.1\n\n[render.extra]\nx = 1\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "render.extra"));
}

TEST(SceneFileErrors, SectionThatIsNotATable) {
    std::string e = errorOf("frames = \"1\"\ncamera = 5\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "camera: expected a table"));
}

TEST(SceneFileErrors, WrongType) {
    std::string e = errorOf("[camera]\nwidth = 640\nfov = \"wide\"\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:7: ")) << e;
    EXPECT_TRUE(contains(e, "camera.fov"));
    EXPECT_TRUE(contains(e, "found string \"wide\""));
    EXPECT_TRUE(contains(e, "(0, 180)"));
}

TEST(SceneFileErrors, FloatWhereAnIntegerIsExpected) {
    std::string e = errorOf("[camera]\n\nwidth = 640.0\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "camera.width: expected an integer in [1, 16384], found 640"));
}

TEST(SceneFileErrors, WrongArrayShapeAndElement) {
    std::string e = errorOf("[camera]\nposition = [0, 1]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "camera.position: expected an array of 3 numbers"));
    EXPECT_TRUE(contains(e, "found an array of 2 elements"));

    e = errorOf("[camera]\nposition = [\n  0,\n  \"a\",\n  0]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "camera.position[1]"));
}

TEST(SceneFileErrors, OutOfRange) {
    std::string e = errorOf("[camera]\nfov = 180\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "camera.fov: expected a number in (0, 180), found 180"));

    e = errorOf("[render]\n\n\nstep = -0.5\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "render.step: expected a number >= 0, found -0.5"));

    e = errorOf("[medium]\ng = 1\n");
    EXPECT_TRUE(contains(e, "medium.g: expected a number in (-1, 1), found 1")) << e;

    e = errorOf("[sky]\nkind = \"gradient\"\nzenith = [0.1, -1, 0]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "sky.zenith[1]: expected a number >= 0, found -1"));

    e = errorOf("[field]\ncoverage = 1.5\n");
    EXPECT_TRUE(contains(e, "field.coverage: expected a number in [0, 1], found 1.5")) << e;

    e = errorOf("[render]\ntile_size = 2\n");
    EXPECT_TRUE(contains(e, "render.tile_size: expected an integer in [4, 256], found 2")) << e;
}

TEST(SceneFileErrors, NonFiniteNumbers) {
    for (const char* v : {"inf", "nan", "-inf", "1e300"}) {
        std::string e = errorOf(std::string("[render]\nstep = ") + v + "\n");
        EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
        EXPECT_TRUE(contains(e, "render.step: expected a number >= 0"));
    }
}

TEST(SceneFileErrors, Uint32Seeds) {
    EXPECT_EQ(parseSceneText("[render]\nseed = 4294967295\n", "t").scene.render.seed, 4294967295u);
    std::string e = errorOf("[render]\nseed = 4294967296\n");
    EXPECT_TRUE(contains(e, "render.seed: expected an integer in [0, 4294967295]")) << e;
    e = errorOf("[field]\nseed = -1\n");
    EXPECT_TRUE(contains(e, "field.seed")) << e;
}

TEST(SceneFileErrors, UnknownEnumWord) {
    std::string e = errorOf("[sky]\nkind = \"gradiant\"\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:8: ")) << e;
    EXPECT_TRUE(contains(e, "sky.kind: unknown value \"gradiant\""));
    EXPECT_TRUE(contains(e, "did you mean \"gradient\""));
    EXPECT_TRUE(contains(e, "\"none\", \"uniform\", \"gradient\""));

    e = errorOf("[output]\naovs = [\"depth\", \"alpha\"]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "output.aovs[1]: unknown value \"alpha\""));

    e = errorOf("[output]\naovs = [\"depth\", \"depth\"]\n");
    EXPECT_TRUE(contains(e, "listed twice")) << e;
}

TEST(SceneFileErrors, KeyOfTheOtherFieldKind) {
    std::string e = errorOf("[field]\nkind = \"homogeneous\"\ndensity = 2\ntower_spacing = 3\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:1: ")) << e;
    EXPECT_TRUE(contains(e, "field.tower_spacing"));
    EXPECT_TRUE(contains(e, "belongs to field.kind = \"cumulus\""));
    EXPECT_TRUE(contains(e, "field.kind is \"homogeneous\""));
}

TEST(SceneFileErrors, BadFieldKindDoesNotCascade) {
    std::string e = errorOf("[field]\nkind = \"cumulous\"\ntower_spacing = 3\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "did you mean \"cumulus\""));
    EXPECT_EQ(e.find('\n'), std::string::npos) << "one problem expected:\n" << e;
}

TEST(SceneFileErrors, AllProblemsAreReportedInFileOrder) {
    std::string e = errorOf("[render]\nstep = -1\nfps = -1\n\n[camera]\nfov = 0\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "\ntest.toml:3:"));
    EXPECT_TRUE(contains(e, "\ntest.toml:6:"));
}

TEST(SceneFileErrors, FrameSpec) {
    std::string e = errorOf("\nframes = \"5-1\"\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "frames: invalid frame spec \"5-1\""));
    EXPECT_TRUE(contains(e, "expected"));
}

TEST(SceneFileErrors, OutputPaths) {
    std::string e = errorOf("[output]\npath = \"a.####.png\"\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "output.path: expected a file name ending in .exr"));

    e = errorOf("[output]\npreview = \"a.####.jpg\"\n");
    EXPECT_TRUE(contains(e, "output.preview")) << e;

    // A single frame may go to a fixed name; several need a token.
    EXPECT_NO_THROW(parseSceneText("[output]\npath = \"still.exr\"\n", "t"));
    e = errorOf("frames = \"1-10\"\n\n[output]\npath = \"still.exr\"\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "output.path \"still.exr\" has no frame token"));
    EXPECT_TRUE(contains(e, "10 frames"));

    e = errorOf("frames = \"1,2\"\n[output]\npreview = \"p.png\"\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "output.preview"));
}

// ---------------------------------------------------------------- rules across keys

TEST(SceneFileRules, CameraLookAtEqualsPosition) {
    std::string e = errorOf("[camera]\nposition = [1, 2, 3]\nlook_at = [1, 2, 3]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "camera.look_at"));
}

TEST(SceneFileRules, CameraUpParallelToView) {
    std::string e = errorOf("[camera]\nposition = [0, 0, 0]\nlook_at = [0, 5, 0]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e; // up defaulted: blame look_at
    EXPECT_TRUE(contains(e, "camera.up"));
    EXPECT_TRUE(contains(e, "parallel"));

    e = errorOf("[camera]\nup = [0, 0, -2]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;

    e = errorOf("[camera]\nup = [0, 0, 0]\n");
    EXPECT_TRUE(contains(e, "camera.up: expected a non-zero vector")) << e;
}

// Finite camera vectors whose difference (or its squared length) overflows a float: the error
// says so, instead of blaming an up vector "parallel" to a NaN or zero direction.
TEST(SceneFileRules, CameraVectorsPastAFloatAreBlamedForWhatTheyAre) {
    std::string e = errorOf("[camera]\nposition = [3e38, 0, 0]\nlook_at = [-3e38, 0, 0]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "lies 6e+38 units from camera.position")) << e;
    EXPECT_TRUE(contains(e, "more than a float holds")) << e;
    EXPECT_FALSE(contains(e, "parallel")) << e;
    // 1e20 apart: fine for a float, its square is not; a valid camera that renders
    SceneFile f =
        parseSceneText("[camera]\nposition = [1e20, 0, 0]\nlook_at = [-1e20, 0, 0]\n", "test.toml");
    const Camera cam(f.scene.camera);
    EXPECT_NEAR(cam.forward.x, -1.0f, 1e-6f);
    EXPECT_NEAR(glm::length(cam.right), 1.0f, 1e-6f);
}

TEST(SceneFileRules, SunPlacement) {
    std::string e = errorOf("[sun]\ndirection = [0, 0, 0]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "sun.direction: expected a non-zero vector"));

    e = errorOf("[sun]\ndirection = [0, 1, 1]\nelevation = 10\nazimuth = 20\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "sun.direction"));

    e = errorOf("[sun]\n\nelevation = 10\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "sun.elevation needs sun.azimuth"));

    e = errorOf("[sun]\nelevation = 91\nazimuth = 0\n");
    EXPECT_TRUE(contains(e, "sun.elevation: expected a number in [-90, 90], found 91")) << e;
}

TEST(SceneFileRules, SunDirectionIsNormalisedAndIntensityScales) {
    SceneFile f =
        parseSceneText("[sun]\ndirection = [3, 0, 4]\nirradiance = 2\nintensity = 0.5\n", "t");
    expectVec(f.scene.sun.direction, 0.6f, 0.0f, 0.8f, 1e-6f);
    expectVec(f.scene.sun.irradiance, 1, 1, 1);
}

TEST(SceneFileRules, FieldBounds) {
    std::string e = errorOf("[field]\nbounds_min = [0, 5, 0]\nbounds_max = [10, 5, 10]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "field.bounds_min"));
    EXPECT_TRUE(contains(e, "on y"));

    e = errorOf("[field]\nkind = \"homogeneous\"\n\nbounds_max = [-2, 1, 1]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "on x"));
}

TEST(SceneFileRules, OctavesConserveEnergy) {
    SceneFile f = parseSceneText("[render]\noctaves = 4\noctave_extinction = 0.6\n"
                                 "octave_contribution = 0.4\noctave_eccentricity = 0.7\n",
                                 "t");
    EXPECT_EQ(f.scene.render.octaves, 4);
    EXPECT_EQ(f.scene.render.octaveExtinction, 0.6f);
    EXPECT_EQ(f.scene.render.octaveContribution, 0.4f);
    EXPECT_EQ(f.scene.render.octaveEccentricity, 0.7f);

    std::string e = errorOf("[render]\noctaves = 3\noctave_extinction = 0.3\n"
                            "octave_contribution = 0.5\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "render.octave_contribution 0.5 exceeds"));

    // single scattering: the octave keys are ignored (a warning), not checked against each other
    f = parseSceneText("[render]\noctave_contribution = 0.9\n", "t");
    ASSERT_EQ(f.warnings.size(), 1u);
    EXPECT_TRUE(contains(f.warnings[0], "render.octave_contribution is ignored"));
}

TEST(SceneFileRules, TowerRadius) {
    std::string e = errorOf("[field]\ntower_radius = [3, 2]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "field.tower_radius: min 3 exceeds max 2"));

    e = errorOf("[field]\ntower_spacing = 2\ntower_radius = [1, 2.5]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "field.tower_radius max 2.5 exceeds field.tower_spacing 2"));
    EXPECT_TRUE(contains(e, "footprints may not be wider than the spacing"));

    e = errorOf("[field]\ntower_spacing = 2\n"); // default radius max 3.5
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;

    e = errorOf("[field]\ntower_height = [0, 1]\n");
    EXPECT_TRUE(contains(e, "field.tower_height[0]: expected a number in (0, 1]")) << e;
}

// ---------------------------------------------------------------- warnings

TEST(SceneFileWarnings, IgnoredKeys) {
    SceneFile f = parseSceneText("[medium]\nphase = \"isotropic\"\ng = 0.5\n", "w.toml");
    ASSERT_EQ(f.warnings.size(), 1u);
    EXPECT_TRUE(startsWith(f.warnings[0], "w.toml:3:5: warning: ")) << f.warnings[0];
    EXPECT_TRUE(contains(f.warnings[0], "medium.g is ignored"));
    EXPECT_TRUE(contains(f.warnings[0], "medium.phase = \"hg\""));
}

TEST(SceneFileWarnings, MaxDepthIsUsedWhereverPhotonsMayCarryTheLight) {
    // "auto" (the default) traces photons where the cloud is thin or medium along the sun, and
    // render.max_depth caps their walks: setting it is not ignored there
    for (const char* ms :
         {"", "multiple_scattering = \"auto\"\n", "multiple_scattering = \"photons\"\n"}) {
        SceneFile f =
            parseSceneText(std::string("[render]\n") + ms + "max_depth = 4096\n", "d.toml");
        EXPECT_TRUE(f.warnings.empty()) << ms << (f.warnings.empty() ? "" : f.warnings[0]);
        EXPECT_EQ(f.scene.render.maxDepth, 4096);
    }
    // march with the grid alone traces no path and no photon
    SceneFile f =
        parseSceneText("[render]\nmultiple_scattering = \"grid\"\nmax_depth = 4096\n", "d.toml");
    ASSERT_EQ(f.warnings.size(), 1u);
    EXPECT_TRUE(contains(f.warnings[0], "render.max_depth is ignored")) << f.warnings[0];
    EXPECT_TRUE(contains(f.warnings[0], "\"auto\"")) << f.warnings[0];
}

TEST(SceneFileWarnings, SkyDirectionsAreUsedWhereAutoTracesTheSkyByPhotons) {
    // "auto" (the default) traces the sky by photons in an absorbing medium and marches its
    // single scattering over render.sky_directions: setting it is not ignored there, but is at
    // albedo 1, where the grid carries the sky
    SceneFile f = parseSceneText(
        "[medium]\nsigma_s = 0.9\nsigma_a = 0.1\n[render]\nsky_directions = 4\n", "k.toml");
    EXPECT_TRUE(f.warnings.empty()) << (f.warnings.empty() ? "" : f.warnings[0]);
    EXPECT_EQ(f.scene.render.skyDirections, 4);
    f = parseSceneText("[medium]\nsigma_s = 1\n[render]\nsky_directions = 4\n", "k.toml");
    ASSERT_EQ(f.warnings.size(), 1u);
    EXPECT_TRUE(contains(f.warnings[0], "render.sky_directions is ignored")) << f.warnings[0];
}

TEST(SceneFileWarnings, MarchSettingsAreIgnoredByThePathTracer) {
    // the keys only march reads say so in the table (Param::marchOnly): a path-traced scene that
    // sets them is warned, a marched one is not, and the validation suite's reference keys leave
    // them out (io::pixelNeutralSettings)
    const std::string keys = "octaves = 3\nphoton_walk_depth = 3\nepsilon = 0.02\nms_p1 = 0.5\n";
    SceneFile marched = parseSceneText("[render]\n" + keys, "m.toml");
    EXPECT_TRUE(marched.warnings.empty()) << marched.warnings.front();
    EXPECT_FALSE(pixelNeutralSettings(marched).count("render.octaves"));

    SceneFile traced =
        parseSceneText("[render]\nintegrator = \"pathtrace\"\nmultiple_scattering = \"auto\"\n" +
                           keys + "[sky]\nkind = \"uniform\"\nambient = 0.5\n",
                       "p.toml");
    ASSERT_EQ(traced.warnings.size(), 6u);
    for (const std::string& w : traced.warnings)
        EXPECT_TRUE(contains(w, "is ignored: it is used only when render.integrator = \"march\""))
            << w;
    const std::set<std::string> neutral = pixelNeutralSettings(traced);
    for (const char* k : {"render.octaves", "render.photon_walk_depth", "render.epsilon",
                          "render.ms_p1", "render.multiple_scattering", "sky.ambient",
                          "render.threads", "render.tile_size", "frames"})
        EXPECT_TRUE(neutral.count(k)) << k;
    // what the path tracer reads stays
    for (const char* k : {"render.max_depth", "render.spp", "medium.g", "sun.direction"})
        EXPECT_FALSE(neutral.count(k)) << k;
}

// ---------------------------------------------------------------- overrides

TEST(SceneFileOverrides, ReplaceAndAddValues) {
    const char* text = "[render]\nstep = 0.1\n\n[camera]\nfov = 30\n";
    SceneFile f =
        parseSceneText(text, "o.toml",
                       {"render.step=0.5", "camera.position=[0,1,2]", "output.path=\"x.####.exr\"",
                        "sky.kind=uniform", "frames=1-10", " render.jitter = false ",
                        "output.preview=shots/p.$F4.png", "medium.sigma_s=2"});
    EXPECT_EQ(f.scene.render.step, 0.5f);
    EXPECT_EQ(f.scene.camera.fovY, 30.0f); // from the file
    expectVec(f.scene.camera.position, 0, 1, 2);
    EXPECT_EQ(f.output.path, "x.####.exr");
    EXPECT_EQ(f.scene.sky.kind, SkyKind::Uniform);
    EXPECT_EQ(f.frames, "1-10");
    EXPECT_FALSE(f.scene.render.jitter);
    EXPECT_EQ(f.output.preview, "shots/p.$F4.png");
    expectVec(f.scene.medium.sigma_s, 2, 2, 2);
}

TEST(SceneFileOverrides, LaterOverrideWins) {
    SceneFile f = parseSceneText("", "o.toml", {"render.step=0.5", "render.step=0.25"});
    EXPECT_EQ(f.scene.render.step, 0.25f);
}

TEST(SceneFileOverrides, AreValidated) {
    std::string e = errorOf("[render]\nstep = 0.1\n", {"render.step=-1"});
    EXPECT_TRUE(startsWith(e, "--set render.step=-1: ")) << e;
    EXPECT_TRUE(contains(e, "render.step: expected a number >= 0, found -1"));

    e = errorOf("", {"camera.fov=wide"});
    EXPECT_TRUE(startsWith(e, "--set camera.fov=wide: camera.fov")) << e;
    EXPECT_TRUE(contains(e, "found string \"wide\""));

    e = errorOf("", {"sky.kind=gradiant"});
    EXPECT_TRUE(startsWith(e, "--set sky.kind=gradiant: sky.kind: unknown value")) << e;

    e = errorOf("[field]\nkind = \"homogeneous\"\n", {"field.coverage=0.5"});
    EXPECT_TRUE(startsWith(e, "--set field.coverage=0.5: field.coverage: belongs to")) << e;
}

TEST(SceneFileOverrides, UnknownKeys) {
    std::string e = errorOf("[render]\nstep = 0.1\n", {"render.stepp=1"});
    EXPECT_TRUE(startsWith(e, "--set render.stepp=1: unknown key \"render.stepp\"")) << e;

    e = errorOf("", {"rendr.step=1"});
    EXPECT_TRUE(startsWith(e, "--set rendr.step=1: unknown key \"rendr\"")) << e;
    EXPECT_TRUE(contains(e, "did you mean \"render\""));
}

TEST(SceneFileOverrides, Syntax) {
    std::string e = errorOf("", {"render.step"});
    EXPECT_TRUE(startsWith(e, "--set render.step: expected section.key=value")) << e;

    e = errorOf("", {"render.step="});
    EXPECT_TRUE(startsWith(e, "--set render.step=: missing value")) << e;

    e = errorOf("", {"camera.position=[0,1"});
    EXPECT_TRUE(startsWith(e, "--set camera.position=[0,1: invalid TOML value")) << e;

    e = errorOf("", {"render step=1"});
    EXPECT_TRUE(startsWith(e, "--set render step=1: expected section.key=value")) << e;

    e = errorOf("", {"render.step=1\n[camera]"});
    EXPECT_TRUE(contains(e, "single line")) << e;

    // Bytes that are not UTF-8 are not even a string (found by fuzzing: the toml++ exception
    // escaped the parser; tests/fuzz/regressions/scene).
    e = errorOf("", {"render.step=0.0h\x91l\x0e"});
    EXPECT_TRUE(startsWith(e, "--set render.step=0.0h")) << e;
    EXPECT_TRUE(contains(e, "invalid value")) << e;
}

TEST(SceneFileOverrides, TriggerRulesAgainstTheFile) {
    // The override makes several frames; the file's fixed output name is then the problem.
    std::string e = errorOf("[output]\npath = \"still.exr\"\n", {"frames=1-3"});
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "no frame token"));
}

// ---------------------------------------------------------------- the generated reference

namespace {
std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}
} // namespace

TEST(SceneFileReference, CheckedInFileMatchesTheCode) {
    const std::string path = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/reference.md";
    const std::string generated = io::sceneFileReference();
    if (const char* update = std::getenv("NIMBUS_UPDATE_REFERENCE"); update && *update == '1') {
        std::ofstream(path, std::ios::binary) << generated;
    }
    EXPECT_EQ(readFile(path), generated)
        << path << " is stale; regenerate it with NIMBUS_UPDATE_REFERENCE=1 nimbus_tests "
        << "--gtest_filter='SceneFileReference.*'";
}

TEST(SceneFileReference, DocumentsEveryKey) {
    const std::string md = io::sceneFileReference();
    std::vector<io::SceneParamInfo> params = io::sceneFileParameters();
    EXPECT_GT(params.size(), 70u);
    for (const io::SceneParamInfo& p : params) {
        std::string key = p.key.substr(p.key.rfind('.') + 1);
        EXPECT_TRUE(contains(md, "| `" + key + "` |")) << p.key;
        EXPECT_FALSE(p.doc.empty()) << p.key;
    }
    EXPECT_TRUE(contains(md, "## [field]"));
    EXPECT_TRUE(contains(md, "### [field] with kind = \"homogeneous\""));
    EXPECT_TRUE(contains(md, "| `fov` | number | `45` | `(0, 180)` |"));
}

TEST(SceneFileReference, DefaultsExampleParsesToTheDefaults) {
    const std::string md = io::sceneFileReference();
    // the block of that section (the SDF node tables have an example block of their own)
    size_t a = md.find("```toml\n", md.find("## Every key at its default"));
    ASSERT_NE(a, std::string::npos);
    a += 8;
    size_t b = md.find("```", a);
    ASSERT_NE(b, std::string::npos);
    SceneFile f = parseSceneText(md.substr(a, b - a), "reference.md");
    const SceneDesc d;
    EXPECT_TRUE(f.warnings.empty()) << f.warnings.front();
    EXPECT_EQ(f.scene.camera.position, d.camera.position);
    EXPECT_EQ(f.scene.sun.direction, d.sun.direction);
    EXPECT_EQ(f.scene.sky.zenith, d.sky.zenith);
    EXPECT_EQ(f.scene.medium.sigma_s, d.medium.sigma_s);
    EXPECT_EQ(f.scene.field.cumulus.bounds.lo, d.field.cumulus.bounds.lo);
    EXPECT_EQ(f.scene.field.cumulus.towerHeightMin, d.field.cumulus.towerHeightMin);
    EXPECT_EQ(f.scene.render.step, d.render.step);
    EXPECT_EQ(f.scene.render.shadowGrowth, d.render.shadowGrowth);
    EXPECT_EQ(f.output.path, io::OutputDesc{}.path);
    // every key of the table appears in the example (except unset, homogeneous, vdb, gardner,
    // sdf and automaton ones)
    for (const io::SceneParamInfo& p : io::sceneFileParameters()) {
        if (p.value.empty() || p.only.find("homogeneous") != std::string::npos ||
            p.only.find("vdb") != std::string::npos ||
            p.only.find("gardner") != std::string::npos ||
            p.only.find("sdf") != std::string::npos ||
            p.only.find("automaton") != std::string::npos)
            continue;
        std::string key = p.key.substr(p.key.rfind('.') + 1);
        const std::string block = md.substr(a - 1, b - a + 1);
        bool listed = contains(block, "\n" + key + " = " + p.value) ||
                      contains(block, "\n# " + key + " = " + p.value); // ignored at defaults
        EXPECT_TRUE(listed) << p.key;
    }
}

// ------------------------------------------------------------------------------------------
// Queries derived from the table: settings, the step schedule, calibration knobs
// ------------------------------------------------------------------------------------------

TEST(SceneSettings, SayWhichIntegratorWasUsed) {
    const SceneFile pt = parseSceneText("[render]\nintegrator = \"pathtrace\"\nspp = 4\n", "pt");
    const auto s = io::sceneSettings(pt);
    EXPECT_EQ(s.at("render.integrator"), "\"pathtrace\"");
    EXPECT_EQ(s.at("render.spp"), "4");
    EXPECT_EQ(io::sceneSettings(parseSceneText("", "m")).at("render.integrator"), "\"march\"");
}

TEST(SceneSettings, ListEveryKeyWithAValue) {
    for (const char* kind : {"cumulus", "homogeneous"}) {
        const SceneFile f =
            parseSceneText(std::string("[field]\nkind = \"") + kind + "\"\n", "settings");
        const auto s = io::sceneSettings(f);
        for (const io::SceneParamInfo& p : io::sceneFileParameters()) {
            if (p.value.empty()) continue; // unset: sun.elevation, sun.azimuth
            const bool otherKind =
                !p.only.empty() && p.only.rfind("field.kind = ", 0) == 0 &&
                p.only.rfind(std::string("field.kind = \"") + kind + "\"", 0) != 0;
            if (otherKind) {
                // a key of another kind only appears when this kind has a key of that name
                continue;
            }
            ASSERT_TRUE(s.count(p.key)) << kind << ": " << p.key;
        }
        EXPECT_EQ(s.at("field.kind"), std::string("\"") + kind + "\"");
    }
}

TEST(SceneSettings, ValuesAreTheEffectiveOnes) {
    const SceneFile f = parseSceneText("[sun]\nirradiance = 2\nintensity = 3\n"
                                       "[render]\nstep = 0.1\n[[volume]]\nname = \"a\"\n"
                                       "path = \"a.vdb\"\n",
                                       "settings");
    const auto s = io::sceneSettings(f);
    EXPECT_EQ(s.at("sun.irradiance"), "6"); // intensity folded in
    EXPECT_EQ(s.at("sun.intensity"), "1");
    EXPECT_EQ(s.at("render.step"), "0.1");
    EXPECT_EQ(s.at("volume[0].path"), "\"a.vdb\"");
    EXPECT_EQ(s.count("sun.elevation"), 0u);
    // each value parses back to the same scene
    const SceneFile again = parseSceneText("", "again", {"render.step=" + s.at("render.step")});
    EXPECT_EQ(again.scene.render.step, f.scene.render.step);
}

TEST(SceneSteps, ScaleExactlyTheStepKeys) {
    EXPECT_EQ(io::stepScheduleKeys(),
              (std::vector<std::string>{"render.step", "render.step_voxels", "render.step_growth",
                                        "render.shadow_step", "render.shadow_step_voxels"}));
    SceneFile f =
        parseSceneText("[render]\nstep = 0.04\nstep_growth = 0.002\nshadow_step = 0.1\n", "steps");
    const auto before = io::sceneSettings(f);
    io::scaleSteps(f.scene, 0.5);
    EXPECT_EQ(f.scene.render.step, float(double(0.04f) * 0.5));
    EXPECT_EQ(f.scene.render.stepGrowth, float(double(0.002f) * 0.5));
    EXPECT_EQ(f.scene.render.shadowStep, float(double(0.1f) * 0.5));
    const auto after = io::sceneSettings(f);
    for (const auto& [key, value] : before) {
        const bool step = key == "render.step" || key == "render.step_voxels" ||
                          key == "render.step_growth" || key == "render.shadow_step" ||
                          key == "render.shadow_step_voxels";
        EXPECT_EQ(value != after.at(key), step) << key;
    }
}

TEST(SceneCalibration, KnobsComeFromTheTable) {
    const std::vector<io::CalibrationKnob> knobs = io::calibrationKnobs();
    std::vector<std::string> keys;
    for (const io::CalibrationKnob& k : knobs) keys.push_back(k.key);
    EXPECT_EQ(keys, (std::vector<std::string>{"sky.ambient", "render.octave_extinction",
                                              "render.octave_contribution",
                                              "render.octave_eccentricity", "render.ms_strength",
                                              "render.ms_p1", "render.sky_openness"}));
    SceneDesc d;
    for (const io::CalibrationKnob& k : knobs) {
        EXPECT_FALSE(k.values.empty()) << k.key;
        for (double v : k.values) {
            EXPECT_GE(v, k.lo) << k.key;
            EXPECT_LE(v, k.hi) << k.key;
        }
        EXPECT_EQ(k.get(d), k.defaultValue) << k.key;
        k.set(d, 0.25);
        EXPECT_EQ(k.get(d), 0.25) << k.key;
    }
    EXPECT_EQ(d.render.octaveExtinction, 0.25f);
    EXPECT_EQ(d.sky.ambient, 0.25f);
    // applies = the key's "used only when"
    SceneDesc ms;
    ms.render.multipleScattering = MultipleScattering::None;
    ms.render.octaves = 1;
    for (const io::CalibrationKnob& k : knobs)
        if (k.key == "render.octave_extinction" || k.key == "render.ms_strength")
            EXPECT_FALSE(k.applies(ms)) << k.key;
}
