// Far from the origin (core/rebase.h): a volume 1e7 units out renders the image it renders at
// the origin, because the frame is translated in double before anything turns to float; where
// the scene cannot be translated exactly the plan keeps its warning and says why.
#include <gtest/gtest.h>

#include <filesystem>

#include <glm/gtc/matrix_transform.hpp>
#include <unistd.h>

#include "core/rebase.h"
#include "plugin/vdb/vdb_field.h"
#include "plugin/vdb/vdb_writer.h"
#include "render_util.h"

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

/// A smooth blob of 24 x 16 x 12 voxels of size 0.1 whose index origin lies at `at` (double).
vdb::VdbGridSpec blobAt(glm::dvec3 at) {
    vdb::VdbGridSpec g;
    g.worldFromIndex =
        glm::translate(glm::dmat4(1.0), at) * glm::scale(glm::dmat4(1.0), glm::dvec3(0.1));
    for (int k = 0; k < 12; ++k)
        for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 24; ++i) {
                const double x = (i - 11.5) / 10.0, y = (j - 7.5) / 6.0, z = (k - 5.5) / 4.5;
                const double v = 1.0 - (x * x + y * y + z * z);
                if (v > 0.0) g.voxels.push_back({ivec3(i, j, k), 2.0 * v, true});
            }
    return g;
}

/// The camera 3.5 units in front of the blob at `dx` along x; every coordinate is exact in float
/// at 1e7 (whole units in x), so the far and near scenes differ only by the translation.
SceneDesc sceneAt(double dx) {
    SceneDesc s;
    s.field.kind = FieldKind::Vdb;
    s.camera.position = vec3(float(dx + 1.0), 2.5f, 0.0f);
    s.camera.lookAt = vec3(float(dx + 1.0), 2.75f, 3.5f);
    s.camera.fovY = 30.0f;
    s.camera.width = 48;
    s.camera.height = 32;
    s.sun.direction = glm::normalize(vec3(0.3f, 0.8f, -0.5f));
    s.sun.irradiance = vec3(2.0f);
    s.medium.sigma_s = vec3(4.0f);
    s.medium.sigma_a = vec3(0.2f);
    s.render.background = Background::Transparent;
    s.render.step = 0.02f;
    s.render.shadowStep = 0.02f;
    s.render.shadowGrowth = 0.0f;
    return s;
}

struct Far : testing::Test {
    fs::path dir = fs::temp_directory_path() / ("nimbus_rebase_" + std::to_string(getpid()));
    void SetUp() override { fs::create_directories(dir); }
    void TearDown() override { fs::remove_all(dir); }

    /// The blob at (dx + 0, 2, 3) rendered by `integrator`; the frame's plan in `plan`.
    Framebuffer render(double dx, Integrator integrator, FramePlan* plan = nullptr) {
        const std::string path = (dir / ("blob" + std::to_string(dx) + ".vdb")).string();
        vdb::writeVdbGrids(path, {blobAt(glm::dvec3(dx, 2.0, 3.0))});
        SceneDesc s = sceneAt(dx);
        s.field.vdb.path = path;
        s.render.integrator = integrator;
        s.render.spp = 16;
        std::vector<std::string> warnings;
        FrameBindings b;
        b.grids = {vdb::bindVdbField(s.field, "", 1, warnings)};
        if (plan) *plan = Renderer(s).plan(1, b);
        return renderScene(s, b);
    }
};

double coverage(const Framebuffer& fb) {
    int n = 0;
    for (size_t i = 3; i < fb.rgba.size(); i += 4) n += fb.rgba[i] > 0.1f;
    return double(n) / double(fb.rgba.size() / 4);
}

} // namespace

TEST_F(Far, AVdbTenMillionUnitsOutRendersTheImageItRendersAtTheOrigin) {
    FramePlan nearPlan, farPlan;
    const Framebuffer near = render(0.0, Integrator::March, &nearPlan);
    const Framebuffer far = render(1e7, Integrator::March, &farPlan);
    ASSERT_GT(coverage(near), 0.1) << "the blob must fill part of the frame";
    EXPECT_FALSE(nearPlan.rebased);
    ASSERT_TRUE(farPlan.rebased);
    EXPECT_NEAR(farPlan.renderOrigin.x, 1e7 + 1.2, 0.5);
    EXPECT_TRUE(farPlan.warnings.empty()) << farPlan.warnings.front();
    EXPECT_NE(farPlan.explain().find("rendered relative to"), std::string::npos);
    // without the translation this was 0.43 (nimbus stress, camera/far-1e+07/march)
    EXPECT_LT(relativeRmse(far, near), 1e-3);
}

TEST_F(Far, PathTracedFarAwayMatchesTheOriginWithinItsNoise) {
    const Framebuffer near = render(0.0, Integrator::PathTrace);
    const Framebuffer far = render(1e7, Integrator::PathTrace);
    // the same random streams: paths part only where a float differs in its last bit, so the
    // two estimates agree far inside the noise of 16 samples (0.48 before the translation)
    EXPECT_LT(relativeRmse(far, near), 0.05);
    EXPECT_NEAR(meanRgb(far), meanRgb(near), 0.02 * meanRgb(near));
}

TEST(Rebase, AHomogeneousBoxFarOutIsTranslatedAndStillRendersTheSameImage) {
    SceneDesc s;
    s.field.kind = FieldKind::Homogeneous;
    s.field.homogeneous.density = 1.0f;
    s.camera.width = 32;
    s.camera.height = 24;
    s.render.background = Background::Transparent;
    s.render.step = 0.05f;
    const Framebuffer near = renderScene(s);
    const vec3 d(-3e6f, 5e6f, 2e6f);
    s.field.homogeneous.box = Box{s.field.homogeneous.box.lo + d, s.field.homogeneous.box.hi + d};
    s.camera.position += d;
    s.camera.lookAt += d;
    const FramePlan p = Renderer(s).plan(1, FrameBindings{});
    EXPECT_TRUE(p.rebased);
    EXPECT_LT(relativeRmse(renderScene(s), near), 1e-3);
}

TEST(Rebase, NearTheOriginNothingMovesAndSurfacesKeepTheWarningWithTheReason) {
    SceneDesc s;
    s.field.kind = FieldKind::Homogeneous;
    EXPECT_FALSE(chooseRebase(s, FrameBindings{}, 0.05).active);
    const vec3 d(1e7f, 0.0f, 0.0f);
    s.field.homogeneous.box = Box{s.field.homogeneous.box.lo + d, s.field.homogeneous.box.hi + d};
    s.camera.position += d;
    s.camera.lookAt += d;
    EXPECT_TRUE(chooseRebase(s, FrameBindings{}, 0.05).active);
    s.ground.enabled = true;
    const Rebase r = chooseRebase(s, FrameBindings{}, 0.05);
    EXPECT_FALSE(r.active);
    EXPECT_NE(r.blocked.find("surfaces"), std::string::npos);
    const FramePlan p = Renderer(s).plan(1, FrameBindings{});
    EXPECT_FALSE(p.rebased);
    ASSERT_FALSE(p.warnings.empty());
    bool said = false;
    for (const std::string& w : p.warnings)
        said |= w.find("not translated automatically") != std::string::npos;
    EXPECT_TRUE(said) << p.explain();
    // procedural fields evaluate their noise at world positions: never translated
    s = SceneDesc{};
    s.field.kind = FieldKind::Cumulus;
    s.camera.position += d;
    EXPECT_FALSE(chooseRebase(s, FrameBindings{}, 0.05).active);
}
