// The two next-event choices of pathtrace that trade work for noise must leave the estimate
// unbiased: the sun's shadow roulette (render.shadow_roulette) and the sky's next-event
// estimation (render.sky_nee). Each is compared with its alternative by a Z-test over
// independent seeds, and shown to do what it is for.
#include <gtest/gtest.h>

#include "core/render.h"

#include "render_util.h"
#include "scenes.h"

using namespace nimbus;

namespace {

/// A unit-radius box 40 mean free paths across, albedo 1, lit by the sun from the side and a
/// uniform sky, seen whole by a 6x4 camera: most scattering points lie deep, where the sun's
/// transmittance is below 0.1 and the roulette skips most shadow rays.
SceneDesc thickBox() {
    SceneDesc s = homogeneousBox(Box{vec3(-1.0f), vec3(1.0f)}, 1.0f,
                                 cameraLookingAt(vec3(0.0f, 0.0f, -5.0f), vec3(0.0f), 6, 4, 30.0f));
    s.render.integrator = Integrator::PathTrace;
    s.render.epsilon = 0.0f;
    s.medium.sigma_s = vec3(20.0f);
    s.medium.sigma_a = vec3(0.0f);
    s.medium.g = 0.6f;
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(0.3f, 0.45f, 0.8f);
    s.sun.direction = glm::normalize(vec3(1.0f, 0.3f, 0.0f));
    s.render.maxDepth = 100000;
    s.render.spp = 64;
    return s;
}

} // namespace

TEST(PathTraceNee, ShadowRouletteKeepsTheMeanAndSkipsShadowWork) {
    SceneDesc on = thickBox(), off = thickBox();
    on.render.shadowRoulette = true;
    off.render.shadowRoulette = false;
    ASSERT_TRUE(Renderer(on).plan(1).shadowRoulette);
    ASSERT_FALSE(Renderer(off).plan(1).shadowRoulette);
    // 16 seeds each, 6x4 pixels x 3 channels, alpha 0.01
    const Estimate a = renderSeeds(on, 16, FrameValues::Rgb, 1000);
    const Estimate b = renderSeeds(off, 16, FrameValues::Rgb, 2000);
    EXPECT_TRUE(zTestPasses(a, b, 0.01));
    EXPECT_FALSE(zTestPasses(scaled(a, 1.05), b, 0.01)) << "the test must see a 5% bias";
    RenderStats sOn, sOff;
    renderScene(on, &sOn);
    renderScene(off, &sOff);
    EXPECT_LT(double(sOn.shadowSamples), 0.8 * double(sOff.shadowSamples))
        << "the roulette must skip shadow work deep in the box";
}

TEST(PathTraceNee, SkyByNextEventEstimationOrByPhaseSamplingAgree) {
    SceneDesc nee = thickBox(), phase = thickBox();
    nee.medium.sigma_s = phase.medium.sigma_s = vec3(1.0f, 2.0f, 3.0f); // chromatic, thinner
    nee.sun.enabled = phase.sun.enabled = false;                        // the sky alone
    nee.render.skyNee = true;
    phase.render.skyNee = false;
    const Estimate a = renderSeeds(nee, 16, FrameValues::Rgb, 1000);
    const Estimate b = renderSeeds(phase, 16, FrameValues::Rgb, 2000);
    EXPECT_TRUE(zTestPasses(a, b, 0.01));
    EXPECT_FALSE(zTestPasses(scaled(a, 1.05), b, 0.01)) << "the test must see a 5% bias";
}

TEST(PathTraceNee, WhiteFurnaceWithSkyNextEventEstimation) {
    // the MIS pair at every depth returns the sky radiance exactly in expectation
    SceneDesc s = whiteFurnace(thickBox(), vec3(0.7f, 1.0f, 1.3f));
    s.camera.width = 2;
    s.camera.height = 2;
    s.medium.sigma_s = vec3(1.0f, 2.0f, 3.0f);
    s.render.skyNee = true;
    s.render.spp = 4096;
    const Estimate render = renderSeeds(s, 16);
    std::vector<double> sky;
    for (int i = 0; i < 4; ++i)
        for (int c = 0; c < 3; ++c) sky.push_back(s.sky.zenith[c]);
    EXPECT_TRUE(zTestPasses(render, exactValues(sky), 0.01));
}
