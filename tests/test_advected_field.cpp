/// @file test_advected_field.cpp
/// @brief [field.advect] (core/fields/advected_field.h): a field carried by a wind. A box under a
///        uniform wind moves by wind x t; a layered wind shears it; no new extrema at CFL 1, 10
///        and 50; a frame rendered alone equals the same frame of a sequence bit for bit (also
///        backwards); the majorant bounds the density; the scene keys and their errors; the
///        plan says what it simulates.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/fields/field.h"
#include "core/plan.h"
#include "core/render.h"
#include "plugin/host/session.h"
#include "plugin/io/scene_file.h"

#include <filesystem>

using namespace nimbus;
using nimbus::io::parseSceneText;

namespace {

/// A unit-density box 2 x 2 x 2 at the origin, carried by `wind` (uniform) over a domain
/// from x = -2 to 14 in cells of 0.25.
FieldDesc boxInWind(vec3 wind, float step = 0.0f) {
    FieldDesc f;
    f.kind = FieldKind::Homogeneous;
    f.homogeneous.box = Box{vec3(-1.0f), vec3(1.0f)};
    f.homogeneous.density = 1.0f;
    f.advect.enabled = true;
    f.advect.wind = AdvectWind::Uniform;
    f.advect.uniform = wind;
    f.advect.voxel = 0.25f;
    f.advect.hasBounds = true;
    f.advect.bounds = Box{vec3(-2.0f, -2.0f, -2.0f), vec3(14.0f, 2.0f, 2.0f)};
    f.advect.step = step;
    return f;
}

/// The renderer's field of `frame` (a fresh renderer: the frame alone).
Field frameAlone(const SceneDesc& s, int frame) {
    Renderer r(s);
    return r.fieldFor(r.plan(frame));
}

SceneDesc sceneOf(const FieldDesc& f) {
    SceneDesc s;
    s.field = f;
    s.render.fps = 24.0f;
    return s;
}

/// Density-weighted centroid and mass of a field sampled at cell centres of `b` (cell h).
vec3 centroid(const Field& f, const Box& b, float h, double* mass = nullptr) {
    glm::dvec3 sum(0.0);
    double m = 0.0;
    for (float z = b.lo.z + h / 2; z < b.hi.z; z += h)
        for (float y = b.lo.y + h / 2; y < b.hi.y; y += h)
            for (float x = b.lo.x + h / 2; x < b.hi.x; x += h) {
                const double d = f.density(vec3(x, y, z));
                sum += d * glm::dvec3(x, y, z);
                m += d;
            }
    if (mass) *mass = m * double(h) * h * h;
    return vec3(sum / m);
}

} // namespace

TEST(AdvectedField, AUniformWindMovesTheBoxByWindTimesTime) {
    for (bool maccormack : {false, true}) {
        FieldDesc fd = boxInWind(vec3(4.0f, 0.0f, 0.0f));
        fd.advect.maccormack = maccormack;
        const SceneDesc s = sceneOf(fd);
        const Field f0 = frameAlone(s, 0);
        const Field f48 = frameAlone(s, 48); // t = 2 s: 8 units, 0.67 cells a step
        EXPECT_EQ(f48.kind, FieldKind::Advected);
        const Box dom = s.field.advect.bounds;
        double m0 = 0.0, m48 = 0.0;
        const vec3 c0 = centroid(f0, dom, 0.125f, &m0);
        const vec3 c48 = centroid(f48, dom, 0.125f, &m48);
        std::printf("%s: centroid moved %.4f (wind x t = 8), mass ratio %.4f\n",
                    maccormack ? "MacCormack" : "semi-Lagrangian", c48.x - c0.x, m48 / m0);
        EXPECT_NEAR(c0.x, 0.0f, 0.07f);
        // semi-Lagrangian steps under a uniform wind are convolutions with a linear kernel
        // whose mean is the exact shift: the centroid moves exactly (up to the domain's edge
        // and rounding); MacCormack's limiter lifts the undershoots of its trailing edge, which
        // adds mass behind the box and holds the centroid back by less than a cell
        EXPECT_NEAR(c48.x - c0.x, 8.0f, maccormack ? 0.25f : 0.01f);
        EXPECT_NEAR(c48.y, c0.y, 1e-3f);
        EXPECT_NEAR(c48.z, c0.z, 1e-3f);
        EXPECT_NEAR(m48 / m0, 1.0, maccormack ? 0.05 : 1e-4);
        EXPECT_TRUE(f48.motion.moving);
        EXPECT_EQ(f48.motion.velocity.uniform, vec3(4.0f, 0.0f, 0.0f));
    }
}

TEST(AdvectedField, ALayeredWindShearsTheBox) {
    FieldDesc fd = boxInWind(vec3(0.0f));
    fd.advect.wind = AdvectWind::Layered;
    fd.advect.layers = {AutomatonWindRow{-1.0f, vec3(2.0f, 0.0f, 0.0f)},
                        AutomatonWindRow{1.0f, vec3(6.0f, 0.0f, 0.0f)}};
    const SceneDesc s = sceneOf(fd);
    const Field f = frameAlone(s, 24); // t = 1 s
    const Box dom = fd.advect.bounds;
    // bottom slab (y in [-1, -0.5]) and top slab (y in [0.5, 1]): winds about 2.5 and 5.5
    const vec3 lo =
        centroid(f, Box{vec3(dom.lo.x, -1.0f, -1.0f), vec3(dom.hi.x, -0.5f, 1.0f)}, 0.125f);
    const vec3 hi =
        centroid(f, Box{vec3(dom.lo.x, 0.5f, -1.0f), vec3(dom.hi.x, 1.0f, 1.0f)}, 0.125f);
    EXPECT_NEAR(lo.x, 2.5f, 0.15f);
    EXPECT_NEAR(hi.x, 5.5f, 0.15f);
}

TEST(AdvectedField, NoNewExtremaAtCfl1And10And50) {
    for (float cfl : {1.0f, 10.0f, 50.0f}) {
        // 0.25-unit cells, steps of 1/24 s: CFL = speed / 6
        FieldDesc fd = boxInWind(vec3(0.0f));
        fd.homogeneous.density = 3.0f;
        fd.advect.wind = AdvectWind::Layered; // shear, so cells are not moved by whole cells
        fd.advect.layers = {AutomatonWindRow{-1.0f, vec3(cfl * 6.0f * 0.3f, 0.0f, 0.0f)},
                            AutomatonWindRow{1.0f, vec3(cfl * 6.0f, 0.0f, cfl * 0.7f)}};
        fd.advect.bounds = Box{vec3(-2.0f), vec3(2.0f)};
        fd.advect.hasBounds = true;
        SceneDesc s = sceneOf(fd);
        Renderer r(s);
        for (int frame = 1; frame <= 12; ++frame) {
            const Field f = r.fieldFor(r.plan(frame));
            const auto& v = f.as<AdvectedField>().grid.frame->density.v;
            const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
            ASSERT_GE(*mn, 0.0f) << "CFL " << cfl << " frame " << frame;
            ASSERT_LE(*mx, 3.0f) << "CFL " << cfl << " frame " << frame;
            for (float x : v) ASSERT_TRUE(std::isfinite(x));
        }
    }
}

TEST(AdvectedField, AFrameAloneEqualsTheSameFrameOfASequenceBitForBit) {
    FieldDesc fd = boxInWind(vec3(3.0f, 0.5f, -0.25f), 0.03f); // steps do not fall on frames
    fd.advect.checkpointEvery = 10;
    const SceneDesc s = sceneOf(fd);
    const Field alone = frameAlone(s, 37);
    Renderer seq(s);
    for (int frame = 30; frame <= 37; ++frame) seq.fieldFor(seq.plan(frame));
    const Field inSeq = seq.fieldFor(seq.plan(37));
    // backwards: from the checkpoint before frame 20 (the state is not only kept forward)
    const Field back = seq.fieldFor(seq.plan(20));
    const Field back37 = seq.fieldFor(seq.plan(37));
    const Field alone20 = frameAlone(s, 20);
    const auto& a = alone.as<AdvectedField>().grid.frame->density.v;
    EXPECT_EQ(a, inSeq.as<AdvectedField>().grid.frame->density.v);
    EXPECT_EQ(a, back37.as<AdvectedField>().grid.frame->density.v);
    EXPECT_EQ(alone20.as<AdvectedField>().grid.frame->density.v,
              back.as<AdvectedField>().grid.frame->density.v);
    EXPECT_NE(a, alone20.as<AdvectedField>().grid.frame->density.v);
}

namespace {

/// A velocity grid over boxInWind's domain (cells of 1 unit) blowing `wind` everywhere.
std::shared_ptr<const sim::VelocityGrid> windGrid(vec3 wind, int nz = 6) {
    auto g = std::make_shared<sim::VelocityGrid>();
    g->res = ivec3(18, 6, nz);
    g->frame = sim::GridFrame{vec3(-3.0f), 1.0f};
    g->v.assign(size_t(g->res.x) * g->res.y * g->res.z, wind);
    return g;
}

/// The frame's grid and block maxima, from their capacities.
double frameBytes(const Field& f) {
    const auto& fr = *f.as<AdvectedField>().grid.frame;
    return double(fr.density.v.capacity() + fr.maxima.v.capacity()) * sizeof(float);
}

} // namespace

TEST(AdvectedField, ThePlansMemoryIsWhatTheSimulationHolds) {
    struct Case {
        std::string what;
        FieldDesc field;
        std::shared_ptr<const sim::VelocityGrid> grid;
        bool staggered = false;
        int frame = 37;
        bool ringGrows = false; ///< a vertical wind crossing more slabs than the ring starts with
    };
    std::vector<Case> cases;
    auto add = [&](std::string what, vec3 wind, bool mac, int frame = 37) {
        FieldDesc f = boxInWind(wind, 0.03f); // steps do not fall on frames: a partial one
        f.advect.checkpointEvery = 10;
        f.advect.maccormack = mac;
        cases.push_back({what, f, nullptr, false, frame});
        return &cases.back();
    };
    add("uniform, MacCormack (row kernel)", vec3(3.0f, 0.0f, -0.25f), true);
    add("uniform, semi-Lagrangian", vec3(3.0f, 0.0f, -0.25f), false);
    add("uniform with a vertical component, MacCormack (per cell: the limiter's range grids)",
        vec3(3.0f, 0.5f, -0.25f), true);
    add("frame 0: no step", vec3(3.0f, 0.0f, 0.0f), true, 0);
    add("frame 1: one partial step", vec3(3.0f, 0.0f, 0.0f), true, 1);
    Case* layered = add("layered, vertical wind, MacCormack", vec3(0.0f), true);
    layered->field.advect.wind = AdvectWind::Layered;
    layered->field.advect.layers = {AutomatonWindRow{-1.0f, vec3(2.0f, 0.0f, 0.0f)},
                                    AutomatonWindRow{1.0f, vec3(6.0f, 0.3f, 0.0f)}};
    for (bool staggered : {false, true})
        for (bool mac : {true, false}) {
            Case* c = add(staggered ? "staggered velocity grid, " : "centred velocity grid, ",
                          vec3(0.0f), mac);
            c->what += mac ? "MacCormack" : "semi-Lagrangian";
            c->field.advect.wind = AdvectWind::Grid;
            c->field.advect.velocityPath = "wind.vdb";
            c->grid = windGrid(vec3(3.0f, 0.0f, 0.1f));
            c->staggered = staggered;
        }
    // a vertical wind of 36 cells a step in a domain of 128 z slabs: the ring starts with 66
    // (twice the 32 slabs of a chunk, and 2) and grows to all of them
    Case* fast = add("centred velocity grid, fast vertical wind", vec3(0.0f), true, 3);
    fast->field.advect.wind = AdvectWind::Grid;
    fast->field.advect.velocityPath = "wind.vdb";
    fast->field.advect.bounds.hi.z = 30.0f;
    fast->grid = windGrid(vec3(0.0f, 0.0f, 300.0f), 34);
    fast->ringGrows = true;

    for (const Case& c : cases) {
        SCOPED_TRACE(c.what);
        const SceneDesc s = sceneOf(c.field);
        FrameBindings b;
        b.velocity = c.grid;
        b.velocityStaggered = c.staggered;
        // the frame alone, and the same frame after the frames before it
        for (int first : {c.frame, std::max(0, c.frame - 8)}) {
            Renderer r(s);
            Field f;
            for (int frame = first; frame <= c.frame; ++frame) f = r.fieldFor(r.plan(frame, b), b);
            const FramePlan p = r.plan(c.frame, b);
            ASSERT_TRUE(p.refusal.empty()) << p.refusal;
            const AdvectMemory& want = p.advectMemory;
            const AdvectMemory held = r.advectMemory();
            EXPECT_EQ(held.state, want.state);
            EXPECT_EQ(held.checkpointCount, want.checkpointCount);
            EXPECT_EQ(held.checkpoints, want.checkpoints);
            EXPECT_EQ(frameBytes(f), want.frame);
            EXPECT_EQ(held.step.grids, want.step.grids);
            EXPECT_EQ(held.step.rows, want.step.rows);
            EXPECT_EQ(held.velocity, want.velocity);
            if (c.ringGrows) {
                EXPECT_GT(held.step.ring, want.step.ring);
                EXPECT_LE(held.step.ring, want.step.ringMost);
                EXPECT_NE(p.explain().find("more where a vertical wind crosses many cells"),
                          std::string::npos);
            } else {
                EXPECT_EQ(held.step.ring, want.step.ring);
            }
            const double total = held.total() - held.frame + frameBytes(f);
            std::printf("%-80s frame %2d from %2d: planned %7.3f MB, held %7.3f MB\n",
                        c.what.c_str(), c.frame, first, want.total() / 1048576.0,
                        total / 1048576.0);
        }
    }
}

TEST(AdvectedField, TheMajorantBoundsTheDensity) {
    FieldDesc fd = boxInWind(vec3(0.0f));
    fd.kind = FieldKind::Cumulus;
    fd.cumulus.bounds = Box{vec3(-6.0f, 1.5f, -6.0f), vec3(6.0f, 4.0f, 6.0f)};
    fd.advect.hasBounds = false;
    fd.advect.voxel = 0.2f;
    fd.advect.wind = AdvectWind::Layered;
    fd.advect.layers = {AutomatonWindRow{1.5f, vec3(1.0f, 0.0f, 0.0f)},
                        AutomatonWindRow{4.0f, vec3(5.0f, 0.2f, 1.0f)}};
    fd.advect.until = 2.0f;
    const SceneDesc s = sceneOf(fd);
    const Field f = frameAlone(s, 30);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const Box b = f.bounds();
    int checked = 0;
    for (int i = 0; i < 20000; ++i) {
        const vec3 p = b.lo + vec3(u(rng), u(rng), u(rng)) * b.extent();
        const vec3 half = vec3(0.05f + 0.5f * u(rng));
        const Box cell{p - half, p + half};
        const float m = f.majorant(cell);
        for (int k = 0; k < 4; ++k) {
            const vec3 q = cell.lo + vec3(u(rng), u(rng), u(rng)) * cell.extent();
            const float d = f.density(q);
            ASSERT_LE(d, m) << "at (" << q.x << ", " << q.y << ", " << q.z << ")";
            checked += d > 0.0f;
        }
    }
    EXPECT_GT(checked, 1000); // the cloud was hit
}

TEST(AdvectedField, TheDefaultDomainHoldsTheSourceCarriedUntilTheLastFrame) {
    const char* text = R"(frames = "1-48"
[field]
kind = "homogeneous"
bounds_min = [-1, -1, -1]
bounds_max = [1, 1, 1]
[field.advect]
wind = [2, 0, -1]
)";
    const SceneDesc s = parseSceneText(text, "test.toml").scene;
    ASSERT_TRUE(s.field.advect.enabled);
    EXPECT_EQ(s.field.advect.wind, AdvectWind::Uniform);
    EXPECT_FLOAT_EQ(s.field.advect.until, 2.0f);
    const FramePlan p = planFrame(s, 48);
    ASSERT_TRUE(p.advected);
    ASSERT_TRUE(p.refusal.empty()) << p.refusal;
    // x from -1 to 1 + 2 x 2 = 5, z from -1 - 2 = -3 to 1; 128 cells along the longest side
    EXPECT_NEAR(p.advectBounds.lo.x, -1.0f, 1e-4f);
    EXPECT_GE(p.advectBounds.hi.x, 5.0f - 1e-4f);
    EXPECT_LE(p.advectBounds.lo.z, -3.0f + 1e-4f);
    EXPECT_EQ(p.advectRes.x, 128);
    EXPECT_EQ(p.advectSteps, 48u);
    EXPECT_NE(p.explain().find("advection: MacCormack, uniform wind (2, 0, -1)"), std::string::npos)
        << p.explain();
    // the box is still whole at the last frame
    Renderer r(s);
    double m0 = 0.0, m48 = 0.0;
    centroid(r.fieldFor(r.plan(0)), p.advectBounds, 0.05f, &m0);
    centroid(r.fieldFor(r.plan(48)), p.advectBounds, 0.05f, &m48);
    EXPECT_NEAR(m48 / m0, 1.0, 0.03);
}

TEST(AdvectedField, AnExplicitVoxelPastTheCellLimitIsRefusedWithTheVoxelThatFits) {
    FieldDesc fd = boxInWind(vec3(1.0f, 0.0f, 0.0f));
    fd.advect.voxel = 0.001f;
    const FramePlan p = planFrame(sceneOf(fd), 1);
    EXPECT_NE(p.refusal.find("field.advect.voxel = 0.001"), std::string::npos) << p.refusal;
    EXPECT_NE(p.refusal.find("the limit is 16777216"), std::string::npos) << p.refusal;
    // the default voxel is enlarged instead, and explain says so
    fd.advect.voxel = 0.0f;
    fd.advect.bounds = Box{vec3(-1000.0f), vec3(1000.0f, 1.0f, 1000.0f)};
    fd.homogeneous.box = Box{vec3(-1000.0f), vec3(1000.0f, 1.0f, 1000.0f)};
    const FramePlan q = planFrame(sceneOf(fd), 1);
    EXPECT_TRUE(q.refusal.empty()) << q.refusal;
    EXPECT_LE(double(q.advectRes.x) * q.advectRes.y * q.advectRes.z, kMaxAdvectCells);
}

TEST(AdvectedField, PlansWithoutAdvectionHaveNone) {
    FieldDesc fd = boxInWind(vec3(1.0f, 0.0f, 0.0f));
    fd.advect.enabled = false;
    const FramePlan p = planFrame(sceneOf(fd), 5);
    EXPECT_FALSE(p.advected);
    EXPECT_EQ(p.explain().find("advection"), std::string::npos);
    EXPECT_EQ(frameAlone(sceneOf(fd), 5).kind, FieldKind::Homogeneous);
}

TEST(SceneAdvect, KeysParseIntoTheDescription) {
    const char* text = R"(frames = "1-10"
[field]
kind = "cumulus"
[field.advect]
voxel = 0.5
step = 0.1
scheme = "semi_lagrangian"
bounds_min = [-30, 0, -30]
bounds_max = [30, 6, 30]
checkpoint_every = 7
[[field.wind_layer]]
altitude = 1.0
wind = [1, 0, 0]
[[field.wind_layer]]
altitude = 5.0
wind = [4, 0.5, 2]
)";
    const AdvectDesc a = parseSceneText(text, "test.toml").scene.field.advect;
    EXPECT_TRUE(a.enabled);
    EXPECT_EQ(a.wind, AdvectWind::Layered);
    ASSERT_EQ(a.layers.size(), 2u);
    EXPECT_EQ(a.layers[1].wind, vec3(4.0f, 0.5f, 2.0f));
    EXPECT_FLOAT_EQ(a.voxel, 0.5f);
    EXPECT_FLOAT_EQ(a.step, 0.1f);
    EXPECT_FALSE(a.maccormack);
    EXPECT_TRUE(a.hasBounds);
    EXPECT_EQ(a.bounds.hi, vec3(30.0f, 6.0f, 30.0f));
    EXPECT_EQ(a.checkpointEvery, 7);

    const char* grid = R"([field]
kind = "vdb"
path = "smoke.vdb"
[field.advect]
velocity = "vel.####.vdb"
velocity_layout = "staggered"
velocity_scale = 0.5
)";
    const AdvectDesc g = parseSceneText(grid, "test.toml").scene.field.advect;
    EXPECT_EQ(g.wind, AdvectWind::Grid);
    EXPECT_EQ(g.velocityPath, "vel.####.vdb");
    EXPECT_EQ(g.velocityGrid, "velocity");
    EXPECT_EQ(g.layout, VelocityLayout::Staggered);
    EXPECT_FLOAT_EQ(g.velocityScale, 0.5f);
}

TEST(SceneAdvect, MistakesAreReportedWithTheirLine) {
    auto error = [](const std::string& text) {
        try {
            parseSceneText(text, "test.toml");
        } catch (const std::exception& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    };
    const std::string head = "[field]\nkind = \"cumulus\"\n";
    EXPECT_NE(error(head + "[field.advect]\nwind = [1, 0, 0]\nvelocity = \"v.vdb\"\n")
                  .find("takes one wind"),
              std::string::npos);
    EXPECT_NE(error(head + "[field.advect]\nbounds_min = [0, 0, 0]\n")
                  .find("field.advect.bounds_min needs field.advect.bounds_max"),
              std::string::npos);
    EXPECT_NE(error(head + "[field.advect]\nbounds_min = [0, 0, 0]\nbounds_max = [1, 0, 1]\n")
                  .find("must be below field.advect.bounds_max"),
              std::string::npos);
    const std::string rows = "[[field.wind_layer]]\naltitude = 3\nwind = [1, 0, 0]\n"
                             "[[field.wind_layer]]\naltitude = 2\nwind = [1, 0, 0]\n";
    const std::string unsorted = error(head + "[field.advect]\n" + rows);
    EXPECT_NE(unsorted.find("test.toml:8"), std::string::npos) << unsorted;
    EXPECT_NE(unsorted.find("field.wind_layer[1].altitude 2 is not above"), std::string::npos)
        << unsorted;
    EXPECT_NE(error(head + rows).find("add a [field.advect] table"), std::string::npos);
    EXPECT_NE(error(head + "[field.advect]\nvoxel = 0\n").find("field.advect.voxel"),
              std::string::npos);
    EXPECT_NE(error(head + "[field.advect]\nschem = \"x\"\n").find("did you mean"),
              std::string::npos);
    // the automaton moves with its own wind
    EXPECT_NE(error("[field]\nkind = \"automaton\"\n[field.advect]\nwind = [1, 0, 0]\n")
                  .find("field.advect"),
              std::string::npos);
}

TEST(AdvectedVdb, MantaflowDensityMovesWithItsOwnStaggeredVelocity) {
    const std::string path =
        std::string(NIMBUS_SHARED_VDB_DIR) + "/blender_mantaflow_fluid_data_0001.vdb";
    if (!std::filesystem::exists(path))
        GTEST_SKIP() << "the shared VDB test files are not here (" << path
                     << " is absent): the Mantaflow advection test is skipped";
    const std::string text = "frames = \"0-24\"\n[field]\nkind = \"vdb\"\npath = \"" + path +
                             "\"\n[field.advect]\nvelocity = \"" + path + "\"\n";
    host::Session s;
    ASSERT_TRUE(s.loadString(text, "manta.toml").ok());
    // --explain plans before reading: the velocity is not read yet, which is no refusal
    const FramePlan unread = s.plan(3);
    EXPECT_TRUE(unread.refusal.empty()) << unread.refusal;
    EXPECT_NE(unread.explain().find("velocity grid \"velocity\" of " + path), std::string::npos)
        << unread.explain();
    EXPECT_NE(unread.explain().find("VDB grids are read when the frame is rendered"),
              std::string::npos);
    ASSERT_TRUE(s.bind(0).ok());
    ASSERT_TRUE(s.bindings().velocity);
    EXPECT_TRUE(s.bindings().velocityStaggered); // the grid class says (velocity_layout "auto")
    Renderer& r = s.renderer();
    const FramePlan p0 = s.plan(0);
    const Field f0 = r.fieldFor(p0, s.bindings());
    // a quarter second: Mantaflow stores velocities only where its fluid was (0 elsewhere in the
    // grid's box), so over longer times the cloud slows down as it leaves them
    ASSERT_TRUE(s.bind(6).ok());
    const FramePlan p24 = s.plan(6);
    ASSERT_TRUE(p24.refusal.empty()) << p24.refusal;
    EXPECT_NE(p24.explain().find("velocity grid \"velocity\" (staggered)"), std::string::npos)
        << p24.explain();
    const Field f24 = r.fieldFor(p24, s.bindings());
    // the density-weighted mean velocity of the source moves its centroid (first order, 1 s)
    const Box dom = p24.advectBounds;
    const float h = p24.advectVoxel;
    glm::dvec3 vSum(0.0);
    double m = 0.0;
    for (float z = dom.lo.z + h / 2; z < dom.hi.z; z += h)
        for (float y = dom.lo.y + h / 2; y < dom.hi.y; y += h)
            for (float x = dom.lo.x + h / 2; x < dom.hi.x; x += h) {
                const double d = f0.density(vec3(x, y, z));
                vSum += d * glm::dvec3(sim::velocityAt(f24.motion.velocity, vec3(x, y, z)));
                m += d;
            }
    const vec3 vMean = vec3(vSum / m);
    const vec3 moved = centroid(f24, dom, h) - centroid(f0, dom, h);
    const vec3 want = vMean * 0.25f;
    std::printf("Mantaflow: mean velocity (%.3f, %.3f, %.3f) x 0.25 s = (%.3f, %.3f, %.3f); "
                "centroid moved (%.3f, %.3f, %.3f)\n",
                vMean.x, vMean.y, vMean.z, want.x, want.y, want.z, moved.x, moved.y, moved.z);
    ASSERT_GT(glm::length(vMean), 0.05f);
    // along the mean velocity, and not faster. Mantaflow stores velocity only where its fluid
    // was; the reader extrapolates it into the box's other voxels (velocity_extrapolate, on by
    // default). Measured 0.180 of 0.256 (with velocity_extrapolate = false, 0.102 of 0.198: the
    // front stalled in the still voxels); the rest is the field changing along the way.
    EXPECT_GT(glm::dot(glm::normalize(moved), glm::normalize(want)), 0.98f);
    EXPECT_GT(glm::length(moved), 0.6f * glm::length(want));
    EXPECT_LT(glm::length(moved), 1.05f * glm::length(want));
    // the next frame binds the same file read again (another grid in memory): the sequence
    // goes on with one step instead of seven from time 0
    ASSERT_TRUE(s.bind(7).ok());
    RenderStats st;
    r.volumesFor(s.plan(7), s.bindings(), st);
    EXPECT_EQ(st.advectSteps, 1u);
}

TEST(AdvectedVdb, EachFrameOfASequenceIsItsOwnGridCarriedToItsTime) {
    const std::string dir = std::string(NIMBUS_SHARED_VDB_DIR);
    if (!std::filesystem::exists(dir + "/usd_smoke_000003.vdb"))
        GTEST_SKIP() << "the shared VDB test files are not here (" << dir
                     << " is absent): the VDB sequence advection test is skipped";
    // frames 2 and 3 of a Blender smoke simulation, carried by a uniform wind of 0.5 units/s
    const std::string text = "frames = \"2-3\"\n[field]\nkind = \"vdb\"\npath = \"" + dir +
                             "/usd_smoke_######.vdb\"\n[field.advect]\nwind = [0.5, 0, 0]\n"
                             "scheme = \"semi_lagrangian\"\n";
    host::Session s;
    ASSERT_TRUE(s.loadString(text, "seq.toml").ok());
    Renderer& r = s.renderer();
    for (int frame : {2, 3}) {
        ASSERT_TRUE(s.bind(frame).ok());
        const FramePlan p = s.plan(frame);
        ASSERT_TRUE(p.refusal.empty()) << p.refusal;
        RenderStats st;
        const VolumeSet vs = r.volumesFor(p, s.bindings(), st);
        // the frame's own grid as read, and the same grid carried to t = frame / 24
        FieldDesc still = s.file().scene.field;
        still.advect.enabled = false;
        const Field source = makeField(still, 0.0f, s.bindings().grid(0));
        const Box dom = p.advectBounds;
        const float h = p.advectVoxel;
        const vec3 moved = centroid(vs.fields[0], dom, h) - centroid(source, dom, h);
        const float want = 0.5f * float(frame) / 24.0f;
        std::printf("frame %d: %llu steps, centroid moved (%.4f, %.4f, %.4f), wind x t = %.4f\n",
                    frame, (unsigned long long)st.advectSteps, moved.x, moved.y, moved.z, want);
        EXPECT_EQ(st.advectSteps, std::uint64_t(frame)); // a new source: from time 0
        EXPECT_NEAR(moved.x, want, 0.02f * want + 1e-4f);
        EXPECT_NEAR(moved.y, 0.0f, 1e-3f);
        EXPECT_NEAR(moved.z, 0.0f, 1e-3f);
    }
}
