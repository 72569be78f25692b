// The single-scattered sky of march (render.sky_scattering = "single", core/lighting/sky_volume.h)
// against pathtrace with max_depth = 1, which computes the same integral without approximation,
// and against the closed form of a half-space; the plan builds the sky's volumes only when used.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "core/kernels/kernels.h"
#include "core/lighting/sky_volume.h"
#include "core/plan.h"
#include "render_util.h"

using namespace nimbus;

namespace {

/// `s` lit by the sky alone (or with its sun), one order of scattering everywhere: march
/// without octaves, in-scatter term or multiple scattering; pathtrace with max_depth = 1.
SceneDesc singleScattering(SceneDesc s, bool sun) {
    s.sun.enabled = sun;
    // a third of a mean free path at density 1 (sigma_s 6): at 0.05 the step's own noise and bias
    // leave 13% against the reference (18% with 8 sky directions), at 0.02 5% (8.5%)
    s.render.step = 0.02f;
    s.sky.kind = SkyKind::Gradient;
    s.render.multipleScattering = MultipleScattering::None;
    s.render.octaves = 1;
    s.render.inScatter = InScatter::None;
    s.render.maxDepth = 1;
    s.render.background = Background::Transparent;
    return s;
}

SceneDesc withSky(SceneDesc s, SkyScattering mode, SkyShadow shadow = SkyShadow::March,
                  int directions = 8) {
    s.render.skyScattering = mode;
    s.render.skyShadow = shadow;
    s.render.skyDirections = directions;
    return s;
}

double seconds(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// A box of 2 x 2 x 2 and optical radius sigma_s, seen from the front and a little above.
SceneDesc skyBox(float sigma_s, int size) {
    SceneDesc s;
    s.camera = cameraLookingAt(vec3(0.0f, 0.5f, -6.0f), vec3(0.0f), size, size, 30.0f);
    s.field = homogeneousField(Box{vec3(-1.0f), vec3(1.0f)});
    s.medium.sigma_s = vec3(sigma_s);
    s.medium.g = 0.5f;
    s.render.step = 0.01f;
    s.render.shadowStep = 0.01f;
    return singleScattering(s, false);
}

} // namespace

TEST(MarchSky, SingleScatteredSkyMatchesPathtraceDepthOne) {
    // a small cumulus layer under a gradient sky, no sun: march's single-scattered sky against
    // pathtrace max_depth = 1 (the exact integral); the ambient term, standing for every order
    // of scattering, is several times too bright and fails the same bound
    const SceneDesc base = singleScattering(smallCumulusLayer(), false);
    double noise = 0.0;
    auto t0 = std::chrono::steady_clock::now();
    const Framebuffer ref = pathtraceHalves(base, 2048, noise);
    const double tRef = seconds(t0);
    const double mRef = meanRgb(ref);
    t0 = std::chrono::steady_clock::now();
    const Framebuffer single = renderScene(withSky(base, SkyScattering::Single));
    const double tSingle = seconds(t0);
    const Framebuffer ambient = renderScene(withSky(base, SkyScattering::Ambient));
    const ImageError eSingle = imageError(single, ref), eAmbient = imageError(ambient, ref);
    const double rel = withoutNoise(eSingle.rmse, noise) / eSingle.mean;
    std::printf("single sky: %.1f%% (%.1f%% with the reference's noise %.1f%%), mean ratio %.3f, "
                "%.2f s; ambient %.1f%%, mean ratio %.2f; pathtrace 2048 spp %.2f s\n",
                100.0 * rel, 100.0 * eSingle.relative(), 100.0 * noise / eSingle.mean,
                meanRgb(single) / mRef, tSingle, 100.0 * eAmbient.relative(),
                meanRgb(ambient) / mRef, tRef);
    EXPECT_LT(rel, 0.12);
    EXPECT_NEAR(meanRgb(single) / mRef, 1.0, 0.04);
    EXPECT_GT(eAmbient.relative(), 0.5);
    EXPECT_GT(meanRgb(ambient) / mRef, 1.5);
}

TEST(MarchSky, SunAndSkySingleScatteringMatchesPathtraceDepthOne) {
    // the same with the sun on in both: march's exact sun term plus its single-scattered sky
    SceneDesc base = singleScattering(smallCumulusLayer(), true);
    base.sun.direction = glm::normalize(vec3(-0.6f, 0.5f, 0.4f));
    base.sun.irradiance = vec3(3.0f);
    double noise = 0.0;
    const Framebuffer ref = pathtraceHalves(base, 2048, noise);
    const Framebuffer single = renderScene(withSky(base, SkyScattering::Single));
    const Framebuffer ambient = renderScene(withSky(base, SkyScattering::Ambient));
    const ImageError e = imageError(single, ref);
    const double rel = withoutNoise(e.rmse, noise) / e.mean;
    std::printf("sun + single sky: %.1f%%, mean ratio %.3f; sun + ambient %.1f%%, mean ratio "
                "%.2f\n",
                100.0 * rel, meanRgb(single) / meanRgb(ref), 100.0 * relativeRmse(ambient, ref),
                meanRgb(ambient) / meanRgb(ref));
    EXPECT_LT(rel, 0.12);
    EXPECT_NEAR(meanRgb(single) / meanRgb(ref), 1.0, 0.04);
    EXPECT_GT(relativeRmse(ambient, ref), 0.3);
}

TEST(MarchSky, HalfSpaceUnderUniformSkyGivesTheClosedForm) {
    // a box 100 mean free paths thick and wide, seen along the normal of its front face,
    // isotropic scattering, uniform sky of 1: the single-scattered sky is (1 - ln 2) / 2
    SceneDesc s;
    s.camera = cameraLookingAt(vec3(0.0f, 0.0f, -3.0f), vec3(0.0f), 4, 4, 0.5f);
    s.field = homogeneousField(Box{vec3(-1.0f), vec3(1.0f)});
    s.medium.sigma_s = vec3(50.0f);
    s.medium.phase = PhaseKind::Isotropic;
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(1.0f);
    s.sun.enabled = false;
    s.render.multipleScattering = MultipleScattering::None;
    s.render.skyScattering = SkyScattering::Single;
    s.render.skyDirections = 64;
    s.render.inScatter = InScatter::None;
    s.render.background = Background::Transparent;
    s.render.epsilon = 1e-4f;
    s.render.step = 0.002f; // a tenth of a mean free path
    s.render.shadowStep = 0.002f;
    s.render.pixelSamples = 16; // 16 rays of 64 directions per pixel, every step
    const Framebuffer fb = renderScene(s);
    const float expect = 0.5f * (1.0f - std::log(2.0f));
    std::printf("half-space: %.5f against (1 - ln 2) / 2 = %.5f\n", meanRgb(fb), expect);
    EXPECT_NEAR(meanRgb(fb) / expect, 1.0, 0.02) << meanRgb(fb) << " against " << expect;
}

TEST(MarchSky, SkyMarchedAtSystematicallyPickedSamplesIsUnbiased) {
    // an optically thin box (0.5 mean free paths across) at steps of 1/200 of a mean free path:
    // every sample's share of the ray's light is far below march.cpp's kSkyMarchShare, so only
    // about one in eight marches the sky, weighted by the inverse of its chance; the image's
    // mean must still be pathtrace's at max_depth = 1 (without the weight it is about 1/8)
    SceneDesc base = skyBox(0.25f, 16);
    base.render.step = 0.02f;
    base.render.shadowStep = 0.02f;
    double noise = 0.0;
    const Framebuffer ref = pathtraceHalves(base, 4096, noise);
    const Framebuffer fb = renderScene(withSky(base, SkyScattering::Single));
    const ImageError e = imageError(fb, ref);
    const double rel = withoutNoise(e.rmse, noise) / e.mean;
    std::printf("thin box, picked samples: mean ratio %.4f, %.1f%% (reference noise %.1f%%)\n",
                meanRgb(fb) / meanRgb(ref), 100.0 * rel, 100.0 * noise / e.mean);
    EXPECT_NEAR(meanRgb(fb) / meanRgb(ref), 1.0, 0.03);
    EXPECT_LT(rel, 0.1);
}

TEST(MarchSky, VolumeOnAFineGridMatchesPathtrace) {
    // fixed directions with their density integrals on a grid of voxels small against the mean
    // free path (0.15 of it): as good as the shadow marches here; on a grid of 1.2 mean free
    // paths it darkens the cloud's skin (measured 48%: docs/accuracy.md)
    const SceneDesc base = skyBox(3.0f, 24);
    double noise = 0.0;
    const Framebuffer ref = pathtraceHalves(base, 2048, noise);
    SceneDesc fine = withSky(base, SkyScattering::Single, SkyShadow::Volume, 32);
    fine.render.lightVolumeCell = 0.05f;
    const Framebuffer volume = renderScene(fine);
    SceneDesc coarse = fine;
    coarse.render.lightVolumeCell = 0.4f;
    const Framebuffer blurred = renderScene(coarse);
    const ImageError e = imageError(volume, ref);
    const double rel = withoutNoise(e.rmse, noise) / e.mean;
    std::printf("sky volume, voxel 0.15 mfp: %.1f%%, mean ratio %.3f; voxel 1.2 mfp: %.1f%%\n",
                100.0 * rel, meanRgb(volume) / meanRgb(ref), 100.0 * relativeRmse(blurred, ref));
    EXPECT_LT(rel, 0.1);
    EXPECT_NEAR(meanRgb(volume) / meanRgb(ref), 1.0, 0.05);
    EXPECT_GT(relativeRmse(blurred, ref), 0.25);
}

TEST(MarchSky, VolumeHoldsTheDensityIntegralOfEachDirection) {
    // a homogeneous box: each direction's value is the density times the distance to the exit
    const FieldDesc fd = homogeneousField(Box{vec3(0.0f), vec3(4.0f, 2.0f, 3.0f)}, 1.5f);
    const Field f = makeField(fd, 0.0f);
    const SkyVolume sv = buildSkyVolume(f, 12, 0.05f);
    ASSERT_EQ(sv.count(), 12);
    EXPECT_EQ(sv.bytes(), size_t(sv.res.x) * sv.res.y * sv.res.z * 12 * sizeof(float));
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.25f, 0.75f);
    float out[12];
    double meanErr = 0.0;
    for (int i = 0; i < 100; ++i) {
        const vec3 p =
            fd.homogeneous.box.lo + vec3(u(rng), u(rng), u(rng)) * fd.homogeneous.box.extent();
        sv.sample(p, out);
        for (int k = 0; k < 12; ++k) {
            const vec3 w = sv.directions[size_t(k)];
            EXPECT_NEAR(glm::length(w), 1.0f, 1e-5f);
            EXPECT_EQ(w, kern::fibonacciDirection(k, 12));
            float t0, t1;
            ASSERT_TRUE(intersectBox(Ray{p, w}, fd.homogeneous.box, 0.0f, 1e30f, t0, t1));
            // the interpolation smooths the kink of rays through the box's edges over about
            // two slice steps (as the sun's light volume, test_light_volume.cpp), and the
            // bilinear steps of long diagonal paths lose up to 6% of it (measured)
            const float l = 0.05f / maxComponent(glm::abs(w));
            EXPECT_NEAR(out[k], 1.5f * t1, 1.5f * 2.5f * l + 0.07f * 1.5f * t1)
                << "direction " << k;
            meanErr += (out[k] - 1.5f * t1) / (1.5f * t1) / 1200.0;
        }
    }
    std::printf("mean relative error of the sky volume's density integrals: %.2f%%\n",
                100.0 * meanErr);
    EXPECT_LT(std::abs(meanErr), 0.02);
}

TEST(MarchSky, FibonacciDirectionsCoverTheSphereEvenly) {
    // equal areas: the mean of the directions is ~0 and as many point up as down
    for (int n : {8, 32, 256}) {
        vec3 sum(0.0f);
        int up = 0;
        for (int i = 0; i < n; ++i) {
            const vec3 w = kern::fibonacciDirection(i, n);
            sum += w;
            up += w.y > 0.0f;
        }
        EXPECT_LT(glm::length(sum) / float(n), 2.0f / float(n)) << n;
        EXPECT_EQ(up, n / 2) << n;
    }
}

TEST(MarchSky, PlanBuildsTheSkyVolumeOnlyWhenUsed) {
    SceneDesc s = singleScattering(smallCumulusLayer(), false);
    // ambient (the default): nothing single, no volume
    FramePlan p = planFrame(s, 1);
    EXPECT_FALSE(p.skySingle);
    EXPECT_FALSE(p.skyVolume);
    EXPECT_NE(p.explain().find("sky light: ambient"), std::string::npos) << p.explain();
    // single with shadow marches: no volume either
    s.render.skyScattering = SkyScattering::Single;
    p = planFrame(s, 1);
    EXPECT_TRUE(p.skySingle);
    EXPECT_FALSE(p.skyVolume);
    EXPECT_NE(p.explain().find("shadow march toward each"), std::string::npos) << p.explain();
    // single with volumes: the volume, its memory in the explanation
    s.render.skyShadow = SkyShadow::Volume;
    p = planFrame(s, 1);
    EXPECT_TRUE(p.skyVolume);
    EXPECT_GT(p.skyVolumeBytes, 0.0);
    EXPECT_NE(p.explain().find("fixed directions"), std::string::npos) << p.explain();
    RenderStats st;
    renderScene(s, &st);
    EXPECT_EQ(double(st.skyVolumeBytes), p.skyVolumeBytes);
    // no sky: neither
    s.sky.kind = SkyKind::None;
    p = planFrame(s, 1);
    EXPECT_FALSE(p.skySingle);
    EXPECT_FALSE(p.skyVolume);
    renderScene(s, &st);
    EXPECT_EQ(st.skyVolumeBytes, 0u);
    // multiple scattering on: the sky is the diffusion grid's
    s.sky.kind = SkyKind::Gradient;
    s.render.multipleScattering = MultipleScattering::Grid;
    p = planFrame(s, 1);
    EXPECT_FALSE(p.skySingle);
    EXPECT_FALSE(p.skyVolume);
    // instances: the volume covers one untransformed volume; the sky marches instead
    s.render.multipleScattering = MultipleScattering::None;
    s.instances = {InstanceDesc{}, InstanceDesc{}};
    s.instances[1].translate = vec3(20.0f, 0.0f, 0.0f);
    p = planFrame(s, 1);
    EXPECT_TRUE(p.skySingle);
    EXPECT_FALSE(p.skyVolume);
    EXPECT_NE(p.explain().find("one untransformed volume"), std::string::npos) << p.explain();
}

TEST(MarchSky, DeterministicAcrossThreadCounts) {
    expectSameImageOnOneAndTwoThreads(
        withSky(singleScattering(smallCumulusLayer(), true), SkyScattering::Single));
}
