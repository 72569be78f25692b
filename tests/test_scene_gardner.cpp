/// @file test_scene_gardner.cpp
/// @brief Scene files with `[field] kind = "gardner"`: the cloud's defaults, `[[field.ellipsoid]]`
///        and `[field.scatter]` tables, and their errors with file:line (plugin/io/scene).
#include <gtest/gtest.h>

#include <string>

#include "plugin/io/scene_file.h"
#include "tests/test_util.h"

using namespace nimbus;
using nimbus::io::parseSceneText;
using nimbus::io::SceneError;
using nimbus::io::SceneFile;

namespace {

testing::AssertionResult startsWith(const std::string& text, const std::string& prefix) {
    if (text.rfind(prefix, 0) == 0) return testing::AssertionSuccess();
    return testing::AssertionFailure() << "expected prefix \"" << prefix << "\" in:\n" << text;
}

std::string errorOf(const std::string& text) {
    try {
        parseSceneText(text, "test.toml");
        ADD_FAILURE() << "no SceneError for:\n" << text;
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

const std::string kHead = "[field]\nkind = \"gardner\"\n"; // lines 1-2

} // namespace

TEST(SceneGardner, HandWrittenCloudParses) {
    const SceneFile f = parseSceneText(kHead + R"(t1 = 0.1
t2 = 0.4
d = 0.2
density = 2
frequency = 0.5
terms = 4
k = 0.9
t0 = 0.7
phase = 1.0
texture_offset = [1, 2, 3]

[[field.ellipsoid]]
center = [0, 2, 0]
radii = [3, 1.5, 2]
rotate = [0, 30, 0]

[[field.ellipsoid]]
center = [4, 2.5, 1]
radii = [2, 2, 2]
t2 = 0.6
terms = 3

[field.scatter]
count = 12
size = 1.5
seed = 9
center = [0, 1, 0]
extent = [8, 4, 5]
)",
                                       "test.toml");
    const GardnerDesc& g = f.scene.field.gardner;
    EXPECT_EQ(f.scene.field.kind, FieldKind::Gardner);
    EXPECT_FLOAT_EQ(g.defaults.t1, 0.1f);
    EXPECT_FLOAT_EQ(g.defaults.t2, 0.4f);
    EXPECT_FLOAT_EQ(g.defaults.d, 0.2f);
    EXPECT_FLOAT_EQ(g.defaults.density, 2.0f);
    EXPECT_FLOAT_EQ(g.defaults.texture.frequency, 0.5f);
    EXPECT_EQ(g.defaults.texture.terms, 4);
    EXPECT_FLOAT_EQ(g.defaults.texture.k, 0.9f);
    EXPECT_FLOAT_EQ(g.defaults.texture.t0, 0.7f);
    EXPECT_FLOAT_EQ(g.defaults.texture.phase, 1.0f);
    EXPECT_EQ(g.defaults.texture.offset, vec3(1.0f, 2.0f, 3.0f));
    ASSERT_EQ(g.ellipsoids.size(), 2u);
    EXPECT_EQ(g.ellipsoids[0].radii, vec3(3.0f, 1.5f, 2.0f));
    EXPECT_EQ(g.ellipsoids[0].rotate, vec3(0.0f, 30.0f, 0.0f));
    EXPECT_FALSE(g.ellipsoids[0].t2.has_value());
    EXPECT_FLOAT_EQ(g.ellipsoids[1].t2.value_or(-1.0f), 0.6f);
    EXPECT_EQ(g.ellipsoids[1].terms.value_or(-1), 3);
    EXPECT_TRUE(g.scatter.enabled);
    EXPECT_EQ(g.scatter.count, 12);
    EXPECT_FLOAT_EQ(g.scatter.size, 1.5f);
    EXPECT_EQ(g.scatter.seed, 9u);
    EXPECT_EQ(g.scatter.extent, vec3(8.0f, 4.0f, 5.0f));
}

TEST(SceneGardner, ScatterAloneIsACloud) {
    const SceneFile f = parseSceneText(kHead + "[field.scatter]\n", "test.toml");
    EXPECT_TRUE(f.scene.field.gardner.scatter.enabled);
    EXPECT_TRUE(f.scene.field.gardner.ellipsoids.empty());
}

TEST(SceneGardner, TheExampleParses) {
    const SceneFile f =
        io::loadSceneFile(std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/gardner.toml");
    EXPECT_EQ(f.scene.field.kind, FieldKind::Gardner);
    EXPECT_TRUE(f.scene.field.gardner.scatter.enabled);
    EXPECT_TRUE(f.warnings.empty()) << f.warnings.front();
}

TEST(SceneGardnerErrors, WrongTypeInAnEllipsoid) {
    const std::string e =
        errorOf(kHead + "[[field.ellipsoid]]\ncenter = [0, 1, 0]\nradii = \"large\"\n");
    EXPECT_TRUE(startsWith(e, "test.toml:5:9: ")) << e;
    EXPECT_TRUE(contains(e, "field.ellipsoid[0].radii: expected an array of 3 numbers")) << e;
    EXPECT_TRUE(contains(e, "found string \"large\"")) << e;
}

TEST(SceneGardnerErrors, NegativeRadius) {
    const std::string e = errorOf(kHead + "[[field.ellipsoid]]\nradii = [1, 2, 1]\n\n"
                                          "[[field.ellipsoid]]\nradii = [1, -2, 1]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:7:")) << e;
    EXPECT_TRUE(contains(e, "field.ellipsoid[1].radii[1]: expected a number > 0, found -2")) << e;
}

TEST(SceneGardnerErrors, T2BelowT1) {
    std::string e = errorOf(kHead + "t1 = 0.5\nt2 = 0.2\n[[field.ellipsoid]]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "t2 0.2 is below t1 0.5")) << e;
    // in an ellipsoid, against the cloud's t1
    e = errorOf(kHead +
                "t1 = 0.3\nt2 = 0.5\n[[field.ellipsoid]]\n\n[[field.ellipsoid]]\nt2 = 0.1\n");
    EXPECT_TRUE(startsWith(e, "test.toml:8:")) << e;
    EXPECT_TRUE(contains(e, "field.ellipsoid[1]: t2 0.1 is below t1 0.3")) << e;
    EXPECT_TRUE(contains(e, "(the other from [field])")) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << "one problem expected:\n" << e;
}

TEST(SceneGardnerErrors, RampWidthMustBePositive) {
    std::string e = errorOf(kHead + "d = 0\n[[field.ellipsoid]]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "field.d: expected a number > 0, found 0")) << e;
    e = errorOf(kHead + "[[field.ellipsoid]]\nd = -0.5\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "field.ellipsoid[0].d: expected a number > 0")) << e;
}

TEST(SceneGardnerErrors, TermsAreIntegersInRange) {
    std::string e = errorOf(kHead + "[[field.ellipsoid]]\nterms = 2.5\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:")) << e;
    EXPECT_TRUE(contains(e, "field.ellipsoid[0].terms: expected an integer in [1, 12]")) << e;
    e = errorOf(kHead + "terms = 13\n[field.scatter]\n");
    EXPECT_TRUE(contains(e, "field.terms: expected an integer in [1, 12], found 13")) << e;
}

TEST(SceneGardnerErrors, UnknownKeysInTheTables) {
    std::string e = errorOf(kHead + "[[field.ellipsoid]]\nradius = [1, 1, 1]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:1: ")) << e;
    EXPECT_TRUE(contains(e, "unknown key \"field.ellipsoid[0].radius\" (did you mean \"radii\"?)"))
        << e;
    e = errorOf(kHead + "[field.scatter]\ncounts = 3\n");
    EXPECT_TRUE(startsWith(e, "test.toml:4:1: ")) << e;
    EXPECT_TRUE(contains(e, "(did you mean \"count\"?)")) << e;
}

TEST(SceneGardnerErrors, TablesOfTheWrongShape) {
    std::string e = errorOf(kHead + "ellipsoid = [1, 2]\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "field.ellipsoid: expected [[field.ellipsoid]] tables")) << e;
    e = errorOf(kHead + "scatter = 3\n");
    EXPECT_TRUE(startsWith(e, "test.toml:3:")) << e;
    EXPECT_TRUE(contains(e, "field.scatter: expected a table ([field.scatter]), found 3")) << e;
    e = errorOf(kHead + "[field.scatter]\ncount = 0\n");
    EXPECT_TRUE(contains(e, "field.scatter.count: expected an integer in [1, 1000], found 0")) << e;
}

TEST(SceneGardnerErrors, NeedsEllipsoids) {
    const std::string e = errorOf(kHead + "t1 = 0.1\n");
    EXPECT_TRUE(startsWith(e, "test.toml:2:")) << e;
    EXPECT_TRUE(contains(e, "needs ellipsoids")) << e;
}

TEST(SceneGardnerErrors, EllipsoidsBelongToGardner) {
    const std::string e =
        errorOf("[field]\nkind = \"cumulus\"\n\n[[field.ellipsoid]]\nradii = [1, 1, 1]\n");
    EXPECT_TRUE(contains(e, "field.ellipsoid: belongs to field.kind = \"gardner\"")) << e;
    EXPECT_TRUE(contains(e, "field.kind is \"cumulus\"")) << e;
}
