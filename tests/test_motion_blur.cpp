// Motion blur (issue 13 item 3, docs/motion_blur.md): a closed shutter changes nothing, bit
// for bit; a moving slab's blurred transmittance is the closed-form average over the shutter;
// the majorants bound every density the shutter can show; a layered wind shears exactly; the
// plan leaves the blur out when the shutter is closed or nothing moves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/plan.h"
#include "core/render.h"
#include "core/sampler.h"
#include "core/tracking/motion_blur.h"
#include "core/tracking/tracking.h"
#include "core/tracking/volumes.h"
#include "plugin/io/scene/reader.h"
#include "render_util.h"

using namespace nimbus;

namespace {

/// A VolumeSet of one field, untransformed, its majorant grid built over the shutter.
VolumeSet oneVolume(Field f, const Shutter& shutter, float cell) {
    VolumeSet vs;
    vs.fields.push_back(std::move(f));
    vs.instances = makeInstances(vs.fields, {});
    setShutter(vs, shutter);
    vs.bounds = vs.instances.at(0).worldBounds;
    vs.grids.push_back(buildMajorantGrid(vs.fields[0], cell, 0.05f, nullptr, shutter));
    vs.useGrid.assign(1, 1);
    vs.wholeMajorant.push_back(sweptMajorant(vs.fields[0], vs.boundsOf(0), shutter));
    return vs;
}

FieldMotion uniformMotion(vec3 v) {
    FieldMotion m;
    m.velocity = sim::uniformWind(v);
    m.moving = true;
    return m;
}

/// The length of [a0, a1] inside [b0, b1].
double overlap(double a0, double a1, double b0, double b1) {
    return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
}

/// A small cumulus scene whose field drifts with a wind, at frame 0 (t = 0: the wind has not
/// moved the noise yet, so a still field gives the same frame).
SceneDesc windyScene(vec3 wind) {
    SceneDesc s = smallCumulusLayer();
    s.field.cumulus.wind = wind;
    s.render.pixelSamples = 4;
    return s;
}

} // namespace

TEST(MotionBlur, AClosedShutterChangesNothingBitForBit) {
    for (const bool pathtrace : {false, true}) {
        SceneDesc still = windyScene(vec3(0.0f));
        if (pathtrace) {
            still.render.integrator = Integrator::PathTrace;
            still.render.spp = 4;
        }
        const Framebuffer ref = renderScene(still, nullptr, {}, 0);
        SceneDesc moving = still;
        moving.field.cumulus.wind = vec3(3.0f, 0.0f, 1.0f);
        for (const float at : {0.0f, 0.5f, -2.0f}) {
            SceneDesc closed = moving;
            closed.render.shutterOpen = closed.render.shutterClose = at;
            EXPECT_FALSE(Renderer(closed).plan(0, {}, {}).motionBlur);
            const Framebuffer img = renderScene(closed, nullptr, {}, 0);
            EXPECT_EQ(img.rgba, ref.rgba) << (pathtrace ? "pathtrace" : "march") << " at " << at;
        }
        // the same scene with the shutter open does blur (the comparison can tell)
        SceneDesc open = moving;
        open.render.shutterOpen = -0.5f;
        open.render.shutterClose = 0.5f;
        EXPECT_TRUE(Renderer(open).plan(0, {}, {}).motionBlur);
        EXPECT_NE(renderScene(open, nullptr, {}, 0).rgba, ref.rgba);
    }
}

TEST(MotionBlur, AClosedShutterKeyParsesToTheSameImageAsNoKey) {
    const std::string base = "[camera]\nwidth = 24\nheight = 16\nposition = [0, 2.5, -9]\n"
                             "look_at = [0, 2.8, 0]\n[field]\nkind = \"cumulus\"\n"
                             "bounds_min = [-6, 1.5, -6]\nbounds_max = [6, 4, 6]\n"
                             "wind = [2, 0, 1]\nevaluation = \"direct\"\n[render]\nstep = 0.1\n"
                             "shadow_step = 0.1\npixel_samples = 2\n";
    const SceneDesc a = io::parseSceneText(base, "a.toml").scene;
    const SceneDesc b = io::parseSceneText(base + "shutter = [0.25, 0.25]\n", "b.toml").scene;
    EXPECT_EQ(b.render.shutterOpen, 0.25f);
    EXPECT_EQ(renderScene(a).rgba, renderScene(b).rgba);
}

TEST(MotionBlur, MovingSlabTransmittanceIsTheClosedFormTimeAverage) {
    // a slab 1 unit thick in x moving along +x at v; rays along z at x0 cross L = 2 units of it
    // while it covers x0: T averaged over the shutter = f exp(-sigma L) + (1 - f), f the share
    // of the shutter during which the slab covers x0
    const float sigma = 0.8f, v = 4.0f, L = 2.0f;
    const Shutter shutter{-0.25f, 0.25f};
    Field f = makeField(
        homogeneousField(Box{vec3(0.0f, -1.0f, -1.0f), vec3(1.0f, 1.0f, 1.0f)}, sigma), 0.0f);
    f.motion = uniformMotion(vec3(v, 0.0f, 0.0f));
    const VolumeSet vs = oneVolume(f, shutter, 0.1f);
    EXPECT_NEAR(vs.boundsOf(0).lo.x, -1.0f, 1e-5f); // swept: [0, 1] moved by v [-0.25, 0.25]
    EXPECT_NEAR(vs.boundsOf(0).hi.x, 2.0f, 1e-5f);
    RayVolumes rv;
    for (const double x0 : {-0.7, -0.2, 0.3, 0.5, 0.9, 1.4, 1.8}) {
        const double covered =
            overlap(shutter.t0, shutter.t1, (x0 - 1.0) / v, x0 / v) / (shutter.t1 - shutter.t0);
        const double exact = covered * std::exp(-double(sigma) * L) + (1.0 - covered);
        const Ray ray{vec3(float(x0), 0.1f, -3.0f), vec3(0.0f, 0.0f, 1.0f)};
        // deterministic: the optical depth integrated along the ray at each of many times
        const int times = 4000;
        double quad = 0.0;
        for (int i = 0; i < times; ++i) {
            const float dt = shutter.t0 + (float(i) + 0.5f) / times * (shutter.t1 - shutter.t0);
            rv.setTime(dt);
            double tau = 0.0;
            if (rv.begin(vs, ray, 0.0f, 10.0f)) {
                const int steps = 400;
                const float h = (rv.tOut() - rv.tIn()) / steps;
                for (int k = 0; k < steps; ++k) tau += rv.density(rv.tIn() + (k + 0.5f) * h) * h;
            }
            quad += std::exp(-tau) / times;
        }
        EXPECT_NEAR(quad, exact, 2.0 / times) << "x0 = " << x0;
        // stochastic: ratio tracking at uniformly drawn times (the tracking's majorants must
        // cover the slab wherever the shutter puts it), a Z-test on the mean
        const int n = 40000;
        double sum = 0.0, sum2 = 0.0;
        Sampler rng{0x9e3779b9u ^ std::uint32_t(x0 * 1000.0 + 5000.0), 0};
        for (int i = 0; i < n; ++i) {
            rv.setTime(shutter.t0 + rng.next() * (shutter.t1 - shutter.t0));
            double T = 1.0;
            if (rv.begin(vs, ray, 0.0f, 10.0f))
                sampleTmaj(rv, 1.0f, rng, [&](float t, const MajorantSegment&, float sigmaMaj) {
                    T *= 1.0 - double(rv.density(t)) / sigmaMaj;
                    return T > 0.0;
                });
            sum += T;
            sum2 += T * T;
        }
        const double mean = sum / n, var = std::max(sum2 / n - mean * mean, 1e-12);
        const double z = (mean - exact) / std::sqrt(var / n);
        EXPECT_LT(std::abs(z), 4.5) << "x0 = " << x0 << ": mean " << mean << ", exact " << exact;
    }
}

TEST(MotionBlur, MajorantsBoundTheDensityOverTheShutter) {
    // random (point, time) densities never exceed the bound of their majorant cell, nor the
    // whole-volume bound; outside the swept bounds there is no density. Uniform wind (a
    // cumulus), layered with a vertical part, and a centred velocity grid.
    FieldDesc d = cumulusField(Box{vec3(-3.0f, 1.0f, -3.0f), vec3(3.0f, 3.0f, 3.0f)}, 2, 1);
    d.cumulus.wind = vec3(3.0f, 0.0f, -2.0f);
    const Field cumulus = makeField(d, 0.4f);
    ASSERT_TRUE(cumulus.motion.moving);
    Field layered = cumulus;
    layered.motion.velocity = sim::layeredWind(
        {{1.5f, {-2.0f, 0.5f, 0.0f}}, {2.0f, {4.0f, -1.0f, 1.0f}}, {2.5f, {0.0f, 0.0f, 3.0f}}});
    auto grid = std::make_shared<sim::VelocityGrid>();
    grid->res = ivec3(4, 3, 4);
    grid->frame = sim::GridFrame{vec3(-3.0f, 1.0f, -3.0f), 1.5f};
    std::mt19937 gen(7);
    std::uniform_real_distribution<float> u(-3.0f, 3.0f);
    for (int i = 0; i < 48; ++i) grid->v.push_back(vec3(u(gen), 0.3f * u(gen), u(gen)));
    Field gridded = cumulus;
    gridded.motion.grid = grid;
    gridded.motion.velocity = sim::centredGrid(*grid);
    const Shutter shutter{-0.3f, 0.2f};
    struct Case {
        const char* name;
        const Field* f;
    };
    for (const Case& c :
         {Case{"uniform", &cumulus}, Case{"layered", &layered}, Case{"grid", &gridded}}) {
        const VolumeSet vs = oneVolume(*c.f, shutter, 0.25f);
        const MajorantGrid& g = vs.grids[0];
        const Box& sb = vs.boundsOf(0);
        EXPECT_EQ(g.bounds.lo, sb.lo);
        std::uniform_real_distribution<float> x(sb.lo.x - 1.0f, sb.hi.x + 1.0f),
            y(sb.lo.y - 0.5f, sb.hi.y + 0.5f), z(sb.lo.z - 1.0f, sb.hi.z + 1.0f),
            t(shutter.t0, shutter.t1);
        int inside = 0, dense = 0, over = 0, outside = 0;
        for (int i = 0; i < 100000; ++i) {
            const vec3 q(x(gen), y(gen), z(gen));
            const float dt = i % 8 == 0 ? (i % 16 ? shutter.t0 : shutter.t1) : t(gen);
            const float rho = densityAt(*c.f, q, dt);
            if (!sb.contains(q)) {
                outside += rho > 0.0f;
                continue;
            }
            ++inside;
            dense += rho > 0.0f;
            const ivec3 cell =
                glm::clamp(ivec3(glm::floor((q - g.bounds.lo) / g.cellSize)), ivec3(0), g.res - 1);
            over += rho > g.at(cell) || rho > vs.wholeMajorant[0];
        }
        EXPECT_GT(dense, 500) << c.name; // the test sees cloud
        EXPECT_EQ(over, 0) << c.name << ": densities above their cell's majorant of " << inside;
        EXPECT_EQ(outside, 0) << c.name << ": densities outside the swept bounds";
    }
}

TEST(MotionBlur, CoarseWorldGridOfATransformedInstanceBoundsTheShutter) {
    FieldDesc d = cumulusField(Box{vec3(-3.0f, 1.0f, -3.0f), vec3(3.0f, 3.0f, 3.0f)}, 2, 1);
    d.cumulus.wind = vec3(4.0f, 0.0f, 2.0f);
    VolumeSet vs;
    vs.fields.push_back(makeField(d, 0.0f));
    InstanceDesc in;
    in.translate = vec3(1.0f, 0.5f, -2.0f);
    in.rotate = vec3(0.0f, 35.0f, 0.0f);
    in.scale = vec3(1.5f);
    in.density = 1.3f;
    vs.instances = makeInstances(vs.fields, {in});
    const Shutter shutter{-0.25f, 0.25f};
    setShutter(vs, shutter);
    vs.bounds = vs.instances[0].worldBounds;
    const MajorantGrid g = buildCoarseMajorantGrid(vs, 0.4f);
    const VolumeInstance& inst = vs.instances[0];
    std::mt19937 gen(3);
    std::uniform_real_distribution<float> ux(0.0f, 1.0f), t(shutter.t0, shutter.t1);
    int over = 0, dense = 0;
    for (int i = 0; i < 40000; ++i) {
        const vec3 p = vs.bounds.lo + vec3(ux(gen), ux(gen), ux(gen)) * vs.bounds.extent();
        const vec3 q = vec3(inst.localFromWorld * vec4(p, 1.0f));
        const float rho = inst.density * densityAt(vs.fields[0], q, t(gen));
        dense += rho > 0.0f;
        const ivec3 cell =
            glm::clamp(ivec3(glm::floor((p - g.bounds.lo) / g.cellSize)), ivec3(0), g.res - 1);
        over += rho > g.at(cell);
    }
    EXPECT_GT(dense, 500);
    EXPECT_EQ(over, 0);
}

TEST(MotionBlur, LayeredWindShearsExactly) {
    // a box in a wind that grows with altitude (no vertical part): at dt it is the parallelogram
    // x - w(y) dt in [0, 1]; the blurred lookup matches it away from its faces
    Field f = makeField(homogeneousField(Box{vec3(0.0f), vec3(1.0f, 2.0f, 1.0f)}, 2.0f), 0.0f);
    f.motion.velocity = sim::layeredWind({{0.0f, {0.0f, 0.0f, 0.0f}}, {2.0f, {3.0f, 0.0f, 0.0f}}});
    f.motion.moving = true;
    std::mt19937 gen(11);
    std::uniform_real_distribution<float> x(-1.0f, 3.0f), y(0.0f, 2.0f), z(0.0f, 1.0f),
        t(-0.5f, 0.5f);
    int checked = 0, wrong = 0, in = 0;
    for (int i = 0; i < 50000; ++i) {
        const vec3 q(x(gen), y(gen), z(gen));
        const float dt = t(gen);
        const double w = 3.0 * double(q.y) / 2.0; // the wind at q's altitude
        const double src = double(q.x) - w * dt;
        if (std::abs(src) < 1e-4 || std::abs(src - 1.0) < 1e-4) continue; // on a face
        const float expect = src > 0.0 && src < 1.0 ? 2.0f : 0.0f;
        ++checked;
        in += expect > 0.0f;
        wrong += densityAt(f, q, dt) != expect;
    }
    EXPECT_GT(in, 5000);
    EXPECT_EQ(wrong, 0) << "of " << checked;
    // and the majorants over the shutter hold the sheared box
    const VolumeSet vs = oneVolume(f, Shutter{-0.5f, 0.5f}, 0.1f);
    EXPECT_NEAR(vs.boundsOf(0).lo.x, -1.5f, 1e-5f);
    EXPECT_NEAR(vs.boundsOf(0).hi.x, 2.5f, 1e-5f);
    const MajorantGrid& g = vs.grids[0];
    // the cell at the top right: only the fast top layer reaches it
    const ivec3 topRight =
        glm::clamp(ivec3(glm::floor((vec3(2.4f, 1.95f, 0.5f) - g.bounds.lo) / g.cellSize)),
                   ivec3(0), g.res - 1);
    EXPECT_EQ(g.at(topRight), 2.0f);
    // bottom right: the still bottom layer never gets there
    const ivec3 bottomRight =
        glm::clamp(ivec3(glm::floor((vec3(2.4f, 0.05f, 0.5f) - g.bounds.lo) / g.cellSize)),
                   ivec3(0), g.res - 1);
    EXPECT_EQ(g.at(bottomRight), 0.0f);
}

TEST(MotionBlur, SampleTimesAreStratifiedOverTheShutter) {
    const Shutter s{-0.1f, 0.3f};
    for (const float offset : {0.0f, 0.37f, 0.999f}) {
        std::vector<int> bins(8, 0);
        for (std::uint32_t k = 0; k < 8; ++k) {
            const float t = sampleTime(s, k, offset);
            ASSERT_GE(t, s.t0);
            ASSERT_LT(t, s.t1);
            ++bins[size_t(std::min(7, int((t - s.t0) / (s.t1 - s.t0) * 8.0f)))];
        }
        for (int b : bins) EXPECT_EQ(b, 1) << "offset " << offset;
    }
}

TEST(MotionBlurPlan, OffWhenTheShutterIsClosedOrNothingMoves) {
    SceneDesc s = windyScene(vec3(2.0f, 0.0f, 0.0f));
    FramePlan p = planFrame(s, 1);
    EXPECT_FALSE(p.motionBlur);
    EXPECT_NE(p.explain().find("motion blur: off (render.shutter closed)"), std::string::npos)
        << p.explain();
    s.render.shutterOpen = -0.25f;
    s.render.shutterClose = 0.25f;
    s.render.fps = 25.0f;
    p = planFrame(s, 1);
    EXPECT_TRUE(p.motionBlur);
    EXPECT_FLOAT_EQ(p.shutterOpen, -0.01f);
    EXPECT_FLOAT_EQ(p.shutterClose, 0.01f);
    EXPECT_NE(p.explain().find("cumulus wind (2, 0, 0)"), std::string::npos) << p.explain();
    EXPECT_NE(p.explain().find("lighting caches"), std::string::npos);
    s.field.cumulus.wind = vec3(0.0f);
    p = planFrame(s, 1);
    EXPECT_FALSE(p.motionBlur);
    EXPECT_NE(p.explain().find("no placed volume moves"), std::string::npos) << p.explain();
    // an automaton with a wind row moves; an advected field with a zero wind does not
    s.field.kind = FieldKind::Automaton;
    s.field.automaton.wind = {{0.0f, vec3(0.0f)}, {3.0f, vec3(1.0f, 0.0f, 0.0f)}};
    EXPECT_TRUE(planFrame(s, 1).motionBlur);
    s.field.automaton.wind.clear();
    EXPECT_FALSE(planFrame(s, 1).motionBlur);
    s.field.advect.enabled = true;
    EXPECT_FALSE(planFrame(s, 1).motionBlur);
    s.field.advect.uniform = vec3(0.0f, 0.0f, 1.0f);
    EXPECT_TRUE(planFrame(s, 1).motionBlur);
    // a moving field no instance places does not count
    s.volumes.push_back(NamedVolumeDesc{"other", homogeneousField(Box{vec3(0.0f), vec3(1.0f)})});
    InstanceDesc only;
    only.volume = 1;
    s.instances = {only};
    EXPECT_FALSE(planFrame(s, 1).motionBlur);
}

TEST(MotionBlurPlan, ShutterKeyIsValidated) {
    auto error = [](const std::string& shutter) -> std::string {
        try {
            io::parseSceneText("[render]\nshutter = " + shutter + "\n", "blur.toml");
        } catch (const io::SceneError& e) {
            return e.what();
        }
        return "";
    };
    const SceneDesc s = io::parseSceneText("[render]\nshutter = [-0.25, 0.5]\n", "ok.toml").scene;
    EXPECT_FLOAT_EQ(s.render.shutterOpen, -0.25f);
    EXPECT_FLOAT_EQ(s.render.shutterClose, 0.5f);
    const std::string after = error("[0.5, -0.25]");
    EXPECT_EQ(after.rfind("blur.toml:2:", 0), 0u) << after;
    EXPECT_NE(after.find("open 0.5 is after close -0.25"), std::string::npos) << after;
    const std::string far = error("[-5, 0]");
    EXPECT_EQ(far.rfind("blur.toml:2:", 0), 0u) << far;
    EXPECT_NE(far.find("render.shutter"), std::string::npos) << far;
    EXPECT_NE(error("[0, nan]"), "");
    EXPECT_NE(error("[0]"), "");
}
