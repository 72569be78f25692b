/// @file scenes.h
/// @brief The scene fixtures the tests share: tiny scenes with known answers (a homogeneous box,
/// a thin slab, a white furnace) and small cumulus layers fast enough for many renders per test.
///
/// Each fixture is a plain function returning a description the test then adjusts; a test that
/// needs a variant changes the few fields it is about, so the fixture names what is common.
#pragma once

#include <cmath>
#include <string>

#include "core/scene.h"

/// A camera at `position` looking at `target`, `width` x `height` pixels, vertical field of view
/// `fovY` degrees.
inline nimbus::CameraDesc cameraLookingAt(nimbus::vec3 position, nimbus::vec3 target, int width,
                                          int height, float fovY) {
    nimbus::CameraDesc c;
    c.position = position;
    c.lookAt = target;
    c.width = width;
    c.height = height;
    c.fovY = fovY;
    return c;
}

/// Density `density` inside `box`, 0 outside.
inline nimbus::FieldDesc homogeneousField(nimbus::Box box, float density = 1.0f) {
    nimbus::FieldDesc f;
    f.kind = nimbus::FieldKind::Homogeneous;
    f.homogeneous.box = box;
    f.homogeneous.density = density;
    return f;
}

/// Cumulus noise in `bounds`, evaluated directly (no baked volumes: exact and quick to set up),
/// with `baseOctaves` and `detailOctaves` octaves.
inline nimbus::FieldDesc cumulusField(nimbus::Box bounds, int baseOctaves, int detailOctaves) {
    nimbus::FieldDesc f;
    f.kind = nimbus::FieldKind::Cumulus;
    f.cumulus.bounds = bounds;
    f.cumulus.eval = nimbus::NoiseEval::Direct;
    f.cumulus.baseOctaves = baseOctaves;
    f.cumulus.detailOctaves = detailOctaves;
    return f;
}

/// A homogeneous box of density `density` seen by `camera`, with the default medium and
/// render settings. (Tests of exact transmittance also set render.epsilon = 0: no early exit.)
inline nimbus::SceneDesc homogeneousBox(nimbus::Box box, float density,
                                        const nimbus::CameraDesc& camera) {
    nimbus::SceneDesc s;
    s.camera = camera;
    s.field = homogeneousField(box, density);
    return s;
}

/// A homogeneous box [-1, 1]^3 (sigma_s per unit density, albedo 1, g = 0.5) filling a 30 degree
/// view of size x size pixels from z = -6, lit by a sun of irradiance 1 at `elevation` and
/// `azimuth` degrees (azimuth from +z toward +x), transparent background, pixel centres (no
/// jitter, as pathtrace samples them).
inline nimbus::SceneDesc sunlitBox(float sigma_s, int size, float elevation, float azimuth) {
    using namespace nimbus;
    SceneDesc s;
    s.camera = cameraLookingAt(vec3(0.0f, 0.0f, -6.0f), vec3(0.0f), size, size, 30.0f);
    s.field = homogeneousField(Box{vec3(-1.0f), vec3(1.0f)});
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

/// A slab 0.5 thick (z in [0, 0.5], 400 wide) seen face-on through a 4x4, 0.5 degree view from
/// z = -5, sigma_s (0.2, 0.3, 0.4), sigma_a 0.05, Henyey-Greenstein g = 0.3, a sun of irradiance
/// 2 from behind the camera at 30 degrees, no sky, one scattering event: single scattering in
/// closed form (test_pathtrace.cpp), path traced.
inline nimbus::SceneDesc thinSlab() {
    using namespace nimbus;
    SceneDesc s =
        homogeneousBox(Box{vec3(-200.0f, -200.0f, 0.0f), vec3(200.0f, 200.0f, 0.5f)}, 1.0f,
                       cameraLookingAt(vec3(0.0f, 0.0f, -5.0f), vec3(0.0f), 4, 4, 0.5f));
    s.render.integrator = Integrator::PathTrace;
    s.render.epsilon = 0.0f;
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

/// A small cumulus layer seen from its side (32x20, direct noise, sigma_s 6, albedo 1, no
/// in-scatter term, transparent background): fast enough for many renders per test.
inline nimbus::SceneDesc smallCumulusLayer() {
    using namespace nimbus;
    SceneDesc s;
    s.camera = cameraLookingAt(vec3(0.0f, 2.5f, -9.0f), vec3(0.0f, 2.8f, 0.0f), 32, 20, 50.0f);
    s.field = cumulusField(Box{vec3(-6.0f, 1.5f, -6.0f), vec3(6.0f, 4.0f, 6.0f)}, 2, 1);
    s.medium.sigma_s = vec3(6.0f);
    s.medium.sigma_a = vec3(0.0f);
    s.render.step = 0.05f;
    s.render.shadowStep = 0.05f;
    s.render.inScatter = nimbus::InScatter::None;
    s.render.background = nimbus::Background::Transparent;
    // the diffusion grid, named: "auto" would trace 2-8 M photons a frame through this noise
    s.render.multipleScattering = nimbus::MultipleScattering::Grid;
    return s;
}

/// A wider cumulus layer (3 + 2 octaves, 16 km across) seen from below its base through a 60
/// degree, 40x24 view, sigma_s 8, albedo 1, a sun of irradiance 3: enough empty space and
/// cloud for the march tests' skipping and determinism checks.
inline nimbus::SceneDesc cumulusFromBelow() {
    using namespace nimbus;
    SceneDesc s;
    s.camera = cameraLookingAt(vec3(0.0f, 0.5f, -9.0f), vec3(0.0f, 2.2f, 0.0f), 40, 24, 60.0f);
    s.field = cumulusField(Box{vec3(-8.0f, 1.5f, -8.0f), vec3(8.0f, 4.0f, 8.0f)}, 3, 2);
    s.medium.sigma_s = vec3(8.0f);
    s.medium.sigma_a = vec3(0.0f);
    s.sun.direction = glm::normalize(vec3(0.6f, 0.4f, 0.5f));
    s.sun.irradiance = vec3(3.0f);
    s.render.step = 0.08f;
    s.render.shadowStep = 0.1f;
    return s;
}

/// Turns `s` into a white furnace: albedo 1 in every channel (sigma_a 0), no sun, a uniform sky
/// of radiance `sky`. Every light path then returns the sky's radiance, whatever the density:
/// an unbiased integrator must give `sky` wherever it looks.
inline nimbus::SceneDesc whiteFurnace(nimbus::SceneDesc s, nimbus::vec3 sky) {
    s.medium.sigma_a = nimbus::vec3(0.0f);
    s.sun.enabled = false;
    s.sky.kind = nimbus::SkyKind::Uniform;
    s.sky.zenith = sky;
    return s;
}

/// The same kind of scene as scene-file text: a 24x14 cumulus layer (frame 3), a fraction of a
/// second to render through the session or the C ABI; @p extra is appended (more tables).
inline std::string tinySceneText(const std::string& extra = "") {
    return "color_space = \"lin_rec709\"\n"
           "frames = \"3\"\n"
           "[camera]\nposition = [0.0, 0.3, -24.0]\nlook_at = [0.0, 5.5, 0.0]\nfov = 45.0\n"
           "width = 24\nheight = 14\n"
           "[sun]\nelevation = 9.0\nazimuth = -30.0\nintensity = 12.0\n"
           "[medium]\nsigma_s = 12.0\ng = 0.5\n"
           "[field]\nkind = \"cumulus\"\nbounds_min = [-30.0, 1.2, -20.0]\n"
           "bounds_max = [30.0, 5.2, 40.0]\nbase_octaves = 2\ndetail_octaves = 1\n"
           // the default scene's lighting model (what these tests check is not the lighting;
           // "auto" would trace 2-8 M photons a frame here)
           "[render]\nstep = 0.2\nshadow_step = 0.2\nthreads = 2\nmultiple_scattering = "
           "\"grid\"\n" +
           extra;
}
