// Integrator tests: known analytic answers, empty-space skipping, determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "core/camera.h"
#include "core/integrators/march.h"
#include "core/render.h"
#include "render_util.h"

using namespace nimbus;
using glm::ivec2;

namespace {

/// A coloured, absorbing homogeneous slab (density 2 x scale 0.75) seen slightly off-axis, no
/// early exit, transparent background.
SceneDesc slabScene() {
    SceneDesc s =
        homogeneousBox(Box{vec3(-1.0f, -1.0f, -0.5f), vec3(1.0f, 1.0f, 0.7f)}, 2.0f,
                       cameraLookingAt(vec3(0.3f, 0.2f, -5.0f), vec3(0.0f), 24, 16, 30.0f));
    s.medium.sigma_s = vec3(0.5f, 0.8f, 1.1f);
    s.medium.sigma_a = vec3(0.2f, 0.1f, 0.0f);
    s.medium.densityScale = 0.75f;
    s.render.epsilon = 0.0f;
    s.render.background = Background::Transparent;
    return s;
}

/// 8 x 1 x 1 cells of size 1 over [0,8] x [0,1] x [0,1]; cells 2, 3 and 6 hold density (bounds
/// 1, 2 and 3): along the ray from x = -1 the segments [3, 4], [4, 5] and [7, 8].
MajorantGrid threeCellGrid() {
    MajorantGrid g;
    g.bounds = Box{vec3(0.0f), vec3(8.0f, 1.0f, 1.0f)};
    g.res = ivec3(8, 1, 1);
    g.cellSize = vec3(1.0f);
    g.maj = {0, 0, 1, 2, 0, 0, 3, 0};
    return g;
}

} // namespace

TEST(March, StepScheduleRoundTrips) {
    for (double growth : {0.0, 0.01, 0.3}) {
        StepSchedule s(0.05, growth);
        for (double t : {0.0, 0.01, 0.2, 3.0, 40.0, 900.0})
            EXPECT_NEAR(s.t(s.u(t)), t, 1e-9 * (1 + t));
        for (int n = 0; n < 100; ++n) EXPECT_GT(s.t(n + 1) - s.t(n), 0.05 * (1 - 1e-9));
    }
}

TEST(March, HomogeneousSlabTransmittanceIsExact) {
    for (float step : {0.013f, 0.1f, 0.37f}) {
        for (bool skip : {false, true}) {
            SceneDesc s = slabScene();
            s.render.step = step;
            s.render.skipEmpty = skip;
            // the transmittance alone is checked: no multiple scattering to build (under "auto"
            // this absorbing slab would trace 16 M photons a render, 6 s of the test's 7)
            s.render.multipleScattering = MultipleScattering::None;
            Framebuffer fb = renderScene(s, nullptr, AovSet{true, false});
            Camera cam(s.camera);
            const vec3 sigma_t = (s.medium.sigma_s + s.medium.sigma_a) * s.medium.densityScale *
                                 s.field.homogeneous.density;
            int hit = 0;
            for (int y = 0; y < fb.height; ++y)
                for (int x = 0; x < fb.width; ++x) {
                    Ray r = cam.generate(x + 0.5f, y + 0.5f);
                    float t0, t1, d = 0.0f;
                    if (intersectBox(r, s.field.homogeneous.box, 0.0f, 1e30f, t0, t1)) d = t1 - t0;
                    hit += d > 0.0f;
                    const size_t i = size_t(y) * fb.width + x;
                    for (int c = 0; c < 3; ++c)
                        ASSERT_NEAR(fb.transmittance[3 * i + c], std::exp(-sigma_t[c] * d), 1e-4)
                            << "pixel " << x << "," << y << " step " << step;
                }
            EXPECT_GT(hit, fb.width * fb.height / 4);
        }
    }
}

TEST(March, SingleScatterInUniformSlabMatchesClosedForm) {
    // No sun, a uniform sky: the in-scattered source S = sigma_s * L_sky * occlusion(h) is
    // constant along a horizontal ray, so L = L_sky * occlusion * sigma_s / sigma_t * (1 - T).
    SceneDesc s = slabScene();
    s.sun.enabled = false;
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(0.7f, 1.0f, 1.3f);
    s.sky.ambient = 1.0f;
    s.render.multipleScattering = MultipleScattering::None; // the v1 height-occluded ambient
    s.render.step = 0.05f;
    s.camera.height = 1; // one row of horizontal rays: constant height along each ray
    s.camera.fovY = 1.5f;
    s.camera.position = vec3(0.3f, 0.2f, -5.0f);
    s.camera.lookAt = vec3(0.3f, 0.2f, 0.0f);
    Framebuffer fb = renderScene(s, nullptr, AovSet{true, false});
    int crossed = 0;
    for (int i = 0; i < fb.width; ++i) crossed += fb.transmittance[3 * i] < 0.5f;
    EXPECT_GT(crossed, fb.width / 2);
    const vec3 sigma_s = s.medium.sigma_s * s.medium.densityScale * s.field.homogeneous.density;
    const vec3 sigma_t =
        (s.medium.sigma_s + s.medium.sigma_a) * s.medium.densityScale * s.field.homogeneous.density;
    for (int i = 0; i < fb.width * fb.height; ++i)
        for (int c = 0; c < 3; ++c) {
            const float T = fb.transmittance[3 * i + c];
            // horizontal rays at y = 0.2: height fraction h = 0.6 in a box spanning y in [-1, 1]
            const float occl =
                MarchContext::kAmbientGround + (1.0f - MarchContext::kAmbientGround) * 0.6f;
            const float expect = s.sky.zenith[c] * occl * sigma_s[c] / sigma_t[c] * (1.0f - T);
            ASSERT_NEAR(fb.rgba[4 * i + c], expect, 1e-4f);
        }
}

TEST(March, AStepsLightIsLookedAtWhereItsTransmittancePutsIt) {
    // A step of constant density and optical depth tau whose source falls as e^{-k tau x}
    // within it (x the fraction of the step; k = 1 / mu0 - like the sun's transmittance under
    // a lit skin) sends in (1 - e^{-(1 + k) tau}) / (1 + k) (in units of the source at the
    // step's start). marchStep weights the source it is given by the step's opacity 1 - e^-tau;
    // looked at lightFraction(f, tau) for uniform f, the mean is that integral whatever tau.
    // Looked at f itself (the sample's own place), a thick step is far too dark.
    const int n = 200000;
    for (const float k : {0.5f, 2.0f})
        for (const float tau : {1e-5f, 0.004f, 0.3f, 5.0f, 390.0f}) {
            double atLight = 0.0, atSample = 0.0;
            for (int i = 0; i < n; ++i) {
                const float f = (float(i) + 0.5f) / float(n);
                atLight += std::exp(-double(k) * tau * kern::lightFraction(f, tau));
                atSample += std::exp(-double(k) * tau * f);
            }
            const double opacity = -std::expm1(-double(tau));
            atLight *= opacity / n;
            atSample *= opacity / n;
            const double want = -std::expm1(-(1.0 + k) * double(tau)) / (1.0 + k);
            EXPECT_NEAR(atLight / want, 1.0, 2e-4) << "tau " << tau << ", k " << k;
            if (tau >= 5.0f) {
                EXPECT_LT(atSample / want, 0.6) << "tau " << tau << ": the test can tell";
            }
        }
    // the fraction stays in [0, 1] and grows with f, at the ends of float too
    float prev = 0.0f;
    for (const float f : {0.0f, 1e-7f, 0.25f, 0.5f, 0.999f, 0.99999994f, 1.0f})
        for (const float tau : {0.0f, 1e-30f, 0.0099f, 0.01f, 1.0f, 1e4f, 1e30f, INFINITY}) {
            const float s = kern::lightFraction(f, tau);
            EXPECT_TRUE(s >= 0.0f && s <= 1.0f) << f << " " << tau << " -> " << s;
            if (tau == 1.0f) {
                EXPECT_GE(s, prev);
                prev = s;
            }
        }
}

TEST(March, ThickStepsAreSplitToMeetTheHalfSpaceClosedForm) {
    // A sunlit half-space (a slab 20 mean free paths deep) seen face-on, isotropic scattering,
    // the sun on the camera's side 40 degrees off the normal, single scattering only: a ray at
    // cosine mu to the normal sees L = E p(theta) (sigma_s / sigma_t) mu0 / (mu0 + mu). Steps of
    // 5 mean free paths (camera and shadow rays) sample it once each: one jittered point stands
    // for light that comes from the first mean free path alone. render.step_tau splits them
    // (measured: whole 64.1%, split to 0.25 3.21%, to 0.05 0.40%; with the sub-steps all at the
    // step's own jitter 8.7% at 0.25). Whole steps are noisy, not dark: each looks at the light
    // where its transmittance puts it (kern::lightFraction), so their mean over 64 samples a pixel
    // is the closed form's (before: 0.36 of it, the light looked at the sample's own place).
    SceneDesc s = homogeneousBox(
        Box{vec3(-4.0f, -4.0f, 0.0f), vec3(4.0f, 4.0f, 2.0f)}, 1.0f,
        cameraLookingAt(vec3(0.0f, 0.0f, -5.0f), vec3(0.0f, 0.0f, 1.0f), 16, 16, 10.0f));
    s.medium.sigma_s = vec3(8.0f, 9.0f, 10.0f);
    s.medium.sigma_a = vec3(2.0f, 1.0f, 0.0f);
    s.medium.phase = PhaseKind::Isotropic;
    const float el = glm::radians(50.0f);
    s.sun.direction = vec3(std::cos(el), 0.0f, -std::sin(el));
    s.sun.irradiance = vec3(1.0f);
    s.sky.kind = SkyKind::None;
    s.render.multipleScattering = MultipleScattering::None;
    s.render.inScatter = InScatter::None;
    s.render.background = Background::Transparent;
    s.render.step = 0.5f;
    s.render.shadowStep = 0.5f;
    s.render.shadowGrowth = 0.0f;
    s.render.epsilon = 1e-4f;
    Camera cam(s.camera);
    const float mu0 = std::sin(el);
    // the relative RMSE over the image and the density lookups of a render
    auto measure = [&](float stepTau, std::uint64_t& lookups) {
        s.render.stepTau = stepTau;
        RenderStats stats;
        const Framebuffer fb = renderScene(s, &stats);
        lookups = stats.lookups();
        double se = 0.0, sum = 0.0;
        for (int y = 0; y < fb.height; ++y)
            for (int x = 0; x < fb.width; ++x) {
                const float mu = cam.generate(x + 0.5f, y + 0.5f).d.z;
                for (int c = 0; c < 3; ++c) {
                    const float sigmaT = s.medium.sigma_s[c] + s.medium.sigma_a[c];
                    const double want = double(s.medium.sigma_s[c] / sigmaT) * mu0 / (mu0 + mu) /
                                        (4.0 * 3.14159265358979);
                    const float got = fb.rgba[4 * (size_t(y) * fb.width + x) + c];
                    EXPECT_TRUE(std::isfinite(got));
                    se += (got - want) * (got - want);
                    sum += want;
                }
            }
        const double n = 3.0 * fb.width * fb.height;
        return std::sqrt(se / n) / (sum / n);
    };
    std::uint64_t whole = 0, split = 0, fine = 0;
    const double errWhole = measure(0.0f, whole);
    const double errSplit = measure(0.25f, split);
    const double errFine = measure(0.05f, fine);
    std::printf("[ step_tau ] steps of 5 mean free paths: whole %.1f%% (%llu lookups), split to "
                "0.25 %.2f%% (%llu), to 0.05 (at most 64 a step) %.2f%% (%llu)\n",
                100.0 * errWhole, (unsigned long long)whole, 100.0 * errSplit,
                (unsigned long long)split, 100.0 * errFine, (unsigned long long)fine);
    EXPECT_GT(errWhole, 0.3); // the whole steps are far off: the test can tell
    EXPECT_LT(errSplit, 0.05);
    EXPECT_LT(errFine, 0.01);
    EXPECT_GT(split, whole);
    EXPECT_GT(fine, split);

    s.render.stepTau = 0.0f;
    s.render.pixelSamples = 64;
    const Framebuffer fb = renderScene(s);
    for (int c = 0; c < 3; ++c) {
        const float sigmaT = s.medium.sigma_s[c] + s.medium.sigma_a[c];
        double got = 0.0, want = 0.0;
        for (int y = 0; y < fb.height; ++y)
            for (int x = 0; x < fb.width; ++x) {
                const float mu = cam.generate(x + 0.5f, y + 0.5f).d.z;
                want += double(s.medium.sigma_s[c] / sigmaT) * mu0 / (mu0 + mu) /
                        (4.0 * 3.14159265358979);
                got += fb.rgba[4 * (size_t(y) * fb.width + x) + c];
            }
        EXPECT_NEAR(got / want, 1.0, 0.03) << "whole steps, 64 samples a pixel, channel " << c;
    }
}

// render.octave_gate: the octaves above the first are weighted by 1 - exp(-k sigma_s tau_line),
// tau_line the density integral along the sun's line through the sample (toward the sun plus away
// from it). Under a sun straight overhead every sample of a homogeneous box has the same tau_line,
// its height times its density, so the light the higher octaves add is scaled by that
// closed-form factor: about 0.05 in a thin box, 0.63 in a thicker one.
TEST(March, OctaveGateScalesTheHigherOctavesByTheCloudsDepth) {
    for (float sigma : {0.2f, 4.0f}) {
        SceneDesc s =
            homogeneousBox(Box{vec3(-1.0f, -0.5f, -1.0f), vec3(1.0f, 0.5f, 1.0f)}, 1.0f,
                           cameraLookingAt(vec3(0.4f, 0.3f, -5.0f), vec3(0.0f), 24, 16, 30.0f));
        s.medium.sigma_s = vec3(sigma);
        s.medium.sigma_a = vec3(0.0f);
        s.sun.direction = vec3(0.0f, 1.0f, 0.0f);
        s.sky.kind = SkyKind::None;
        s.render.multipleScattering = MultipleScattering::None;
        s.render.inScatter = InScatter::None;
        s.render.background = Background::Transparent;
        s.render.octaveContribution = 0.4f;
        s.render.octaveExtinction = 0.4f;
        auto mean = [&](int octaves, float gate) {
            SceneDesc t = s;
            t.render.octaves = octaves;
            t.render.octaveGate = gate;
            const Framebuffer fb = renderScene(t);
            double sum = 0.0;
            for (std::size_t i = 0; i < fb.rgba.size(); ++i)
                if (i % 4 != 3) sum += fb.rgba[i];
            return sum / double(fb.rgba.size() / 4 * 3);
        };
        const double one = mean(1, 0.0f), all = mean(8, 0.0f), gated = mean(8, 0.25f);
        const double gate = 1.0 - std::exp(-0.25 * double(sigma) * 1.0);
        ASSERT_GT(all - one, 0.05 * one) << "sigma " << sigma; // the octaves add light
        EXPECT_NEAR((gated - one) / (all - one), gate, 1e-3 * gate) << "sigma " << sigma;

        // with the light-attenuation volume the line's integral is the volume read where the
        // line leaves it below (no second march): the same factor, but for the half voxel of
        // density between the last voxel centre and the box's floor (voxels of 1/32 here: the
        // integral 1/64 short, the factor about 1.6% low)
        s.render.shadow = ShadowMethod::Volume;
        s.render.lightVolumeCell = 1.0f / 32.0f;
        const double vOne = mean(1, 0.0f), vAll = mean(8, 0.0f), vGated = mean(8, 0.25f);
        ASSERT_GT(vAll - vOne, 0.05 * vOne) << "sigma " << sigma;
        EXPECT_NEAR((vGated - vOne) / (vAll - vOne), gate, 0.025 * gate) << "sigma " << sigma;
        s.render.shadow = ShadowMethod::March;
        s.render.lightVolumeCell = 0.0f;
    }
}

TEST(March, StepWalkVisitsTheEdgesOfEmptyStretches) {
    // Cells 2, 3 and 6 of 8 hold density: segments [3, 4], [4, 5] and [7, 8] along the ray.
    // Steps of 0.4 sampled a quarter in (t = 0.4 n + 0.1). Without edges only the samples in a
    // segment are visited. With them also, as empty, the step before a segment that reaches into
    // it (n 7 and 17) and the step after one when the next segment starts later (13 and 20),
    // but not step 10 (its sample lies in the segment that follows at once, where it is visited
    // as it is).
    const MajorantGrid g = threeCellGrid();
    const Ray r{vec3(-1.0f, 0.5f, 0.5f), vec3(1.0f, 0.0f, 0.0f)};
    const StepSchedule sched(0.4, 0.0);
    using V = std::vector<std::pair<std::int64_t, bool>>;
    auto walk = [&](EdgeSteps edges, double tIn) {
        MajorantIterator it(&g, g.bounds, r, float(tIn), 9.0f, 0.0f);
        V visited;
        marchSegments(it, sched, tIn, 9.0, 0.25f, edges,
                      [&](float t, float dt, std::int64_t n, float tNext, bool empty) {
                          if (float(sched.t(double(n))) >= float(tIn)) { // (not clipped)
                              EXPECT_NEAR(t, 0.4f * float(n) + 0.1f, 1e-5f) << n;
                              EXPECT_NEAR(dt, 0.4f, 1e-5f) << n;
                          }
                          EXPECT_NEAR(tNext, 0.4f * float(n + 1) + 0.1f, 1e-5f) << n;
                          visited.emplace_back(n, empty);
                          return true;
                      });
        return visited;
    };
    EXPECT_EQ(walk(EdgeSteps::kNone, 1.0), (V{{8, false},
                                              {9, false},
                                              {10, false},
                                              {11, false},
                                              {12, false},
                                              {18, false},
                                              {19, false}}));
    const V edges{{7, true},  {8, false}, {9, false},  {10, false}, {11, false}, {12, false},
                  {13, true}, {17, true}, {18, false}, {19, false}, {20, true}};
    EXPECT_EQ(walk(EdgeSteps::kEdges, 1.0), edges);
    // from a point inside [4, 5] whose first (clipped) step has its sample past 5: only a start
    // that sees density makes that step an edge
    const V tail{{17, true}, {18, false}, {19, false}, {20, true}};
    EXPECT_EQ(walk(EdgeSteps::kEdges, 4.95), tail);
    V fromStart = tail;
    fromStart.insert(fromStart.begin(), {12, true});
    EXPECT_EQ(walk(EdgeSteps::kFromStart, 4.95), fromStart);
}

TEST(March, MajorantGridKnowsTheBoxThatHoldsDensity) {
    // cells 2, 3 and 6 of 8 hold density: [2, 7] x [0, 1] x [0, 1]; none: an empty box
    MajorantGrid g = threeCellGrid();
    const Box b = g.occupiedBounds();
    EXPECT_EQ(b.lo, vec3(2.0f, 0.0f, 0.0f));
    EXPECT_EQ(b.hi, vec3(7.0f, 1.0f, 1.0f));
    g.maj.assign(g.maj.size(), 0.0f);
    EXPECT_TRUE(g.occupiedBounds().empty());
}

TEST(March, MajorantGridBoundAtAPoint) {
    // the cell holding the point; 0 outside the grid, at NaN and for a grid not built
    const MajorantGrid g = threeCellGrid();
    EXPECT_EQ(g.boundAt(vec3(2.5f, 0.5f, 0.5f)), 1.0f);
    EXPECT_EQ(g.boundAt(vec3(3.0f, 0.0f, 0.99f)), 2.0f); // a cell's low faces belong to it
    EXPECT_EQ(g.boundAt(vec3(6.9f, 0.2f, 0.2f)), 3.0f);
    EXPECT_EQ(g.boundAt(vec3(1.5f, 0.5f, 0.5f)), 0.0f);
    for (vec3 out : {vec3(-0.01f, 0.5f, 0.5f), vec3(8.0f, 0.5f, 0.5f), vec3(2.5f, 1.0f, 0.5f),
                     vec3(2.5f, 0.5f, -1e30f), vec3(std::nanf(""), 0.5f, 0.5f)})
        EXPECT_EQ(g.boundAt(out), 0.0f) << out.x << " " << out.y << " " << out.z;
    EXPECT_EQ(MajorantGrid{}.boundAt(vec3(0.5f)), 0.0f);
}

TEST(March, MajorantIteratorGivesKnownSpans) {
    // 8 x 1 x 1 cells over [0,8] x [0,1] x [0,1]; cells 2, 3 and 6 hold density
    const MajorantGrid g = threeCellGrid();
    Ray r{vec3(-1.0f, 0.5f, 0.5f), vec3(1.0f, 0.0f, 0.0f)};
    MajorantIterator it(&g, g.bounds, r, 0.0f, 100.0f, 0.0f);
    MajorantSegment seg;
    std::vector<MajorantSegment> segs;
    while (it.next(seg)) segs.push_back(seg);
    ASSERT_EQ(segs.size(), 3u);
    EXPECT_FLOAT_EQ(segs[0].t0, 3.0f);
    EXPECT_FLOAT_EQ(segs[0].t1, 4.0f);
    EXPECT_FLOAT_EQ(segs[0].sigma_maj, 1.0f);
    EXPECT_FLOAT_EQ(segs[1].t0, 4.0f);
    EXPECT_FLOAT_EQ(segs[1].t1, 5.0f);
    EXPECT_FLOAT_EQ(segs[1].sigma_maj, 2.0f);
    EXPECT_FLOAT_EQ(segs[2].t0, 7.0f);
    EXPECT_FLOAT_EQ(segs[2].t1, 8.0f);
    // backwards, diagonal through a 8^3 grid with only (0,0,0) and (7,7,7) set: spans known
    MajorantGrid d;
    d.bounds = Box{vec3(0.0f), vec3(8.0f)};
    d.res = ivec3(8);
    d.cellSize = vec3(1.0f);
    d.maj.assign(512, 0.0f);
    d.maj[0] = 1.0f;
    d.maj[511] = 1.0f;
    const float s3 = std::sqrt(3.0f);
    Ray back{vec3(9.0f), glm::normalize(vec3(-1.0f))};
    MajorantIterator it2(&d, d.bounds, back, 0.0f, 100.0f, 0.0f);
    segs.clear();
    while (it2.next(seg)) segs.push_back(seg);
    ASSERT_EQ(segs.size(), 2u);
    EXPECT_NEAR(segs[0].t0, 1.0f * s3, 1e-4f);
    EXPECT_NEAR(segs[0].t1, 2.0f * s3, 1e-4f);
    EXPECT_NEAR(segs[1].t0, 8.0f * s3, 1e-4f);
    EXPECT_NEAR(segs[1].t1, 9.0f * s3, 1e-4f);
}

TEST(March, BlockSkippingYieldsTheSameSpansAsTheCellWalk) {
    // a 37 x 13 x 29 grid (blocks cut at every face) with a few clusters of density; rays from
    // everywhere, axis-aligned ones too: the walk that leaps over empty blocks must give the
    // spans the plain cell walk gives
    MajorantGrid g;
    g.bounds = Box{vec3(-3.0f, 1.0f, -2.0f), vec3(4.4f, 3.6f, 3.8f)};
    g.res = ivec3(37, 13, 29);
    g.cellSize = g.bounds.extent() / vec3(g.res);
    g.maj.assign(size_t(37) * 13 * 29, 0.0f);
    std::mt19937 rng(21);
    std::uniform_int_distribution<int> cx(0, 36), cy(0, 12), cz(0, 28), r(0, 2);
    for (int k = 0; k < 12; ++k) {
        const ivec3 c(cx(rng), cy(rng), cz(rng));
        const int rad = r(rng);
        for (int z = c.z - rad; z <= c.z + rad; ++z)
            for (int y = c.y - rad; y <= c.y + rad; ++y)
                for (int x = c.x - rad; x <= c.x + rad; ++x)
                    if (x >= 0 && y >= 0 && z >= 0 && x < 37 && y < 13 && z < 29)
                        g.maj[(size_t(z) * 13 + y) * 37 + x] = 1.0f + float(k);
    }
    MajorantGrid skipping = g;
    skipping.buildBlocks();
    size_t empty = 0, far = 0;
    for (auto d : skipping.blockDistance) {
        empty += d > 0;
        far += d > 1;
    }
    // there is something to skip, in cubes of more than one block too
    ASSERT_GT(empty, skipping.blockDistance.size() / 3);
    ASSERT_LT(empty, skipping.blockDistance.size());
    ASSERT_GT(far, 0u);

    std::uniform_real_distribution<float> u(-1.0f, 1.0f), pos(-6.0f, 7.0f);
    auto spans = [](const MajorantGrid& grid, const Ray& ray, float tmin) {
        std::vector<MajorantSegment> out;
        MajorantIterator it(&grid, grid.bounds, ray, tmin, 100.0f, 0.0f);
        MajorantSegment seg;
        while (it.next(seg)) out.push_back(seg);
        return out;
    };
    size_t total = 0;
    for (int i = 0; i < 4000; ++i) {
        vec3 d(u(rng), u(rng), u(rng));
        if (i % 4 == 0) d[i / 4 % 3] = 0.0f; // parallel to a face
        if (glm::length(d) < 1e-3f) continue;
        // rays from outside and from inside the grid
        const vec3 o = i % 2 ? vec3(pos(rng), pos(rng) * 0.5f + 2.3f, pos(rng))
                             : g.bounds.lo + vec3(0.5f + 0.5f * u(rng)) * g.bounds.extent();
        const Ray ray{o, glm::normalize(d)};
        const auto a = spans(g, ray, 0.0f), b = spans(skipping, ray, 0.0f);
        ASSERT_EQ(a.size(), b.size()) << "ray " << i;
        for (size_t k = 0; k < a.size(); ++k) {
            EXPECT_NEAR(a[k].t0, b[k].t0, 1e-4f);
            EXPECT_NEAR(a[k].t1, b[k].t1, 1e-4f);
            EXPECT_EQ(a[k].sigma_maj, b[k].sigma_maj);
        }
        total += a.size();
    }
    EXPECT_GT(total, 800u); // many rays met density (1089 spans with this seed)
}

TEST(March, FieldMajorantBoundsDensity) {
    // direct noise, float tiles, and RGBA8 tiles in Olajos' layout (the bound from the channels'
    // extremes: the largest Perlin channel, the smallest Worley ones)
    for (int mode : {0, 1, 2}) {
        const bool baked = mode > 0;
        SceneDesc s = cumulusFromBelow();
        if (mode == 2) s.field.cumulus.eval = NoiseEval::Rgba;
        s.field.cumulus.baseBakeResolution = 32;
        s.field.cumulus.detailBakeResolution = 16;
        auto base = baked ? bakeCumulusBase(s.field.cumulus) : nullptr;
        auto detail = baked ? bakeCumulusDetail(s.field.cumulus) : nullptr;
        Field f = makeField(s.field, 3.0f, base, detail);
        std::mt19937 rng(8);
        std::uniform_real_distribution<float> ux(-8, 8), uy(1.5f, 4.0f), w(0.02f, 1.0f);
        int positive = 0, boxesZero = 0;
        for (int i = 0; i < 3000; ++i) {
            vec3 lo(ux(rng), uy(rng), ux(rng));
            Box b{lo, lo + vec3(w(rng), w(rng) * 0.5f, w(rng))};
            const float m = f.majorant(b);
            boxesZero += m == 0.0f;
            for (int k = 0; k < 27; ++k) {
                vec3 a((k % 3) / 2.0f, ((k / 3) % 3) / 2.0f, (k / 9) / 2.0f);
                float rho = f.density(b.lo + a * b.extent());
                positive += rho > 0.0f;
                ASSERT_LE(rho, m + 1e-6f) << "mode " << mode;
            }
        }
        EXPECT_GT(positive, 500) << "the test field must hold cloud";
        EXPECT_GT(boxesZero, 300) << "and bounds must be tight enough to skip";
    }
}

TEST(March, BakedNoiseEqualsDirectAtNodes) {
    CumulusDesc c;
    c.baseBakeResolution = 16;
    auto vol = bakeCumulusBase(c);
    for (int i = 0; i < 16; i += 3)
        for (int j = 0; j < 16; j += 5) {
            vec3 node(float(i), float(j), float((i + j) % 16));
            EXPECT_NEAR(vol->sample(node),
                        kern::cumulusBaseNoise(cumulusParams(c, 0.0f), node / 16.0f), 1e-6f);
            EXPECT_NEAR(vol->sample(node + vec3(16.0f, -32.0f, 48.0f)), vol->sample(node), 1e-5f);
        }
}

// Olajos' channel layout (field.evaluation = "rgba"): combined at one point, the channels are the
// noise itself (every octave count of the detail noise); at the nodes of an RGBA8 tile, within
// the 8-bit quantisation of the channels; the tile wraps.
TEST(March, RgbaChannelsAreTheNoise) {
    std::mt19937 rng(21);
    std::uniform_real_distribution<float> u(-3.0f, 3.0f);
    for (int detailOctaves : {1, 2, 3, 4, 5, 6}) {
        CumulusDesc c;
        c.detailOctaves = detailOctaves;
        const kern::CumulusParams P = cumulusParams(c, 0.0f);
        double worst = 0.0;
        for (int i = 0; i < 2000; ++i) {
            const vec3 q(u(rng), u(rng), u(rng));
            const float base = kern::cumulusBaseNoise(P, q);
            const float detail = kern::cumulusDetailNoise(P, q);
            worst = std::max(
                worst, double(std::abs(
                           kern::cumulusBaseFromChannels(kern::cumulusBaseChannels(P, q)) - base)));
            worst = std::max(worst, double(std::abs(kern::cumulusDetailFromChannels(
                                                        P, kern::cumulusDetailChannels(P, q)) -
                                                    detail)));
            const vec4 ch = kern::cumulusDetailChannels(P, q);
            for (int k = 0; k < 4; ++k) ASSERT_TRUE(ch[k] >= 0.0f && ch[k] <= 1.0f) << k;
        }
        EXPECT_LT(worst, 2e-6) << detailOctaves << " detail octaves";
    }
    CumulusDesc c;
    c.eval = NoiseEval::Rgba;
    c.baseBakeResolution = 16;
    c.detailBakeResolution = 16;
    const auto base = bakeCumulusBase(c), detail = bakeCumulusDetail(c);
    ASSERT_TRUE(base->channels() && detail->channels());
    EXPECT_TRUE(base->values.empty());
    EXPECT_EQ(base->rgba.size(), std::size_t(4 * 16 * 16 * 16));
    const kern::CumulusParams P = cumulusParams(c, 0.0f);
    for (int i = 0; i < 16; i += 3)
        for (int j = 0; j < 16; j += 5) {
            const vec3 node(float(i), float(j), float((i + j) % 16));
            const vec4 want = kern::cumulusBaseChannels(P, node / 16.0f);
            const vec4 got = base->sample4(node);
            for (int k = 0; k < 4; ++k) EXPECT_NEAR(got[k], want[k], 0.5f / 255.0f + 1e-6f);
            const vec4 wantD = kern::cumulusDetailChannels(P, node / 16.0f);
            const vec4 gotD = detail->sample4(node);
            for (int k = 0; k < 4; ++k) EXPECT_NEAR(gotD[k], wantD[k], 0.5f / 255.0f + 1e-6f);
            const vec4 wrapped = base->sample4(node + vec3(16.0f, -32.0f, 48.0f));
            for (int k = 0; k < 4; ++k) EXPECT_NEAR(wrapped[k], got[k], 1e-5f);
        }
    // between the nodes: each channel interpolated apart (the midpoint of two nodes along x)
    const vec4 a = base->sample4(vec3(3, 4, 5)), b = base->sample4(vec3(4, 4, 5));
    const vec4 mid = base->sample4(vec3(3.5f, 4, 5));
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(mid[k], 0.5f * (a[k] + b[k]), 1e-6f);
}

TEST(March, EmptySpaceSkippingSameImageFewerLookups) {
    SceneDesc s = cumulusFromBelow();
    // the grid, named: photons ("auto") are delta-tracked over the majorant grid too, so their
    // noise differs with skipping (unbiased either way; tests/test_photons.cpp)
    s.render.multipleScattering = MultipleScattering::Grid;
    s.render.skipEmpty = false;
    RenderStats off, on;
    Framebuffer a = renderScene(s, &off, AovSet{true, true});
    s.render.skipEmpty = true;
    Framebuffer b = renderScene(s, &on, AovSet{true, true});
    float maxDiff = 0.0f, maxVal = 0.0f;
    for (size_t i = 0; i < a.rgba.size(); ++i) {
        maxDiff = std::max(maxDiff, std::abs(a.rgba[i] - b.rgba[i]));
        maxVal = std::max(maxVal, a.rgba[i]);
    }
    EXPECT_LE(maxDiff, 1e-5f);
    EXPECT_GT(maxVal, 0.0f);
    EXPECT_LT(on.lookups() * 2, off.lookups()) << "on " << on.lookups() << " off " << off.lookups();
    // the image is not trivial: some pixels see cloud
    int cloudy = 0;
    for (size_t i = 0; i < a.transmittance.size(); i += 3) cloudy += a.transmittance[i] < 0.9f;
    EXPECT_GT(cloudy, 20);
}

TEST(March, DeterministicAcrossThreadCounts) {
    SceneDesc s = cumulusFromBelow();
    s.render.tileSize = 8;
    // (photons named: the photons "auto" traces through this layer were most of the four
    // renders, 15.3 s against 1.9 s at 500,000; their trace is compared across thread counts
    // all the same)
    s.render.photons = 500000;
    std::vector<Framebuffer> fbs;
    for (ivec2 cfg : {ivec2(1, 8), ivec2(2, 8), ivec2(2, 5)}) {
        s.render.threads = cfg.x;
        s.render.tileSize = cfg.y;
        fbs.push_back(renderScene(s, nullptr, AovSet{true, true}, 7));
    }
    for (size_t k = 1; k < fbs.size(); ++k) {
        EXPECT_EQ(fbs[0].rgba, fbs[k].rgba);
        EXPECT_EQ(fbs[0].transmittance, fbs[k].transmittance);
        EXPECT_EQ(fbs[0].depth, fbs[k].depth);
    }
    // a different seed gives a different (jittered) image
    s.render.seed = 99;
    Framebuffer other = renderScene(s, nullptr, {}, 7);
    EXPECT_NE(other.rgba, fbs[0].rgba);
}

TEST(March, CancelStopsEarly) {
    SceneDesc s = cumulusFromBelow();
    Renderer r(s);
    Framebuffer fb;
    RenderStats st;
    std::atomic<bool> cancel{true};
    RenderCallbacks cb;
    cb.cancel = &cancel;
    EXPECT_FALSE(r.render(r.plan(1), fb, st, cb));
}

TEST(MarchPixels, BoxFilteredSamplesEqualTheSupersampledAverage) {
    // with jitter off, 64 stratified samples of a box filter one pixel wide sit at the centres
    // of the pixels of the same view rendered 8x larger: the two must agree after averaging
    // 8x8 blocks (up to the rounding of the ray directions)
    SceneDesc s = sunlitBox(2.0f, 6, 30.0f, 40.0f);
    s.render.multipleScattering = MultipleScattering::None;
    s.render.jitter = false;
    s.render.pixelSamples = 64;
    const Framebuffer a = renderScene(s);
    SceneDesc big = s;
    big.render.pixelSamples = 1;
    big.camera.width *= 8;
    big.camera.height *= 8;
    const Framebuffer b = renderScene(big);
    int edge = 0;
    for (int y = 0; y < s.camera.height; ++y)
        for (int x = 0; x < s.camera.width; ++x)
            for (int c = 0; c < 4; ++c) {
                double mean = 0.0;
                float lo = 1e30f, hi = -1e30f;
                for (int j = 0; j < 8; ++j)
                    for (int i = 0; i < 8; ++i) {
                        const float v = b.rgba[4 * ((8 * y + j) * b.width + 8 * x + i) + c];
                        mean += v / 64.0;
                        lo = std::min(lo, v);
                        hi = std::max(hi, v);
                    }
                edge += c == 3 && hi - lo > 0.5f; // the box's silhouette crosses this pixel
                EXPECT_NEAR(a.rgba[4 * (y * a.width + x) + c], mean, 1e-4 + 1e-4 * std::abs(mean))
                    << "pixel " << x << "," << y << " channel " << c;
            }
    EXPECT_GT(edge, 0) << "the view must cross the box's edge";
}

TEST(MarchPixels, EveryFilterKeepsAUniformImage) {
    // filter weights are normalised: the sky behind an empty view comes back unchanged
    SceneDesc s = sunlitBox(2.0f, 4, 30.0f, 40.0f);
    s.field.homogeneous.box = Box{vec3(50.0f), vec3(51.0f)}; // out of view
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(0.3f, 0.5f, 0.9f);
    s.render.background = Background::Sky;
    s.render.pixelSamples = 9;
    for (PixelFilter f : {PixelFilter::Box, PixelFilter::Gaussian, PixelFilter::BlackmanHarris})
        for (float width : {1.0f, 2.0f, 4.0f}) {
            s.render.filter = f;
            s.render.filterWidth = width;
            const Framebuffer fb = renderScene(s);
            for (int i = 0; i < fb.width * fb.height; ++i)
                for (int c = 0; c < 3; ++c)
                    EXPECT_NEAR(fb.rgba[4 * i + c], s.sky.zenith[c], 1e-6f)
                        << "filter " << int(f) << " width " << width;
        }
}
