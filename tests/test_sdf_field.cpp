// The SDF cloud field (core/fields/sdf_cloud.h) and its sphere-traced skipping
// (core/tracking/majorant.h): density against the formula, majorants that bound it, traced
// segments that cover every point with density, march with skipping on and off, pathtrace's
// ratio tracking against quadrature, and the example scene through the CLI.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "core/fields/field.h"
#include "core/integrators/pathtrace.h"
#include "core/tracking/majorant.h"
#include "render_util.h"
#include "test_util.h"

using namespace nimbus;

namespace {

/// A sculpted cloud: spheres in a smooth union, cut flat below, eroded by Worley and Perlin
/// noise when `noise`.
SdfFieldDesc sdfCloud(bool noise) {
    SdfNodeDesc blob;
    blob.kind = SdfKind::Union;
    blob.smooth = 0.8f;
    const vec4 spheres[] = {{-1.6f, 0.6f, 0.0f, 0.9f}, {0.0f, 0.8f, 0.2f, 1.2f},
                            {1.5f, 0.6f, -0.2f, 0.9f}, {-0.5f, 1.9f, 0.0f, 0.9f},
                            {0.7f, 2.1f, 0.1f, 0.8f},  {0.1f, 3.0f, 0.0f, 0.5f}};
    for (const vec4& s : spheres) {
        SdfNodeDesc n = sdfSphere(s.w);
        n.transform.translate = vec3(s);
        blob.children.push_back(n);
    }
    SdfNodeDesc base;
    base.kind = SdfKind::Plane;
    base.normal = vec3(0.0f, -1.0f, 0.0f);
    SdfNodeDesc root = sdfOp(SdfKind::Intersection, {blob, base}, 0.2f);
    if (noise) {
        root.displacement = {0.3f, SdfNoise::Worley, 1.2f, 3, 0.5f, 3};
        root.children[0].displacement = {0.1f, SdfNoise::Perlin, 2.5f, 3, 0.5f, 5};
    }
    SdfFieldDesc d;
    d.root = root;
    d.density = 2.0f;
    d.falloff = 0.3f;
    return d;
}

FieldDesc sdfFieldDesc(const SdfFieldDesc& s) {
    FieldDesc f;
    f.kind = FieldKind::Sdf;
    f.sdf = s;
    return f;
}

struct Rng {
    std::mt19937 g{777};
    float u(float lo, float hi) { return std::uniform_real_distribution<float>(lo, hi)(g); }
    vec3 v3(float lo, float hi) { return vec3(u(lo, hi), u(lo, hi), u(lo, hi)); }
};

} // namespace

TEST(SdfCloudField, DensityFollowsTheDistance) {
    SdfFieldDesc d;
    d.root = sdfSphere(1.0f);
    d.density = 2.0f;
    d.falloff = 0.5f;
    const Field f = makeField(sdfFieldDesc(d), 0.0f);
    EXPECT_FLOAT_EQ(f.density(vec3(0.0f)), 2.0f);                 // deeper than the falloff
    EXPECT_NEAR(f.density(vec3(0.75f, 0.0f, 0.0f)), 1.0f, 1e-5f); // d = -w / 2: half
    EXPECT_NEAR(f.density(vec3(0.0f, -0.9f, 0.0f)), 2.0f * 0.104f, 1e-5f); // x = 0.2: 3x^2-2x^3
    EXPECT_EQ(f.density(vec3(0.0f, 1.01f, 0.0f)), 0.0f);                   // outside the surface
    // the bounds: the sphere's box (and a rounding margin)
    EXPECT_NEAR(f.bounds().lo.x, -1.0f, 1e-3f);
    EXPECT_NEAR(f.bounds().hi.y, 1.0f, 1e-3f);
    EXPECT_LE(f.bounds().lo.x, -1.0f);
}

TEST(SdfCloudField, MajorantBoundsTheDensityAndIsZeroFarFromTheSurface) {
    for (bool noise : {false, true}) {
        const Field f = makeField(sdfFieldDesc(sdfCloud(noise)), 0.0f);
        Rng rng;
        int zero = 0, tight = 0;
        for (int b = 0; b < 400; ++b) {
            const vec3 c = rng.v3(-3.5f, 4.0f);
            const vec3 h = rng.v3(0.02f, 0.6f);
            const Box box{c - h, c + h};
            const float m = f.majorant(box);
            float seen = 0.0f;
            for (int i = 0; i < 300; ++i) {
                const vec3 p = box.lo + (box.hi - box.lo) * rng.v3(0.0f, 1.0f);
                seen = std::max(seen, f.density(p));
            }
            ASSERT_LE(seen, m) << "noise " << noise << " box " << b;
            zero += m == 0.0f;
            tight += seen > 0.5f * m;
        }
        EXPECT_GT(zero, 40) << "boxes away from the cloud get 0";
        EXPECT_GT(tight, 20);
    }
}

TEST(SdfCloudField, TracedSegmentsCoverEveryPointWithDensity) {
    // sphere tracing leaps only over space without density (noise on: the displacement
    // amplitude is in the bound), and each segment's majorant bounds the density on it
    for (bool noise : {false, true}) {
        const Field f = makeField(sdfFieldDesc(sdfCloud(noise)), 0.0f);
        const SdfCloudField& sdf = f.as<SdfCloudField>();
        Rng rng;
        long covered = 0, steps = 0;
        for (int r = 0; r < 2000; ++r) {
            const vec3 o = rng.v3(-6.0f, 6.0f) + vec3(0.0f, 0.0f, -8.0f);
            const vec3 target = rng.v3(-2.0f, 2.0f) + vec3(0.0f, 1.2f, 0.0f);
            // instances give non-unit directions: a third of the rays carry one
            const float len = r % 3 == 0 ? 0.6f : 1.0f;
            const Ray ray{o, glm::normalize(target - o) * len};
            MajorantIterator it(sdf, f.bounds(), ray, 0.0f, 40.0f);
            std::vector<MajorantSegment> segs;
            MajorantSegment s;
            while (it.next(s)) {
                ASSERT_TRUE(segs.empty() || s.t0 >= segs.back().t1);
                segs.push_back(s);
            }
            steps += long(it.traceSteps());
            size_t k = 0;
            for (float t = 0.0f; t < 40.0f; t += 2e-3f) {
                const float rho = f.density(ray.at(t));
                while (k < segs.size() && segs[k].t1 < t) ++k;
                if (rho <= 0.0f) continue;
                ++covered;
                ASSERT_TRUE(k < segs.size() && segs[k].t0 <= t)
                    << "density " << rho << " at t " << t << " outside every segment, ray " << r;
                ASSERT_LE(rho, segs[k].sigma_maj) << "ray " << r << " t " << t;
            }
        }
        EXPECT_GT(covered, 10000);
        RecordProperty(noise ? "trace_steps_per_ray_noise" : "trace_steps_per_ray",
                       std::to_string(double(steps) / 2000.0));
    }
}

namespace {

SceneDesc sdfScene(Integrator integrator) {
    SceneDesc s;
    s.camera = cameraLookingAt(vec3(0.0f, 1.5f, -9.0f), vec3(0.0f, 1.3f, 0.0f), 32, 18, 40.0f);
    s.field = sdfFieldDesc(sdfCloud(true));
    s.medium.sigma_s = vec3(3.0f);
    s.sun.direction = glm::normalize(vec3(0.5f, 0.8f, -0.3f));
    s.render.integrator = integrator;
    s.render.step = 0.05f;
    s.render.shadowStep = 0.1f;
    return s;
}

} // namespace

TEST(SdfCloudField, MarchWithSphereTracingGivesTheImageWithoutSkipping) {
    SceneDesc s = sdfScene(Integrator::March);
    // the grid, named: photons ("auto") draw other numbers over other majorants when skipping
    s.render.multipleScattering = MultipleScattering::Grid;
    RenderStats on, off;
    const Framebuffer a = renderScene(s, &on);
    s.render.skipEmpty = false;
    const Framebuffer b = renderScene(s, &off);
    // skipping leaps only over samples of density 0: the same samples, the same image
    double worst = 0.0;
    for (size_t i = 0; i < a.rgba.size(); ++i)
        worst = std::max(worst, double(std::abs(a.rgba[i] - b.rgba[i])));
    EXPECT_LT(worst, 1e-5);
    EXPECT_GT(meanRgb(a), 0.01);
    EXPECT_LT(on.primarySamples + on.shadowSamples, off.primarySamples + off.shadowSamples);
    RecordProperty("lookups_skip_on", std::to_string(on.primarySamples + on.shadowSamples));
    RecordProperty("lookups_skip_off", std::to_string(off.primarySamples + off.shadowSamples));
}

TEST(SdfCloudField, PathTraceWithSphereTracingMatchesWithoutSkipping) {
    SceneDesc s = sdfScene(Integrator::PathTrace);
    s.camera.width = 12;
    s.camera.height = 8;
    s.render.spp = 16;
    // 16 seeds each, per-pixel Z-test (Sidak, alpha 0.01): the traced majorants are unbiased
    const Estimate on = renderSeeds(s, 16);
    s.render.skipEmpty = false;
    const Estimate off = renderSeeds(s, 16, FrameValues::Rgb, 5000);
    EXPECT_TRUE(zTestPasses(on, off, 0.01));
    EXPECT_FALSE(zTestPasses(scaled(on, 1.1), off, 0.01)) << "the test sees a 10% error";
}

TEST(SdfCloudField, RatioTrackingThroughTracedSegmentsIsUnbiased) {
    SceneDesc s = sdfScene(Integrator::PathTrace);
    s.medium.sigma_s = vec3(0.15f);
    Renderer r(s);
    const FramePlan plan = r.plan(1);
    ASSERT_TRUE(plan.sdfTrace);
    const Field field = r.fieldFor(plan);
    RenderStats stats;
    const VolumeSet vs = r.volumesFor(plan, stats);
    ASSERT_TRUE(vs.traceSdf[0]);
    PathContext ctx(s, plan, vs);
    const vec3 o(-4.0f, 1.0f, 0.1f), d(1.0f, 0.0f, 0.0f);
    double tau = 0.0;
    const int N = 200000;
    for (int k = 0; k < N; ++k) tau += field.density(o + d * (8.0f * (k + 0.5f) / N)) * (8.0 / N);
    const double exact = std::exp(-0.15 * tau);
    ASSERT_GT(tau, 0.3);
    ASSERT_GT(exact, 0.01);
    RayCounters cnt;
    PathContext::Scratch scratch;
    std::vector<std::vector<double>> samples;
    for (int k = 0; k < 20000; ++k) {
        Sampler rng{kern::pcg(std::uint32_t(k)), 0};
        samples.push_back({double(ctx.transmittance(o, d, rng, cnt, scratch).x)});
    }
    EXPECT_TRUE(zTestPasses(estimateFromSamples(samples), exactValues({exact}), 0.01))
        << "tau " << tau;
}

TEST(SdfCloudField, ExampleSceneRendersWithoutNaN) {
    // (render.photons named: "auto" traces 8 M photons for this cloud, 14.7 s of the render at
    // 96x54; 500,000 take the same path in 5.3 s)
    TempDir dir;
    const std::string out = (dir / "sdf.####.exr").string();
    const CliRun r =
        runNimbus("render " NIMBUS_SOURCE_DIR "/examples/scenes/sdf_cloud.toml "
                  "--set camera.width=64 --set camera.height=36 --set render.photons=500000 "
                  "--set 'output.path=\"" +
                  out + "\"' --set 'output.preview=\"\"'");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(std::filesystem::exists(dir / "sdf.0001.exr")) << r.output;
    EXPECT_FALSE(contains(r.output, "non-finite")) << r.output;
}
