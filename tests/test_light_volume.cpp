// Light-attenuation volume: propagated density integrals against closed forms and against the
// shadow marches it replaces.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/lighting/light_volume.h"
#include "core/render.h"
#include "scenes.h"

using namespace nimbus;

TEST(LightVolume, HomogeneousBoxGivesDistanceToExitTimesDensity) {
    const FieldDesc fd = homogeneousField(Box{vec3(0.0f), vec3(4.0f, 2.0f, 3.0f)}, 1.5f);
    Field f = makeField(fd, 0.0f);
    for (vec3 sun :
         {glm::normalize(vec3(1.0f, 0.6f, 0.3f)), glm::normalize(vec3(-0.2f, 1.0f, -0.4f)),
          glm::normalize(vec3(0.1f, 0.2f, -1.0f))}) {
        LightVolume lv = buildLightVolume(f, sun, 0.05f);
        std::mt19937 rng(3);
        std::uniform_real_distribution<float> u(0.25f, 0.75f);
        const float l = 0.05f / maxComponent(glm::abs(sun)); // path length per slice step
        double meanErr = 0.0;
        for (int i = 0; i < 300; ++i) {
            const vec3 p =
                fd.homogeneous.box.lo + vec3(u(rng), u(rng), u(rng)) * fd.homogeneous.box.extent();
            float t0, t1;
            ASSERT_TRUE(intersectBox(Ray{p, sun}, fd.homogeneous.box, 0.0f, 1e30f, t0, t1));
            const float exact = 1.5f * t1;
            // tau has a kink on the surface of light rays through the box's edges; the
            // interpolation smooths it over about two slice steps
            EXPECT_NEAR(lv.sample(p), exact, 1.5f * 2.5f * l)
                << "sun " << sun.x << "," << sun.y << "," << sun.z;
            meanErr += (lv.sample(p) - exact) / 300.0;
        }
        EXPECT_LT(std::abs(meanErr), 1.5f * 0.3f * l); // no drift along the propagation
    }
}

TEST(LightVolume, MarchWithVolumeCloseToShadowMarches) {
    SceneDesc s;
    s.camera.position = vec3(0.0f, 0.5f, -9.0f);
    s.camera.lookAt = vec3(0.0f, 2.2f, 0.0f);
    s.camera.width = 48;
    s.camera.height = 27;
    s.camera.fovY = 60.0f;
    s.field.cumulus.bounds = Box{vec3(-8.0f, 1.5f, -8.0f), vec3(8.0f, 4.0f, 8.0f)};
    s.field.cumulus.eval = NoiseEval::Direct;
    s.field.cumulus.baseOctaves = 3;
    s.field.cumulus.detailOctaves = 2;
    s.medium.sigma_s = vec3(4.0f);
    s.sun.direction = glm::normalize(vec3(0.6f, 0.5f, 0.4f));
    s.sun.irradiance = vec3(3.0f);
    s.sky.kind = SkyKind::None;
    s.render.background = Background::Transparent;
    s.render.step = 0.05f;
    s.render.shadowStep = 0.05f;
    s.render.shadowGrowth = 0.0f;
    auto renderWith = [&](ShadowMethod m, RenderStats& st) {
        s.render.shadow = m;
        s.render.lightVolumeCell = 0.05f;
        Renderer r(s);
        Framebuffer fb;
        EXPECT_TRUE(r.render(r.plan(1), fb, st));
        return fb;
    };
    RenderStats a, b;
    Framebuffer ref = renderWith(ShadowMethod::March, a);
    Framebuffer vol = renderWith(ShadowMethod::Volume, b);
    EXPECT_GT(a.shadowSamples, 0u);
    EXPECT_EQ(b.shadowSamples, 0u); // the volume replaced every shadow march
    EXPECT_GT(b.lightVolumeLookups, 0u);
    double se = 0.0, sr = 0.0;
    for (size_t i = 0; i < ref.rgba.size(); ++i) {
        se += (ref.rgba[i] - vol.rgba[i]) * (ref.rgba[i] - vol.rgba[i]);
        sr += ref.rgba[i] * ref.rgba[i];
    }
    ASSERT_GT(sr, 0.0);
    EXPECT_LT(std::sqrt(se / sr), 0.05) << "relative RMSE of the volume against shadow marches";
}
