// pathtrace in optically thick media: the reference must stay unbiased where path weights are
// products of hundreds of collision probabilities (DESIGN.md, "Path weights as ratios"), and the
// sky's MIS pair must be complete at every depth. Known answers only: the white furnace (an
// albedo-1 medium under a uniform sky returns the sky) and single scattering of a uniform sky by
// a semi-infinite isotropic medium, (1 - ln 2) / 2 of the sky seen along the normal.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/render.h"
#include "render_util.h"

using namespace nimbus;

namespace {

/// A cube of side 2 at the origin, seen face-on from -z through a narrow field of view (every
/// pixel on the centre of the front face), uniform sky, no sun, albedo 1.
SceneDesc thickCube(vec3 sigma_s, int maxDepth, int spp) {
    SceneDesc s = homogeneousBox(Box{vec3(-1.0f), vec3(1.0f)}, 1.0f,
                                 cameraLookingAt(vec3(0.0f, 0.0f, -5.0f), vec3(0.0f), 2, 2, 2.0f));
    s.render.integrator = Integrator::PathTrace;
    s.medium.sigma_s = sigma_s;
    s.medium.sigma_a = vec3(0.0f);
    s.medium.phase = PhaseKind::Isotropic;
    s.sun.enabled = false;
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(1.0f);
    s.render.maxDepth = maxDepth;
    s.render.spp = spp;
    s.render.epsilon = 0.0f;
    return s;
}

/// Per channel over all pixels: the mean of `batches` renders with different seeds and the
/// standard error of that mean (from the spread of the batch means). Every render must be free
/// of non-finite samples (renderScene checks RenderStats::nonFinite == 0).
void channelMeans(SceneDesc s, int batches, vec3& mean, vec3& se) {
    std::vector<std::vector<double>> samples;
    for (int b = 0; b < batches; ++b) {
        s.render.seed = 7000u + std::uint32_t(b);
        RenderStats stats;
        const Framebuffer fb = renderScene(s, &stats);
        EXPECT_EQ(stats.nonFinite, 0u) << "non-finite samples in batch " << b;
        std::vector<double> sum(3, 0.0);
        for (int i = 0; i < fb.width * fb.height; ++i)
            for (int c = 0; c < 3; ++c) sum[c] += fb.rgba[4 * i + c];
        for (double& v : sum) v /= double(fb.width * fb.height);
        samples.push_back(sum);
    }
    const Estimate e = estimateFromSamples(samples); // tests/stats.h
    for (int c = 0; c < 3; ++c) {
        mean[c] = float(e.mean[c]);
        se[c] = float(std::sqrt(e.variance[c] / e.n));
    }
}

// alpha = 0.01 per channel (two-sided): |z| < 2.576
constexpr float kZ = 2.576f;

} // namespace

TEST(PathTraceStress, ChromaticWhiteFurnace2000MeanFreePaths) {
    // 2000 mean free paths across in the thinnest channel; the max-channel majorant makes the
    // other channels' tracking collide mostly null (p_null = 2/3 and 1/3): hundreds of null
    // collisions per path, where unnormalised weights underflowed to 0/0
    SceneDesc s = thickCube(vec3(1000.0f, 2000.0f, 3000.0f), 1 << 30, 512);
    vec3 mean, se;
    channelMeans(s, 6, mean, se);
    for (int c = 0; c < 3; ++c) {
        EXPECT_GT(se[c], 0.0f);
        EXPECT_LT(std::abs(mean[c] - 1.0f), kZ * se[c])
            << "channel " << c << ": " << mean[c] << " +- " << se[c];
        EXPECT_NEAR(mean[c], 1.0f, 0.03f) << "channel " << c;
    }
}

TEST(PathTraceStress, SingleScatteredSkyOfASemiInfiniteMedium) {
    // 10^5 mean free paths across: a half-space for the front face. max_depth = 1: the sky light
    // scattered once toward the camera, (1 - ln 2) / 2 of a uniform sky along the normal for
    // isotropic scattering, which needs both halves of the sky's MIS pair (next-event and phase
    // sampling) at the last vertex
    SceneDesc s = thickCube(vec3(50000.0f), 1, 4096);
    const float expect = 0.5f * (1.0f - std::log(2.0f));
    vec3 mean, se;
    channelMeans(s, 6, mean, se);
    for (int c = 0; c < 3; ++c) {
        EXPECT_LT(std::abs(mean[c] - expect), kZ * se[c] + 1e-4f)
            << "channel " << c << ": " << mean[c] << " +- " << se[c] << ", expected " << expect;
        EXPECT_NEAR(mean[c] / expect, 1.0f, 0.02f) << "channel " << c;
    }
}

TEST(PathTraceStress, DefaultDepthKeepsTheLightOfACloud500MeanFreePathsAcross) {
    // The thick rows of the validation matrix are about 500 mean free paths across at albedo 1.
    // A white furnace of that size with the renderer's default render.max_depth: every walk ends
    // by leaving the cube, not at the cap, so the furnace returns the sky. Caps take the light
    // of the longer walks: 256 (the default before stop 72) 11% of it here, 65,536 0.11%.
    const int spp = 256, batches = 6;
    vec3 mean, se;
    channelMeans(thickCube(vec3(250.0f), RenderDesc{}.maxDepth, spp), batches, mean, se);
    for (int c = 0; c < 3; ++c) {
        EXPECT_LT(std::abs(mean[c] - 1.0f), kZ * se[c] + 1e-4f)
            << "channel " << c << ": " << mean[c] << " +- " << se[c];
        EXPECT_NEAR(mean[c], 1.0f, 0.005f) << "channel " << c;
    }
    vec3 capped, cse;
    channelMeans(thickCube(vec3(250.0f), 256, spp), batches, capped, cse);
    EXPECT_LT(capped.x, 1.0f - 0.01f) << "the 256 cap: " << capped.x << " +- " << cse.x;
    // the same furnace tells a cap of 65,536 apart too: its loss is beyond the noise
    channelMeans(thickCube(vec3(250.0f), 65536, spp), batches, capped, cse);
    EXPECT_GT(1.0f - capped.x, kZ * cse.x) << "the 65,536 cap: " << capped.x << " +- " << cse.x;
    RecordProperty("furnace_default_depth", std::to_string(mean.x));
    RecordProperty("furnace_depth_256", std::to_string(capped.x));
}

TEST(PathTraceStress, NoNonFiniteSamplesAt100000MeanFreePaths) {
    // chromatic and 10^5 mean free paths: paths of up to 4000 events with many null collisions
    // each; every sample must be finite and the furnace must stay near 1 (the depth cap takes
    // the paths that wander longer: about 1.8 / sqrt(4000) = 3% of a half-space's light)
    SceneDesc s = thickCube(vec3(50000.0f, 100000.0f, 150000.0f), 4000, 128);
    vec3 mean, se;
    channelMeans(s, 4, mean, se);
    for (int c = 0; c < 3; ++c) {
        EXPECT_GT(mean[c], 0.9f) << "channel " << c;
        EXPECT_LT(mean[c], 1.0f + kZ * se[c]) << "channel " << c;
    }
}

namespace {

/// Chandrasekhar's H-function of isotropic scattering at albedo 1, from its integral
/// representation ln H(mu) = -(mu / pi) int_0^{pi/2} ln(1 - t cot t) / (cos^2 t + mu^2 sin^2 t) dt
/// (midpoint rule; the logarithmic singularity at t = 0 is integrable).
double chandrasekharH(double mu) {
    const int n = 200000;
    const double h = 0.5 * M_PI / n;
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
        const double t = (i + 0.5) * h, c = std::cos(t), si = std::sin(t);
        sum += std::log(1.0 - t * c / si) / (c * c + mu * mu * si * si);
    }
    return std::exp(-mu / M_PI * sum * h);
}

} // namespace

TEST(PathTraceStress, DiffuseReflectionOfA1000MeanFreePathSlab) {
    // A slab 1000 mean free paths thick (a half-space to 0.2% of its reflection), albedo 1,
    // isotropic scattering, lit by the sun at mu0 = cos 60 deg and seen along its normal
    // (mu = 1): all orders of scattering, reflected radiance in closed form (Chandrasekhar,
    // Radiative Transfer, ch. IV): E / (4 pi) * mu0 / (mu + mu0) * H(mu) H(mu0). The paths
    // are random walks of about a thousand collisions on average, some of millions.
    const double mu0 = 0.5, mu = 1.0;
    ASSERT_NEAR(chandrasekharH(1.0), 2.9078, 2e-4) << "H(1), Chandrasekhar's table";
    const double expect =
        1.0 / (4.0 * M_PI) * mu0 / (mu + mu0) * chandrasekharH(mu) * chandrasekharH(mu0);

    SceneDesc s = homogeneousBox(Box{vec3(-2e4f, -2e4f, 0.0f), vec3(2e4f, 2e4f, 1000.0f)}, 1.0f,
                                 cameraLookingAt(vec3(0.0f, 0.0f, -5.0f), vec3(0.0f), 2, 2, 2.0f));
    s.render.integrator = Integrator::PathTrace;
    s.render.epsilon = 0.0f;
    s.medium.sigma_s = vec3(1.0f);
    s.medium.sigma_a = vec3(0.0f);
    s.medium.phase = PhaseKind::Isotropic;
    s.sky.kind = SkyKind::None;
    s.sun.enabled = true;
    s.sun.irradiance = vec3(1.0f);
    s.sun.direction = glm::normalize(vec3(std::sqrt(1.0f - float(mu0 * mu0)), 0.0f, -float(mu0)));
    s.render.maxDepth = 1 << 30;
    s.render.spp = 1024;
    vec3 mean, se;
    channelMeans(s, 8, mean, se);
    for (int c = 0; c < 3; ++c) {
        EXPECT_LT(std::abs(mean[c] - expect), kZ * se[c])
            << "channel " << c << ": " << mean[c] << " +- " << se[c] << ", expected " << expect;
        EXPECT_NEAR(mean[c] / expect, 1.0, 0.03) << "channel " << c;
    }
    RecordProperty("reflected_radiance", std::to_string(mean[0]));
    RecordProperty("chandrasekhar", std::to_string(expect));
}
