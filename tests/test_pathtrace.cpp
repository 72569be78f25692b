// Path tracer tests: known analytic answers and statistical checks of unbiasedness.
#include <gtest/gtest.h>

#include <cmath>

#include "core/camera.h"
#include "core/integrators/pathtrace.h"
#include "core/render.h"
#include "render_util.h"
#include "stats.h"

using namespace nimbus;

namespace {

/// The unit box [-1, 1]^3 filling a narrow 6x4 view from z = -5, path traced, no early exit.
SceneDesc boxScene() {
    SceneDesc s = homogeneousBox(Box{vec3(-1.0f), vec3(1.0f)}, 1.0f,
                                 cameraLookingAt(vec3(0.0f, 0.0f, -5.0f), vec3(0.0f), 6, 4, 12.0f));
    s.render.integrator = Integrator::PathTrace;
    s.render.epsilon = 0.0f;
    return s;
}

/// Single scattering of thinSlab() (scenes.h) in closed form: the sun's light scattered once
/// along the view ray and attenuated in and out of the slab.
vec3 thinSlabAnalytic(const SceneDesc& s) {
    const float D = s.field.homogeneous.box.hi.z;
    const float c = std::cos(glm::radians(30.0f));
    const vec3 st = s.medium.sigma_s + s.medium.sigma_a;
    const float cosTheta = glm::dot(vec3(0.0f, 0.0f, 1.0f), s.sun.direction);
    const float p = kern::phaseHG(cosTheta, s.medium.g);
    const float k = 1.0f + 1.0f / c; // in along the view ray, out toward the sun
    return s.sun.irradiance * p * s.medium.sigma_s * (vec3(1.0f) - glm::exp(-st * D * k)) /
           (st * k);
}

} // namespace

TEST(PathTrace, WhiteFurnaceReturnsSkyRadiance) {
    // albedo 1 in every channel (chromatic sigma_s exercises the spectral MIS tracking),
    // uniform sky, no sun: every path must return the sky radiance, whatever the density
    SceneDesc s = whiteFurnace(boxScene(), vec3(0.7f, 1.0f, 1.3f));
    s.camera.width = 2;
    s.camera.height = 2;
    s.medium.sigma_s = vec3(1.0f, 2.0f, 3.0f);
    s.medium.g = 0.6f;
    s.render.spp = 8192;
    s.render.maxDepth = 100000;
    // 16 seeds against the exact sky radiance, 2x2 pixels x 3 channels, alpha 0.01
    const Estimate render = renderSeeds(s, 16);
    std::vector<double> sky;
    for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) sky.push_back(s.sky.zenith[c]);
    EXPECT_TRUE(zTestPasses(render, exactValues(sky), 0.01));
}

TEST(PathTrace, WhiteFurnaceInCumulus) {
    // smallCumulusLayer's cloud through a 3x2 view
    SceneDesc s = whiteFurnace(boxScene(), vec3(1.0f));
    s.camera = cameraLookingAt(vec3(0.0f, 2.5f, -9.0f), vec3(0.0f, 2.8f, 0.0f), 3, 2, 30.0f);
    s.field = smallCumulusLayer().field;
    s.medium.sigma_s = vec3(3.0f);
    s.render.spp = 1536;
    s.render.maxDepth = 100000;
    // 16 seeds against the exact sky radiance 1, 3x2 pixels x 3 channels, alpha 0.01
    const Estimate render = renderSeeds(s, 16);
    EXPECT_TRUE(zTestPasses(render, exactValues(std::vector<double>(18, 1.0)), 0.01));
    Framebuffer T = renderScene(s, nullptr, AovSet{true, false});
    int cloudy = 0;
    for (int i = 0; i < 6; ++i) cloudy += T.transmittance[3 * i] < 0.9f;
    EXPECT_GT(cloudy, 1) << "the furnace must look through cloud";
}

TEST(PathTrace, HomogeneousTransmittanceIsExpMinusSigmaTD) {
    SceneDesc s = boxScene();
    s.medium.sigma_s = vec3(0.4f, 0.6f, 0.8f);
    s.medium.sigma_a = vec3(0.1f);
    s.render.spp = 256;
    s.render.maxDepth = 1;
    Camera cam(s.camera);
    std::vector<double> expect;
    for (int y = 0; y < s.camera.height; ++y)
        for (int x = 0; x < s.camera.width; ++x) {
            // the pixel footprint is jittered: average the exact value over it
            double exact[3] = {0, 0, 0};
            const int n = 16;
            for (int k = 0; k < n * n; ++k) {
                Ray r = cam.generate(x + (k % n + 0.5f) / n, y + (k / n + 0.5f) / n);
                float t0, t1, d = 0.0f;
                if (intersectBox(r, s.field.homogeneous.box, 0.0f, 1e30f, t0, t1)) d = t1 - t0;
                for (int c = 0; c < 3; ++c)
                    exact[c] +=
                        std::exp(-(s.medium.sigma_s[c] + s.medium.sigma_a[c]) * d) / (n * n);
            }
            for (int c = 0; c < 3; ++c) expect.push_back(exact[c]);
        }
    // 16 seeds of the transmittance AOV against the closed form, 6x4 pixels x 3 channels,
    // alpha 0.01
    const Estimate T = renderSeeds(s, 16, FrameValues::Transmittance);
    EXPECT_TRUE(zTestPasses(T, exactValues(expect), 0.01));
}

TEST(PathTrace, RatioTrackingIsUnbiasedInHeterogeneousMedium) {
    SceneDesc s = boxScene();
    const CumulusDesc octaves; // the default octaves
    s.field = cumulusField(Box{vec3(-6.0f, 1.5f, -6.0f), vec3(6.0f, 4.0f, 6.0f)},
                           octaves.baseOctaves, octaves.detailOctaves);
    s.medium.sigma_s = vec3(1.5f);
    s.medium.sigma_a = vec3(0.2f);
    Renderer r(s);
    FramePlan plan = r.plan(1);
    Field field = r.fieldFor(plan);
    RenderStats stats;
    VolumeSet vs = r.volumesFor(plan, stats);
    ASSERT_TRUE(vs.useGrid[0]);
    PathContext ctx(s, plan, vs);
    // a horizontal ray through the layer at 2.2 km
    const vec3 o(-6.0f, 2.2f, 0.3f), d(1.0f, 0.0f, 0.0f);
    double tau = 0.0;
    const int N = 200000;
    for (int k = 0; k < N; ++k) tau += field.density(o + d * (12.0f * (k + 0.5f) / N)) * (12.0 / N);
    const double exact = std::exp(-1.7 * tau);
    ASSERT_GT(tau, 0.3) << "the test ray must cross cloud";
    ASSERT_GT(exact, 0.01);
    RayCounters cnt;
    PathContext::Scratch scratch;
    std::vector<std::vector<double>> samples;
    const int M = 20000;
    for (int k = 0; k < M; ++k) {
        Sampler rng{kern::pcg(std::uint32_t(k)), 0};
        samples.push_back({double(ctx.transmittance(o, d, rng, cnt, scratch).x)});
    }
    // 20000 ratio-tracking estimates against the quadrature, one value, alpha 0.01
    const Estimate T = estimateFromSamples(samples);
    EXPECT_TRUE(zTestPasses(T, exactValues({exact}), 0.01)) << "tau " << tau;
    EXPECT_GT(T.variance[0], 0.0); // it is a stochastic estimator, not an exact one
}

TEST(PathTrace, SingleScatteringInThinSlabMatchesClosedForm) {
    SceneDesc s = thinSlab();
    s.render.spp = 512;
    const vec3 expect = thinSlabAnalytic(s);
    std::vector<double> exact;
    for (int i = 0; i < s.camera.width * s.camera.height; ++i)
        for (int c = 0; c < 3; ++c) exact.push_back(expect[c]);
    // 16 seeds against the closed form, 4x4 pixels x 3 channels, alpha 0.01
    const Estimate render = renderSeeds(s, 16);
    EXPECT_TRUE(zTestPasses(render, exactValues(exact), 0.01));
    // and the test has the power to see a 5% error with the same noise
    EXPECT_FALSE(zTestPasses(scaled(render, 1.05), exactValues(exact), 0.01));
}

TEST(PathTrace, TwoSetsOfSeedsAgree) {
    // two unbiased estimators of the same image: seeds 1000.. against seeds 2000.., 6x4 pixels x
    // 3 channels of the box under the default sun and a uniform sky, alpha 0.01
    SceneDesc s = boxScene();
    s.sky.kind = SkyKind::Uniform;
    s.medium.sigma_s = vec3(2.0f);
    s.render.spp = 64;
    const Estimate a = renderSeeds(s, 16, FrameValues::Rgb, 1000);
    const Estimate b = renderSeeds(s, 16, FrameValues::Rgb, 2000);
    EXPECT_TRUE(zTestPasses(a, b, 0.01));
    // a biased image with the same noise is rejected
    EXPECT_FALSE(zTestPasses(scaled(a, 1.05), b, 0.01));
}

TEST(PathTrace, MarchAgreesInTheSingleScatteringLimit) {
    // the same thin slab through march (deterministic per step) against the closed form: march
    // is a biased (step-discretised), noise-free approximation, so this is a tolerance on its
    // error, not a statistical test
    SceneDesc s = thinSlab();
    s.render.integrator = Integrator::March;
    s.render.inScatter = InScatter::None;
    s.render.multipleScattering = MultipleScattering::None;
    s.render.step = 0.005f;
    s.render.shadowStep = 0.005f;
    s.render.shadowGrowth = 0.0f;
    const vec3 expect = thinSlabAnalytic(s);
    Framebuffer m = renderScene(s);
    for (int i = 0; i < m.width * m.height; ++i)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(m.rgba[4 * i + c] / expect[c], 1.0f, 0.01f) << "march pixel " << i;
}

TEST(PathTrace, DeterministicAcrossThreadCounts) {
    SceneDesc s = boxScene();
    s.sky.kind = SkyKind::Uniform;
    s.render.spp = 16;
    expectSameImageOnOneAndTwoThreads(s, 4);
}
