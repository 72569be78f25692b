/// @file test_automaton_field.cpp
/// @brief `[field] kind = "automaton"` (core/fields/automaton_field.h, core/sim/automaton_wind.h):
///        the majorant bounds the density at random points, a frame rendered alone equals the
///        same frame of a sequence bit for bit, the cloud moves with the wind by wind x dt, a
///        scene renders without NaN, a white furnace returns the sky.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include "core/fields/field.h"
#include "core/render.h"
#include "tests/render_util.h"

using namespace nimbus;

namespace {

/// A small automaton: 48 x 8 x 48 cells over 24 x 4 x 24 world units, a sheared wind.
AutomatonDesc smallAutomaton() {
    AutomatonDesc a;
    a.res = ivec3(48, 8, 48);
    a.bounds = Box{vec3(-12.0f, 1.0f, -12.0f), vec3(12.0f, 5.0f, 12.0f)};
    a.sizeMean = 8.0f;
    a.sizeVar = 2.0f;
    a.regionMargin = 8.0f;
    a.ellipsoids = 8;
    a.warmup = 3.0f;
    a.wind = {AutomatonWindRow{1.0f, vec3(2.0f, 0.0f, 0.5f)},
              AutomatonWindRow{5.0f, vec3(6.0f, 0.0f, -1.0f)}};
    return a;
}

FieldDesc automatonFieldDesc(const AutomatonDesc& a) {
    FieldDesc f;
    f.kind = FieldKind::Automaton;
    f.automaton = a;
    return f;
}

/// A scene looking at the small automaton from the side, lit by a low sun.
SceneDesc automatonScene(int width = 24, int height = 14) {
    SceneDesc s;
    s.camera =
        cameraLookingAt(vec3(0.0f, 3.0f, -30.0f), vec3(0.0f, 3.0f, 0.0f), width, height, 50.0f);
    s.field = automatonFieldDesc(smallAutomaton());
    s.field.automaton.density = 4.0f;
    s.render.fps = 24.0f;
    s.render.step = 0.1f;
    s.render.shadowStep = 0.2f;
    s.render.threads = 2;
    return s;
}

bool sameBits(const Framebuffer& a, const Framebuffer& b) {
    if (a.rgba.size() != b.rgba.size()) return false;
    return std::memcmp(a.rgba.data(), b.rgba.data(), a.rgba.size() * sizeof(float)) == 0;
}

/// Centre of mass (index space, x and z) and mass of a frame's density.
struct Moments {
    double mass = 0.0, x = 0.0, z = 0.0;
};
Moments momentsOf(const sim::DensityGrid& d) {
    Moments m;
    for (int z = 0; z < d.res.z; ++z)
        for (int y = 0; y < d.res.y; ++y)
            for (int x = 0; x < d.res.x; ++x) {
                const double v = d.at(x, y, z);
                m.mass += v;
                m.x += v * (x + 0.5);
                m.z += v * (z + 0.5);
            }
    m.x /= m.mass;
    m.z /= m.mass;
    return m;
}

} // namespace

TEST(AutomatonField, MajorantBoundsDensityAtRandomPoints) {
    const FieldDesc fd = automatonFieldDesc(smallAutomaton());
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    int inside = 0, tested = 0;
    for (float time : {0.0f, 0.5f, 1.3f}) {
        const Field f = makeField(fd, time);
        const Box& b = f.bounds();
        ASSERT_GT(f.majorant(b), 0.0f) << "no cloud to test at t = " << time;
        for (int i = 0; i < 20000; ++i) {
            // a random box (from a point to a quarter of the bounds) and a point inside it;
            // a tenth of the boxes reach past the bounds
            const vec3 e = b.extent() * 1.2f;
            const vec3 lo = b.lo - 0.1f * b.extent() + vec3(u(rng), u(rng), u(rng)) * e;
            const vec3 size = vec3(u(rng), u(rng), u(rng)) * b.extent() * (i % 2 ? 0.25f : 0.02f);
            const Box box{lo, lo + size};
            const vec3 p = box.lo + vec3(u(rng), u(rng), u(rng)) * size;
            const float d = f.density(p), m = f.majorant(box);
            ++tested;
            inside += d > 0.0f;
            ASSERT_LE(d, m) << "t " << time << " p " << p.x << " " << p.y << " " << p.z;
            // a point box
            ASSERT_LE(d, f.majorant(Box{p, p}));
        }
    }
    RecordProperty("points_with_density", inside);
    EXPECT_GT(inside, tested / 50) << "too few points in cloud to test the bound";
}

TEST(AutomatonField, FrameAloneEqualsFrameInSequence) {
    const SceneDesc s = automatonScene();
    Renderer seq(s);
    Framebuffer fb, seven;
    RenderStats st;
    for (int frame = 1; frame <= 7; ++frame) {
        ASSERT_TRUE(seq.render(seq.plan(frame), fb, st));
        if (frame == 7) seven = fb;
        // the renderer keeps the simulation: frame 1 simulates from step 0 (3 s warm-up at
        // 0.1 s: steps 0-31), each later frame only the step it moves past (0.42 per frame)
        if (frame == 1) EXPECT_EQ(st.automatonSteps, 31u);
        if (frame > 1) EXPECT_LE(st.automatonSteps, 1u) << "frame " << frame;
    }
    Renderer alone(s);
    Framebuffer lone;
    ASSERT_TRUE(alone.render(alone.plan(7), lone, st));
    EXPECT_EQ(st.automatonSteps, 33u); // 3 s + 7 / 24 s: steps 0-32, then 33 for the lerp
    EXPECT_TRUE(sameBits(seven, lone)) << "frame 7 alone differs from frame 7 of 1-7";
    // going back in time (a checkpoint every 10 steps here) gives the lone frame 3 as well
    SceneDesc c = s;
    c.field.automaton.checkpointEvery = 10;
    Renderer back(c);
    ASSERT_TRUE(back.render(back.plan(40), fb, st));
    Framebuffer three, loneThree;
    ASSERT_TRUE(back.render(back.plan(3), three, st));
    Renderer alone3(s);
    ASSERT_TRUE(alone3.render(alone3.plan(3), loneThree, st));
    EXPECT_TRUE(sameBits(three, loneThree)) << "frame 3 after frame 40 differs from frame 3 alone";
    // and the frames differ from each other (the cloud moves)
    EXPECT_FALSE(sameBits(seven, three));
}

TEST(AutomatonField, UniformWindMovesTheCentreOfMassByWindDt) {
    // One region ellipsoid, retired as soon as any cloud shows (target cover 0, adapted every
    // step) so that it shrinks away over 2 s, and no extinction: after the 4 s warm-up the
    // cloud it grew is frozen, and only the wind moves it. 96 x 8 x 48 unit cells, wind 6
    // units/s along x and 1.5 along z: frames at 24 fps move it 0.25 and 0.0625 cells each, so
    // whole-cell shifts per step alone (or a cross-fade between steps) would be off by up to
    // half a cell.
    AutomatonDesc a;
    a.res = ivec3(96, 8, 48);
    a.bounds = Box{vec3(0.0f), vec3(96.0f, 8.0f, 48.0f)};
    a.seed = 3;
    a.ellipsoids = 1;
    a.minEllipsoids = 0;
    a.maxEllipsoids = 1;
    a.targetCover = 0.0f;
    a.coverTolerance = 0.0f;
    a.adaptPeriod = 1;
    a.sizeMean = 10.0f;
    a.sizeVar = 0.0f;
    a.lifeMean = 100.0f;
    a.lifeVar = 0.0f;
    a.regionMargin = 0.0f;
    a.shrinkTime = 2.0f;
    a.pExt = 0.0f;
    a.pHum = 0.5f;
    a.pAct = 0.2f;
    a.warmup = 4.0f;
    const vec3 wind(6.0f, 0.0f, 1.5f);
    a.wind = {AutomatonWindRow{0.0f, wind}};
    AutomatonSequence seq(a);
    ASSERT_TRUE(seq.frameAt(0.0f) != nullptr);
    const Moments m0 = momentsOf(seq.frameAt(0.0f)->density);
    ASSERT_GT(m0.mass, 50.0) << "the ellipsoid grew no cloud: mass " << m0.mass;
    double worst = 0.0, worstMass = 0.0;
    for (int frame = 1; frame <= 48; ++frame) {
        const float t = float(frame) / 24.0f;
        const Moments m = momentsOf(seq.frameAt(t)->density);
        const double ex = m.x - m0.x - double(wind.x) * t, ez = m.z - m0.z - double(wind.z) * t;
        worst = std::max(worst, std::max(std::abs(ex), std::abs(ez)));
        worstMass = std::max(worstMass, std::abs(m.mass / m0.mass - 1.0));
    }
    RecordProperty("worst_centre_error_cells", std::to_string(worst));
    RecordProperty("worst_relative_mass_change", std::to_string(worstMass));
    // the cloud is frozen and stays inside the grid: whole-cell shifts are exact and the
    // MacCormack step moves the first moment exactly but for its limiter's clamps (measured:
    // see docs/automaton.md); 0.05 cells is a fifth of one frame's motion
    EXPECT_LT(worst, 0.05);
    EXPECT_LT(worstMass, 0.01);
}

TEST(AutomatonField, SceneRendersWithoutNaNAndShowsCloud) {
    SceneDesc s = automatonScene(32, 18);
    s.sun.direction = glm::normalize(vec3(0.5f, 0.35f, 0.8f));
    RenderStats st;
    const Framebuffer fb = renderScene(s, &st, AovSet{true, false}, 12); // finite, no NaN
    EXPECT_EQ(st.nonFinite, 0u);
    int cloudy = 0;
    for (size_t i = 0; i < fb.transmittance.size(); i += 3) cloudy += fb.transmittance[i] < 0.5f;
    EXPECT_GT(cloudy, 10) << "the camera should see cloud";
}

TEST(AutomatonField, WhiteFurnaceReturnsTheSky) {
    SceneDesc s = whiteFurnace(automatonScene(3, 2), vec3(1.0f));
    s.render.integrator = Integrator::PathTrace;
    s.camera = cameraLookingAt(vec3(0.0f, 3.0f, -30.0f), vec3(0.0f, 3.0f, 0.0f), 3, 2, 20.0f);
    s.medium.sigma_s = vec3(3.0f);
    s.render.spp = 512;
    s.render.maxDepth = 100000;
    // 16 seeds against the exact sky radiance 1, 3x2 pixels x 3 channels, alpha 0.01
    const Estimate render = renderSeeds(s, 16);
    EXPECT_TRUE(zTestPasses(render, exactValues(std::vector<double>(18, 1.0)), 0.01));
    const Framebuffer T = renderScene(s, nullptr, AovSet{true, false});
    int cloudy = 0;
    for (int i = 0; i < 6; ++i) cloudy += T.transmittance[3 * i] < 0.9f;
    EXPECT_GT(cloudy, 0) << "the furnace must look through cloud";
}

TEST(AutomatonField, PlanBuildsTheSimulationOnlyForTheAutomaton) {
    const SceneDesc s = automatonScene();
    const FramePlan p = planFrame(s, 24);
    EXPECT_TRUE(p.automaton);
    EXPECT_EQ(p.automatonRes, ivec3(48, 8, 48));
    // warm-up 3 s + 1 s at 24 fps, steps of 0.1 s: steps 0 to 41
    EXPECT_EQ(p.automatonSteps, 41u);
    EXPECT_NE(p.explain().find("automaton: 48 x 8 x 48 cells"), std::string::npos) << p.explain();
    SceneDesc c = s;
    c.field = cumulusField(Box{vec3(-5.0f), vec3(5.0f)}, 1, 1);
    EXPECT_FALSE(planFrame(c, 24).automaton);
    EXPECT_EQ(planFrame(c, 24).explain().find("automaton"), std::string::npos);
    EXPECT_TRUE(p.warnings.empty());
    SceneDesc slow = s;
    slow.field.automaton.warmup = 3600.0f;
    slow.field.automaton.simStep = 0.01f;
    const FramePlan ps = planFrame(slow, 1);
    ASSERT_EQ(ps.warnings.size(), 1u);
    EXPECT_NE(ps.warnings[0].find("re-simulates 360005 steps"), std::string::npos)
        << ps.warnings[0];
    SceneDesc big = s;
    big.field.automaton.res = ivec3(1024, 64, 1024);
    EXPECT_NE(planFrame(big, 1).refusal.find("the limit is 16777216"), std::string::npos)
        << planFrame(big, 1).refusal;
}
