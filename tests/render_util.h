/// @file render_util.h
/// @brief Rendering helpers shared by the integrator tests: one frame of a scene, the scene
/// they share, and image comparisons.
#pragma once

#include <cmath>

#include <gtest/gtest.h>

#include "core/render.h"

/// Renders frame `frame` of `s` with what is bound to it (grids, geometry), expecting it to
/// complete with every value finite.
inline nimbus::Framebuffer renderScene(const nimbus::SceneDesc& s,
                                       const nimbus::FrameBindings& bindings,
                                       nimbus::RenderStats* statsOut = nullptr,
                                       nimbus::AovSet aovs = {}, int frame = 1) {
    nimbus::Renderer r(s);
    nimbus::Framebuffer fb;
    nimbus::RenderStats stats;
    EXPECT_TRUE(r.render(r.plan(frame, bindings, aovs), bindings, fb, stats));
    EXPECT_EQ(stats.nonFinite, 0u);
    for (float v : fb.rgba) EXPECT_TRUE(std::isfinite(v));
    if (statsOut) *statsOut = stats;
    return fb;
}

/// Renders frame `frame` of a scene with nothing to bind (procedural fields, no surfaces).
inline nimbus::Framebuffer renderScene(const nimbus::SceneDesc& s,
                                       nimbus::RenderStats* statsOut = nullptr,
                                       nimbus::AovSet aovs = {}, int frame = 1) {
    return renderScene(s, nimbus::FrameBindings{}, statsOut, aovs, frame);
}

/// A small cumulus layer seen from its side (32x20, direct noise, sigma_s 6, albedo 1, no
/// in-scatter term, transparent background): fast enough for many renders per test.
inline nimbus::SceneDesc smallCumulusLayer() {
    using namespace nimbus;
    SceneDesc s;
    s.camera.position = vec3(0.0f, 2.5f, -9.0f);
    s.camera.lookAt = vec3(0.0f, 2.8f, 0.0f);
    s.camera.width = 32;
    s.camera.height = 20;
    s.camera.fovY = 50.0f;
    s.field.kind = FieldKind::Cumulus;
    s.field.cumulus.bounds = Box{vec3(-6.0f, 1.5f, -6.0f), vec3(6.0f, 4.0f, 6.0f)};
    s.field.cumulus.eval = NoiseEval::Direct;
    s.field.cumulus.baseOctaves = 2;
    s.field.cumulus.detailOctaves = 1;
    s.medium.sigma_s = vec3(6.0f);
    s.medium.sigma_a = vec3(0.0f);
    s.render.step = 0.05f;
    s.render.shadowStep = 0.05f;
    s.render.inScatter = nimbus::InScatter::None;
    s.render.background = nimbus::Background::Transparent;
    return s;
}

/// A homogeneous box [-1, 1]^3 (sigma_s per unit density, albedo 1, g = 0.5) filling a 30 degree
/// view of size x size pixels from z = -6, lit by a sun of irradiance 1 at `elevation` and
/// `azimuth` degrees (azimuth from +z toward +x), transparent background, pixel centres (no
/// jitter, as pathtrace samples them).
inline nimbus::SceneDesc sunlitBox(float sigma_s, int size, float elevation, float azimuth) {
    using namespace nimbus;
    SceneDesc s;
    s.camera.position = vec3(0.0f, 0.0f, -6.0f);
    s.camera.lookAt = vec3(0.0f);
    s.camera.width = size;
    s.camera.height = size;
    s.camera.fovY = 30.0f;
    s.field.kind = FieldKind::Homogeneous;
    s.field.homogeneous.box = Box{vec3(-1.0f), vec3(1.0f)};
    s.medium.sigma_s = vec3(sigma_s);
    s.medium.g = 0.5f;
    const float el = glm::radians(elevation), az = glm::radians(azimuth);
    s.sun.direction = vec3(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
    s.sun.irradiance = vec3(1.0f);
    s.render.inScatter = InScatter::None;
    s.render.background = Background::Transparent;
    s.render.jitter = false;
    return s;
}

/// RMSE of `a` against `ref` over the RMS of `ref`, over RGBA or over the colour alone.
inline double relativeRmse(const nimbus::Framebuffer& a, const nimbus::Framebuffer& ref,
                           bool withAlpha = true) {
    double sq = 0.0, r2 = 0.0;
    for (size_t i = 0; i < ref.rgba.size(); ++i) {
        if (!withAlpha && i % 4 == 3) continue;
        sq += double(a.rgba[i] - ref.rgba[i]) * (a.rgba[i] - ref.rgba[i]);
        r2 += double(ref.rgba[i]) * ref.rgba[i];
    }
    return std::sqrt(sq / r2);
}

/// Mean of the colour channels over the image.
inline double meanRgb(const nimbus::Framebuffer& fb) {
    double sum = 0.0;
    for (size_t i = 0; i < fb.rgba.size(); ++i)
        if (i % 4 != 3) sum += fb.rgba[i];
    return sum / double(fb.width * fb.height * 3);
}
