// Path tracer tests: known analytic answers and statistical checks of unbiasedness.
#include <gtest/gtest.h>

#include <cmath>

#include "core/camera.h"
#include "core/integrators/pathtrace.h"
#include "core/render.h"
#include "render_util.h"

using namespace nimbus;

namespace {

SceneDesc boxScene() {
    SceneDesc s;
    s.render.integrator = Integrator::PathTrace;
    s.camera.position = vec3(0.0f, 0.0f, -5.0f);
    s.camera.lookAt = vec3(0.0f);
    s.camera.width = 6;
    s.camera.height = 4;
    s.camera.fovY = 12.0f;
    s.field.kind = FieldKind::Homogeneous;
    s.field.homogeneous.box = Box{vec3(-1.0f), vec3(1.0f)};
    s.field.homogeneous.density = 1.0f;
    s.render.epsilon = 0.0f;
    return s;
}

/// Thin slab, sun from behind the camera at 30 degrees: closed-form single scattering.
SceneDesc thinSlab() {
    SceneDesc s = boxScene();
    s.camera.fovY = 0.5f;
    s.camera.width = 4;
    s.camera.height = 4;
    s.field.homogeneous.box = Box{vec3(-200.0f, -200.0f, 0.0f), vec3(200.0f, 200.0f, 0.5f)};
    s.medium.sigma_s = vec3(0.2f, 0.3f, 0.4f);
    s.medium.sigma_a = vec3(0.05f);
    s.medium.phase = PhaseKind::HenyeyGreenstein;
    s.medium.g = 0.3f;
    const float th = glm::radians(30.0f);
    s.sun.direction = vec3(std::sin(th), 0.0f, -std::cos(th));
    s.sun.irradiance = vec3(2.0f);
    s.sky.kind = SkyKind::None;
    s.render.background = Background::Transparent;
    s.render.maxDepth = 1;
    return s;
}

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

/// Renders `batches` images with different seeds; per pixel and channel returns the mean and the
/// standard error of the mean (from the spread of the batch means).
void batchedRender(SceneDesc s, int batches, std::vector<double>& mean, std::vector<double>& se,
                   AovSet aovs = {}) {
    std::vector<double> sum, sum2;
    for (int b = 0; b < batches; ++b) {
        s.render.seed = 1000u + std::uint32_t(b);
        Framebuffer fb = renderScene(s, nullptr, aovs);
        if (sum.empty()) sum.assign(fb.rgba.size(), 0.0), sum2.assign(fb.rgba.size(), 0.0);
        for (size_t i = 0; i < fb.rgba.size(); ++i) {
            sum[i] += fb.rgba[i];
            sum2[i] += double(fb.rgba[i]) * fb.rgba[i];
        }
    }
    mean.resize(sum.size());
    se.resize(sum.size());
    for (size_t i = 0; i < sum.size(); ++i) {
        mean[i] = sum[i] / batches;
        const double var =
            std::max(0.0, sum2[i] / batches - mean[i] * mean[i]) * batches / (batches - 1);
        se[i] = std::sqrt(var / batches);
    }
}

} // namespace

TEST(PathTrace, WhiteFurnaceReturnsSkyRadiance) {
    // albedo 1 in every channel (chromatic sigma_s exercises the spectral MIS tracking),
    // uniform sky, no sun: every path must return the sky radiance, whatever the density
    SceneDesc s = boxScene();
    s.camera.width = 2;
    s.camera.height = 2;
    s.sun.enabled = false;
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(0.7f, 1.0f, 1.3f);
    s.medium.sigma_s = vec3(1.0f, 2.0f, 3.0f);
    s.medium.sigma_a = vec3(0.0f);
    s.medium.g = 0.6f;
    s.render.spp = 16384;
    s.render.maxDepth = 100000;
    std::vector<double> mean, se;
    batchedRender(s, 8, mean, se);
    for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) {
            const double L = s.sky.zenith[c], m = mean[4 * i + c];
            EXPECT_NEAR(m / L, 1.0, 0.01) << "pixel " << i << " channel " << c;
            EXPECT_LT(std::abs(m - L), 4.0 * se[4 * i + c] + 1e-6) << "Z-test, pixel " << i;
        }
}

TEST(PathTrace, WhiteFurnaceInCumulus) {
    SceneDesc s = boxScene();
    s.camera.width = 3;
    s.camera.height = 2;
    s.camera.position = vec3(0.0f, 2.5f, -9.0f);
    s.camera.lookAt = vec3(0.0f, 2.8f, 0.0f);
    s.camera.fovY = 30.0f;
    s.field.kind = FieldKind::Cumulus;
    s.field.cumulus.bounds = Box{vec3(-6.0f, 1.5f, -6.0f), vec3(6.0f, 4.0f, 6.0f)};
    s.field.cumulus.eval = NoiseEval::Direct;
    s.field.cumulus.baseOctaves = 2;
    s.field.cumulus.detailOctaves = 1;
    s.sun.enabled = false;
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(1.0f);
    s.medium.sigma_s = vec3(3.0f);
    s.medium.sigma_a = vec3(0.0f);
    s.render.spp = 4096;
    s.render.maxDepth = 100000;
    std::vector<double> mean, se;
    batchedRender(s, 6, mean, se);
    Framebuffer T = renderScene(s, nullptr, AovSet{true, false});
    int cloudy = 0;
    for (int i = 0; i < 6; ++i) {
        cloudy += T.transmittance[3 * i] < 0.9f;
        EXPECT_NEAR(mean[4 * i + 1], 1.0, 0.01) << "pixel " << i;
        EXPECT_LT(std::abs(mean[4 * i + 1] - 1.0), 4.0 * se[4 * i + 1] + 1e-6)
            << "Z-test, pixel " << i;
    }
    EXPECT_GT(cloudy, 1) << "the furnace must look through cloud";
}

TEST(PathTrace, HomogeneousTransmittanceIsExpMinusSigmaTD) {
    SceneDesc s = boxScene();
    s.medium.sigma_s = vec3(0.4f, 0.6f, 0.8f);
    s.medium.sigma_a = vec3(0.1f);
    s.render.spp = 4096;
    s.render.maxDepth = 1;
    Framebuffer fb = renderScene(s, nullptr, AovSet{true, false});
    Camera cam(s.camera);
    for (int y = 0; y < fb.height; ++y)
        for (int x = 0; x < fb.width; ++x) {
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
            const size_t i = size_t(y) * fb.width + x;
            for (int c = 0; c < 3; ++c) {
                // each sample is a ratio-tracking estimate in [0, 1]: sd <= 0.5 / sqrt(spp)
                EXPECT_NEAR(fb.transmittance[3 * i + c], exact[c], 5.0 * 0.5 / std::sqrt(4096.0))
                    << x << "," << y << " channel " << c;
            }
        }
}

TEST(PathTrace, RatioTrackingIsUnbiasedInHeterogeneousMedium) {
    SceneDesc s = boxScene();
    s.field.kind = FieldKind::Cumulus;
    s.field.cumulus.bounds = Box{vec3(-6.0f, 1.5f, -6.0f), vec3(6.0f, 4.0f, 6.0f)};
    s.field.cumulus.eval = NoiseEval::Direct;
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
    double sum = 0.0, sum2 = 0.0;
    const int M = 20000;
    for (int k = 0; k < M; ++k) {
        Sampler rng{kern::pcg(std::uint32_t(k)), 0};
        const double T = ctx.transmittance(o, d, rng, cnt, scratch).x;
        sum += T;
        sum2 += T * T;
    }
    const double mean = sum / M, var = sum2 / M - mean * mean;
    const double se = std::sqrt(var / M);
    EXPECT_NEAR(mean, exact, 4.0 * se + 1e-4) << "tau " << tau << " se " << se;
    EXPECT_GT(var, 0.0); // it is a stochastic estimator, not an exact one
}

TEST(PathTrace, SingleScatteringInThinSlabMatchesClosedForm) {
    SceneDesc s = thinSlab();
    s.render.spp = 8192;
    Framebuffer fb = renderScene(s);
    const vec3 expect = thinSlabAnalytic(s);
    vec3 mean(0.0f);
    for (int i = 0; i < fb.width * fb.height; ++i)
        mean += vec3(fb.rgba[4 * i], fb.rgba[4 * i + 1], fb.rgba[4 * i + 2]);
    mean /= float(fb.width * fb.height);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[c] / expect[c], 1.0f, 0.02f) << "channel " << c;
}

TEST(PathTrace, MarchAgreesInTheSingleScatteringLimit) {
    // the same thin slab through march (deterministic per step) and pathtrace (unbiased)
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
    s.render.threads = 1;
    Framebuffer a = renderScene(s);
    s.render.threads = 2;
    s.render.tileSize = 4;
    Framebuffer b = renderScene(s);
    EXPECT_EQ(a.rgba, b.rgba);
}
