// render.forward_scattering = "delta" (march, core/integrators/march.h): the share g^2 of
// scattering in the phase function's forward peak kept in the sun's and the camera's beams.
// Against pathtrace (every order, no approximation) on a homogeneous box lit from behind, where
// light scattered forward a few times reaches the camera and plain single scattering plus the
// isotropic diffusion grid misses it; the plan turns it off where it has nothing to do.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/image_error.h"
#include "core/plan.h"
#include "render_util.h"

using namespace nimbus;

namespace {

/// A box of 2 x 2 x 2 of optical radius sigmaS (albedo 1, HG g), the sun alone at `angle`
/// degrees between the view direction and the direction toward the sun (0: straight behind the
/// box), camera from -z; march's defaults otherwise (the diffusion grid).
SceneDesc forwardBox(float sigmaS, float g, float angle, int size = 32) {
    SceneDesc s;
    s.camera = cameraLookingAt(vec3(0.0f, 0.0f, -6.0f), vec3(0.0f), size, size, 30.0f);
    s.field = homogeneousField(Box{vec3(-1.0f), vec3(1.0f)});
    s.medium.sigma_s = vec3(sigmaS);
    s.medium.sigma_a = vec3(0.0f);
    s.medium.g = g;
    const float a = glm::radians(angle);
    s.sun.direction = vec3(0.0f, std::sin(a), std::cos(a));
    s.sun.irradiance = vec3(1.0f);
    s.sky.kind = SkyKind::None;
    s.render.background = Background::Transparent;
    s.render.step = 0.02f;
    s.render.shadowStep = 0.02f;
    s.render.inScatter = InScatter::None;
    s.render.maxDepth = 4096;
    // the beams are part of the diffusion grid's model ("auto" would trace photons here)
    s.render.multipleScattering = MultipleScattering::Grid;
    return s;
}

struct Compared {
    double error = 0.0; ///< relative RMSE over the box's pixels, the reference's noise taken out
    double ratio = 0.0; ///< march's mean over those pixels / the reference's
};

Compared compare(const SceneDesc& s, ForwardScattering mode, const Framebuffer& ref, double noise) {
    SceneDesc m = s;
    m.render.forwardScattering = mode;
    const Framebuffer img = renderScene(m);
    const ImageError e = imageError(img, ref);
    const ImageError own = imageError(img, img, &ref);
    return {withoutNoise(e.rmse, noise) / e.mean, own.mean / e.mean};
}

} // namespace

TEST(ForwardScattering, BacklitBoxCloserToPathtrace) {
    // optical radius 1, g 0.8, the sun 30 degrees off the view axis behind the box: the light
    // the camera sees has mostly been scattered forward once or twice
    const SceneDesc s = forwardBox(1.0f, 0.8f, 30.0f);
    double noise = 0.0;
    const Framebuffer ref = pathtraceHalves(s, 2048, noise);
    const Compared plain = compare(s, ForwardScattering::None, ref, noise);
    const Compared delta = compare(s, ForwardScattering::Delta, ref, noise);
    std::printf("backlit box: none %.1f%% (mean ratio %.3f), delta %.1f%% (%.3f); reference "
                "noise %.2f%%\n",
                100 * plain.error, plain.ratio, 100 * delta.error, delta.ratio,
                100 * noise / imageError(ref, ref).mean);
    EXPECT_LT(delta.error, 0.6 * plain.error);
    EXPECT_NEAR(delta.ratio, 1.0, 0.2);
    EXPECT_LT(plain.ratio, 0.85); // what the beams add is not small here
}

TEST(ForwardScattering, FrontLitBoxNoWorse) {
    // the sun behind the camera (scattering angle 160 degrees): the forward peak's light is
    // what enters the box, and its share toward the camera is small. (Both are about twice too
    // bright here: the box is 0.4 transport mean free paths across, where the diffusion grid
    // overestimates; that is the grid's error, not the beams'.)
    const SceneDesc s = forwardBox(1.0f, 0.8f, 160.0f);
    double noise = 0.0;
    const Framebuffer ref = pathtraceHalves(s, 2048, noise);
    const Compared plain = compare(s, ForwardScattering::None, ref, noise);
    const Compared delta = compare(s, ForwardScattering::Delta, ref, noise);
    std::printf("front-lit box: none %.1f%% (mean ratio %.3f), delta %.1f%% (%.3f)\n",
                100 * plain.error, plain.ratio, 100 * delta.error, delta.ratio);
    EXPECT_LT(delta.error, plain.error + 0.02);
    EXPECT_LT(std::abs(delta.ratio - 1.0), std::abs(plain.ratio - 1.0) + 0.02);
}

TEST(ForwardScattering, IsotropicPhaseUnchanged) {
    // g = 0: no forward peak, so the plan keeps nothing in the beams and the image is the same
    // to the bit
    SceneDesc s = forwardBox(1.0f, 0.0f, 30.0f, 16);
    s.render.forwardScattering = ForwardScattering::Delta;
    const Framebuffer a = renderScene(s);
    s.render.forwardScattering = ForwardScattering::None;
    const Framebuffer b = renderScene(s);
    EXPECT_EQ(a.rgba, b.rgba);
}

TEST(ForwardScattering, PlanKeepsTheForwardPeakOnlyWhereUsed) {
    SceneDesc s = forwardBox(1.0f, 0.8f, 30.0f, 8);
    EXPECT_NEAR(planFrame(s, 1).forwardFraction, 0.64f, 1e-6f);
    SceneDesc off = s;
    off.render.forwardScattering = ForwardScattering::None;
    EXPECT_EQ(planFrame(off, 1).forwardFraction, 0.0f);
    SceneDesc back = s; // a backward peak: nothing forward to keep
    back.medium.g = -0.5f;
    EXPECT_EQ(planFrame(back, 1).forwardFraction, 0.0f);
    SceneDesc photons = s; // traced photons carry the forward-scattered light themselves
    photons.render.multipleScattering = MultipleScattering::Photons;
    EXPECT_EQ(planFrame(photons, 1).forwardFraction, 0.0f);
    SceneDesc single = s; // single scattering alone: nothing forward-scattered is added
    single.render.multipleScattering = MultipleScattering::None;
    EXPECT_EQ(planFrame(single, 1).forwardFraction, 0.0f);
    SceneDesc noSun = s;
    noSun.sun.enabled = false;
    EXPECT_EQ(planFrame(noSun, 1).forwardFraction, 0.0f);
    SceneDesc pt = s;
    pt.render.integrator = Integrator::PathTrace;
    EXPECT_EQ(planFrame(pt, 1).forwardFraction, 0.0f);
}
