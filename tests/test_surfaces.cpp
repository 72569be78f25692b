// Opaque surfaces through Embree (plugin/geom): a ground plane and OBJ meshes, lit by the sun
// through the clouds (cloud shadows), holdouts, and both integrators against closed forms.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "core/render.h"
#include "render_util.h"
#include "plugin/geom/embree_geometry.h"
#include "test_util.h"

using namespace nimbus;

namespace {

constexpr float kPi = 3.14159265358979f;

/// Camera looking down at a grey ground at y = 0, sun at 60 degrees elevation, no sky; a thin
/// homogeneous cloud slab far above the left half of the view shadows the ground.
SceneDesc groundScene() {
    SceneDesc s;
    s.camera.position = vec3(0.0f, 10.0f, 0.0f);
    s.camera.lookAt = vec3(0.0f, 0.0f, 0.01f);
    s.camera.up = vec3(0.0f, 0.0f, 1.0f);
    s.camera.width = 16;
    s.camera.height = 8;
    s.camera.fovY = 20.0f;
    const float el = glm::radians(60.0f);
    s.sun.direction = vec3(0.0f, std::sin(el), std::cos(el));
    s.sun.irradiance = vec3(2.0f, 1.5f, 1.0f);
    s.sky.kind = SkyKind::None;
    s.field.kind = FieldKind::Homogeneous;
    // the sun ray from a ground point x < 0 crosses this slab (y in [40, 41]) over the slab
    // thickness / sin(elevation)
    s.field.homogeneous.box = Box{vec3(-500.0f, 40.0f, -500.0f), vec3(0.0f, 41.0f, 500.0f)};
    s.field.homogeneous.density = 1.0f;
    s.medium.sigma_s = vec3(0.5f);
    s.medium.sigma_a = vec3(0.0f);
    s.ground.enabled = true;
    s.ground.material.albedo = vec3(0.5f, 0.4f, 0.3f);
    s.render.background = Background::Transparent;
    s.render.step = 0.02f;
    s.render.shadowStep = 0.02f;
    s.render.shadowGrowth = 0.0f;
    s.render.jitter = false;
    s.render.threads = 2;
    return s;
}

/// Renders s with its surfaces (Embree geometry built from s as it is now).
Framebuffer renderWithSurfaces(const SceneDesc& s) {
    std::vector<std::string> w;
    FrameBindings b;
    b.geometry = geom::makeEmbreeGeometry(s, "", w);
    return renderScene(s, b);
}

vec3 px(const Framebuffer& fb, int x, int y) {
    const size_t i = size_t(y) * fb.width + x;
    return vec3(fb.rgba[4 * i], fb.rgba[4 * i + 1], fb.rgba[4 * i + 2]);
}
float alpha(const Framebuffer& fb, int x, int y) {
    return fb.rgba[4 * (size_t(y) * fb.width + x) + 3];
}

} // namespace

TEST(Surfaces, LitGroundAndCloudShadowMatchTheClosedForm) {
    SceneDesc s = groundScene();
    const Framebuffer fb = renderWithSurfaces(s);
    const float cosSun = s.sun.direction.y;
    const vec3 lit = s.ground.material.albedo / kPi * s.sun.irradiance * cosSun;
    const vec3 shadowed = lit * std::exp(-0.5f / cosSun); // sigma_t * 1 / sin(elevation)
    // the camera looks straight down, image x grows toward -x in the world (right = fwd x up):
    // find which half is shadowed from the pixels themselves, then check both values
    const vec3 a = px(fb, 1, 4), b = px(fb, 14, 4);
    const vec3 bright = a.x > b.x ? a : b, dark = a.x > b.x ? b : a;
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(bright[c], lit[c], 1e-3f * lit[c]) << "channel " << c;
        EXPECT_NEAR(dark[c], shadowed[c], 0.01f * shadowed[c]) << "channel " << c;
    }
    EXPECT_EQ(alpha(fb, 1, 4), 1.0f);
}

TEST(Surfaces, PathTracerAgreesWithTheClosedFormOnTheGround) {
    SceneDesc s = groundScene();
    s.render.integrator = Integrator::PathTrace;
    s.render.spp = 256;
    s.render.maxDepth = 1; // direct light only: the slab's in-scattering onto the ground is off
    s.camera.width = 8;
    s.camera.height = 4;
    const Framebuffer fb = renderWithSurfaces(s);
    const float cosSun = s.sun.direction.y;
    const vec3 lit = s.ground.material.albedo / kPi * s.sun.irradiance * cosSun;
    const vec3 shadowed = lit * std::exp(-0.5f / cosSun);
    const vec3 a = px(fb, 0, 2), b = px(fb, 7, 2);
    const vec3 bright = a.x > b.x ? a : b, dark = a.x > b.x ? b : a;
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(bright[c], lit[c], 1e-3f * lit[c]);
        // ratio tracking through a homogeneous slab with a tight majorant is exact up to RR
        EXPECT_NEAR(dark[c], shadowed[c], 0.05f * shadowed[c]);
    }
}

TEST(Surfaces, SkyLightOnTheGroundIsAlbedoTimesRadianceForBothIntegrators) {
    // uniform sky L, no sun, no cloud: radiance from a diffuse plane = albedo * L (the
    // hemisphere's cosine-weighted integral is pi L); pathtrace also bounces once more (the
    // sky below the horizon is hidden by the plane, so the answer is the same)
    SceneDesc s = groundScene();
    s.sun.enabled = false;
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(0.3f, 0.6f, 0.9f);
    s.field.homogeneous.density = 0.0f;
    const Framebuffer m = renderWithSurfaces(s);
    const vec3 expect = s.ground.material.albedo * s.sky.zenith;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(px(m, 8, 4)[c], expect[c], 0.005f * expect[c]);
    s.render.integrator = Integrator::PathTrace;
    s.render.spp = 1024;
    s.camera.width = 2;
    s.camera.height = 2;
    const Framebuffer p = renderWithSurfaces(s);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(px(p, 1, 1)[c], expect[c], 0.03f * expect[c]);
}

TEST(Surfaces, HoldoutHasAlphaOfTheCloudInFrontOnly) {
    SceneDesc s = groundScene();
    s.ground.material.holdout = true;
    // a cloud between camera and ground over the middle of the view
    s.field.homogeneous.box = Box{vec3(-0.5f, 4.0f, -500.0f), vec3(0.5f, 5.0f, 500.0f)};
    s.render.background = Background::Sky; // a holdout wins over the background
    const Framebuffer fb = renderWithSurfaces(s);
    // ground only: nothing at all
    EXPECT_EQ(alpha(fb, 0, 4), 0.0f);
    EXPECT_EQ(px(fb, 0, 4), vec3(0.0f));
    // cloud in front: alpha = 1 - T of the 1-unit slab, colour of the cloud alone
    const float T = std::exp(-0.5f);
    EXPECT_NEAR(alpha(fb, 8, 4), 1.0f - T, 2e-3f);
    EXPECT_GT(px(fb, 8, 4).x, 0.0f);
}

TEST(Surfaces, ObjMeshCastsAShadowOnTheGround) {
    const auto dir = std::filesystem::temp_directory_path() / "nimbus_test_mesh";
    std::filesystem::create_directories(dir);
    const auto obj = dir / "roof.obj";
    {
        // a horizontal quad at y = 2 above the x < 0 half: a roof between the sun and the ground
        std::ofstream o(obj);
        o << "# a quad\nv -50 2 -50\nv 0 2 -50\nv 0 2 50\nv -50 2 50\nf 1 2 3 4\n";
    }
    SceneDesc s = groundScene();
    s.field.homogeneous.density = 0.0f;
    MeshDesc m;
    m.path = obj.string();
    s.meshes.push_back(m);
    s.camera.position = vec3(0.0f, 1.0f, 0.0f); // under the roof's height: sees the ground
    s.camera.lookAt = vec3(0.0f, 0.0f, 0.01f);
    s.camera.fovY = 60.0f;
    const Framebuffer fb = renderWithSurfaces(s);
    const vec3 a = px(fb, 0, 4), b = px(fb, 15, 4);
    const float cosSun = s.sun.direction.y;
    const vec3 lit = s.ground.material.albedo / kPi * s.sun.irradiance * cosSun;
    // one side in full sun, the other in the roof's shadow (no sky: black)
    EXPECT_NEAR(std::max(a.x, b.x), lit.x, 1e-3f * lit.x);
    EXPECT_EQ(std::min(a.x, b.x), 0.0f);
    std::filesystem::remove_all(dir);
}

TEST(Surfaces, BadObjFilesGiveErrorsNamingTheFile) {
    const auto dir = std::filesystem::temp_directory_path() / "nimbus_test_badobj";
    std::filesystem::create_directories(dir);
    std::vector<std::string> w;
    MeshDesc m;
    m.path = (dir / "missing.obj").string();
    try {
        geom::loadObjMesh(m, "", w);
        FAIL() << "a missing file must throw";
    } catch (const geom::GeometryError& e) {
        EXPECT_TRUE(contains(e.what(), "missing.obj: mesh file not found"));
    }
    const auto write = [&](const char* name, const char* text) {
        std::ofstream(dir / name) << text;
        m.path = (dir / name).string();
    };
    write("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    try {
        geom::loadObjMesh(m, "", w);
        FAIL() << "an index out of range must throw";
    } catch (const geom::GeometryError& e) {
        EXPECT_TRUE(contains(e.what(), "range.obj"));
    }
    write("inf.obj", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n");
    EXPECT_THROW(geom::loadObjMesh(m, "", w), geom::GeometryError);
    write("empty.obj", "# nothing\nv 0 0 0\n");
    try {
        geom::loadObjMesh(m, "", w);
        FAIL() << "a file without faces must throw";
    } catch (const geom::GeometryError& e) {
        EXPECT_TRUE(contains(e.what(), "holds no faces"));
    }
    std::filesystem::remove_all(dir);
}
