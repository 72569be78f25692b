/// @file test_scene_automaton.cpp
/// @brief Scene files with `[field] kind = "automaton"`: its keys and `[[field.wind]]` rows, and
///        their errors with file:line (plugin/io/scene).
#include <gtest/gtest.h>

#include <string>

#include "plugin/io/scene_file.h"

using namespace nimbus;
using nimbus::io::parseSceneText;
using nimbus::io::SceneError;
using nimbus::io::SceneFile;

namespace {

std::string errorOf(const std::string& text) {
    try {
        parseSceneText(text, "test.toml");
        ADD_FAILURE() << "no SceneError for:\n" << text;
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

const std::string kHead = "[field]\nkind = \"automaton\"\n"; // lines 1-2

} // namespace

TEST(SceneAutomaton, EveryKeyParses) {
    const SceneFile f = parseSceneText(kHead + R"(resolution = [96, 12, 80]
bounds_min = [-10, 1, -8]
bounds_max = [10, 3, 8]
density = 3
seed = 17
sim_step = 0.05
warmup = 4
cover = 0.5
cover_tolerance = 0.1
ellipsoids = 9
min_ellipsoids = 3
max_ellipsoids = 20
adapt_period = 5
size = 12
size_spread = 3
height_ratio = 0.5
lifetime = 30
lifetime_spread = 5
shrink_time = 4
region_margin = 10
layer = [0.2, 0.5]
p_humidity = 0.2
p_activation = 0.02
p_extinction = 0.05
start_full = true
checkpoint_every = 50

[[field.wind]]
altitude = 1
wind = [2, 0, 0.5]

[[field.wind]]
altitude = 3
wind = [8, 0, -1]
)",
                                       "test.toml");
    EXPECT_EQ(f.scene.field.kind, FieldKind::Automaton);
    const AutomatonDesc& a = f.scene.field.automaton;
    EXPECT_EQ(a.res, ivec3(96, 12, 80));
    EXPECT_EQ(a.bounds.lo, vec3(-10, 1, -8));
    EXPECT_EQ(a.bounds.hi, vec3(10, 3, 8));
    EXPECT_FLOAT_EQ(a.density, 3.0f);
    EXPECT_EQ(a.seed, 17u);
    EXPECT_FLOAT_EQ(a.simStep, 0.05f);
    EXPECT_FLOAT_EQ(a.warmup, 4.0f);
    EXPECT_FLOAT_EQ(a.targetCover, 0.5f);
    EXPECT_FLOAT_EQ(a.coverTolerance, 0.1f);
    EXPECT_EQ(a.ellipsoids, 9);
    EXPECT_EQ(a.minEllipsoids, 3);
    EXPECT_EQ(a.maxEllipsoids, 20);
    EXPECT_EQ(a.adaptPeriod, 5);
    EXPECT_FLOAT_EQ(a.sizeMean, 12.0f);
    EXPECT_FLOAT_EQ(a.sizeVar, 3.0f);
    EXPECT_FLOAT_EQ(a.heightRatio, 0.5f);
    EXPECT_FLOAT_EQ(a.lifeMean, 30.0f);
    EXPECT_FLOAT_EQ(a.lifeVar, 5.0f);
    EXPECT_FLOAT_EQ(a.shrinkTime, 4.0f);
    EXPECT_FLOAT_EQ(a.regionMargin, 10.0f);
    EXPECT_FLOAT_EQ(a.layerLo, 0.2f);
    EXPECT_FLOAT_EQ(a.layerHi, 0.5f);
    EXPECT_FLOAT_EQ(a.pHum, 0.2f);
    EXPECT_FLOAT_EQ(a.pAct, 0.02f);
    EXPECT_FLOAT_EQ(a.pExt, 0.05f);
    EXPECT_TRUE(a.startFull);
    EXPECT_EQ(a.checkpointEvery, 50);
    ASSERT_EQ(a.wind.size(), 2u);
    EXPECT_FLOAT_EQ(a.wind[1].altitude, 3.0f);
    EXPECT_EQ(a.wind[1].wind, vec3(8, 0, -1));
}

TEST(SceneAutomaton, DefaultsAreTheAutomatonsStableSet) {
    const AutomatonDesc a = parseSceneText(kHead, "test.toml").scene.field.automaton;
    EXPECT_EQ(a.res, ivec3(256, 32, 256));
    EXPECT_FLOAT_EQ(a.simStep, 0.1f);
    EXPECT_FLOAT_EQ(a.targetCover, 0.35f);
    EXPECT_EQ(a.ellipsoids, 24);
    EXPECT_FLOAT_EQ(a.sizeMean, 28.0f);
    EXPECT_TRUE(a.wind.empty());
}

TEST(SceneAutomaton, AResolutionPastTheLimitIsRefusedWithTheLimit) {
    const std::string e = errorOf(kHead + "resolution = [1024, 64, 1024]\n");
    EXPECT_NE(e.find("test.toml:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("67108864 cells; the limit is 16777216"), std::string::npos) << e;
    const std::string frac = errorOf(kHead + "resolution = [64.5, 8, 64]\n");
    EXPECT_NE(frac.find("test.toml:3:"), std::string::npos) << frac;
    EXPECT_NE(frac.find("whole numbers"), std::string::npos) << frac;
    const std::string zero = errorOf(kHead + "resolution = [0, 8, 64]\n");
    EXPECT_NE(zero.find("test.toml:3:"), std::string::npos) << zero;
}

TEST(SceneAutomaton, RangesAreCheckedWithFileAndLine) {
    struct Case {
        const char* line;
        const char* expect;
    };
    for (const Case& c :
         {Case{"sim_step = 0", "field.sim_step"}, Case{"cover = 1.5", "field.cover"},
          Case{"p_extinction = -0.1", "field.p_extinction"}, Case{"size = 0", "field.size"},
          Case{"layer = [0.7, 0.2]", "field.layer"}, Case{"warmup = 1e9", "field.warmup"},
          Case{"seed = -1", "field.seed"}, Case{"density = -1", "field.density"}}) {
        const std::string e = errorOf(kHead + c.line + "\n");
        EXPECT_NE(e.find("test.toml:3:"), std::string::npos) << c.line << ": " << e;
        EXPECT_NE(e.find(c.expect), std::string::npos) << c.line << ": " << e;
    }
}

TEST(SceneAutomaton, CrossKeyProblemsAreReported) {
    const std::string minmax = errorOf(kHead + "min_ellipsoids = 9\nmax_ellipsoids = 4\n");
    EXPECT_NE(minmax.find("test.toml:3:"), std::string::npos) << minmax;
    EXPECT_NE(minmax.find("exceeds field.max_ellipsoids 4"), std::string::npos) << minmax;
    const std::string bounds = errorOf(kHead + "bounds_min = [0, 5, 0]\nbounds_max = [1, 2, 1]\n");
    EXPECT_NE(bounds.find("must be below field.bounds_max"), std::string::npos) << bounds;
}

TEST(SceneAutomaton, WindRowsAreCheckedWithFileAndLine) {
    const std::string vertical =
        errorOf(kHead + "[[field.wind]]\naltitude = 1\nwind = [1, 0.5, 0]\n");
    EXPECT_NE(vertical.find("test.toml:5:"), std::string::npos) << vertical;
    EXPECT_NE(vertical.find("expected y = 0"), std::string::npos) << vertical;
    const std::string order = errorOf(kHead + "[[field.wind]]\naltitude = 3\nwind = [1, 0, 0]\n"
                                              "[[field.wind]]\naltitude = 2\nwind = [4, 0, 0]\n");
    EXPECT_NE(order.find("test.toml:7:"), std::string::npos) << order;
    EXPECT_NE(order.find("field.wind[1].altitude 2 is not above"), std::string::npos) << order;
    const std::string unknown =
        errorOf(kHead + "[[field.wind]]\naltitude = 1\nspeed = [1, 0, 0]\n");
    EXPECT_NE(unknown.find("test.toml:5:"), std::string::npos) << unknown;
    EXPECT_NE(unknown.find("unknown key \"field.wind[0].speed\""), std::string::npos) << unknown;
}

TEST(SceneAutomaton, KeysOfTheAutomatonAreRefusedForOtherKinds) {
    const std::string e = errorOf("[field]\nkind = \"cumulus\"\nsim_step = 0.1\n");
    EXPECT_NE(e.find("test.toml:3:"), std::string::npos) << e;
    const std::string w =
        errorOf("[field]\nkind = \"cumulus\"\n[[field.wind]]\naltitude = 1\nwind = [1, 0, 0]\n");
    EXPECT_FALSE(w.empty());
}
