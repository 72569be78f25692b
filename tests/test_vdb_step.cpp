// The march steps of VDB volumes: with render.step (and render.shadow_step) left at 0 the plan
// takes render.step_voxels (render.shadow_step_voxels) times the finest voxel of the placed
// grids; an explicit step wins; procedural fields keep their 0.05; --explain says which and why.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <glm/gtc/matrix_transform.hpp>
#include <unistd.h>

#include "core/camera.h"
#include "core/fields/grid.h"
#include "core/image_error.h"
#include "core/plan.h"
#include "plugin/host/session.h"
#include "plugin/io/scene_file.h"
#include "plugin/vdb/vdb_writer.h"
#include "test_util.h"

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

const fs::path kData = NIMBUS_SHARED_VDB_DIR;

/// OpenVDB's smoke plume (voxel 0.476) seen from the front, 48x27; `render` is the [render]
/// section's extra lines.
std::string smokeScene(const std::string& render = "") {
    return "[camera]\nposition = [0.0, 15.0, -90.0]\nlook_at = [0.0, 15.0, 0.0]\nfov = 40.0\n"
           "width = 48\nheight = 27\n"
           "[sun]\nelevation = 30.0\nazimuth = 60.0\nintensity = 3.0\n"
           "[medium]\nsigma_s = 1.0\ng = 0.6\n"
           "[field]\nkind = \"vdb\"\npath = \"" +
           (kData / "openvdb_smoke1.vdb").string() +
           "\"\n"
           "[render]\nmultiple_scattering = \"none\"\ninscatter = \"none\"\nthreads = 2\n"
           "background = \"transparent\"\n" +
           render;
}

/// Loads `text`, binds frame 1 and returns its plan.
FramePlan boundPlan(host::Session& s, const std::string& text,
                    const std::vector<std::string>& overrides = {}) {
    const host::Status st = s.loadString(text, "step.toml", overrides);
    EXPECT_TRUE(st.ok()) << st.message;
    const host::Status b = s.bind(1);
    EXPECT_TRUE(b.ok()) << b.message;
    return s.plan(1);
}

/// A float as TOML text that reads back to the same float.
std::string exact(float x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", x);
    return buf;
}

} // namespace

#define REQUIRE_DATA()                                                                             \
    if (!fs::is_directory(kData))                                                                  \
    GTEST_SKIP() << "shared VDB folder " << kData << " is absent: VDB step tests skipped"

TEST(VdbStep, UnsetStepsComeFromTheVoxel) {
    REQUIRE_DATA();
    host::Session s;
    const FramePlan p = boundPlan(s, smokeScene());
    const float voxel = minComponent(gridVoxelSize(s.bindings().grid(0)));
    EXPECT_NEAR(voxel, 0.476f, 0.001f);
    const RenderDesc defaults;
    EXPECT_EQ(p.step, defaults.stepVoxels * voxel);
    EXPECT_EQ(p.shadowStep, defaults.shadowStepVoxels * voxel);
    EXPECT_NE(p.stepDecision.find("render.step_voxels"), std::string::npos) << p.stepDecision;
    EXPECT_NE(p.explain().find("finest voxel"), std::string::npos) << p.explain();
    // step_voxels scales it
    host::Session t;
    const FramePlan q = boundPlan(t, smokeScene("step_voxels = 2\nshadow_step_voxels = 4\n"));
    EXPECT_EQ(q.step, 2.0f * voxel);
    EXPECT_EQ(q.shadowStep, 4.0f * voxel);
}

TEST(VdbStep, AnExplicitStepWins) {
    REQUIRE_DATA();
    host::Session s;
    const FramePlan p = boundPlan(s, smokeScene("step = 0.05\n"));
    EXPECT_EQ(p.step, 0.05f);
    EXPECT_EQ(p.shadowStep,
              RenderDesc{}.shadowStepVoxels * minComponent(gridVoxelSize(s.bindings().grid(0))));
    EXPECT_NE(p.stepDecision.find("0.05 (render.step)"), std::string::npos) << p.stepDecision;
    // and an override too
    host::Session t;
    const FramePlan q = boundPlan(t, smokeScene(), {"render.shadow_step=0.3"});
    EXPECT_EQ(q.shadowStep, 0.3f);
}

TEST(VdbStep, RendersWithTheVoxelStep) {
    // the frame rendered with steps left to the plan is the frame rendered with those steps
    // given explicitly, and differs from the old default of 0.05
    REQUIRE_DATA();
    host::Session a;
    const FramePlan p = boundPlan(a, smokeScene());
    Framebuffer fa, fb, fc;
    RenderStats sa, sb, sc;
    ASSERT_TRUE(a.render(1, fa, sa).ok());
    host::Session b;
    boundPlan(
        b, smokeScene("step = " + exact(p.step) + "\nshadow_step = " + exact(p.shadowStep) + "\n"));
    // the text form of the steps must read back to the same floats
    ASSERT_EQ(b.scene().render.step, p.step);
    ASSERT_EQ(b.scene().render.shadowStep, p.shadowStep);
    ASSERT_TRUE(b.render(1, fb, sb).ok());
    EXPECT_EQ(fa.rgba, fb.rgba);
    EXPECT_EQ(sa.lookups(), sb.lookups());
    host::Session c;
    boundPlan(c, smokeScene("step = 0.05\nshadow_step = 0.05\n"));
    ASSERT_TRUE(c.render(1, fc, sc).ok());
    // about 10x the lookups at a tenth of a voxel, and the image within 1% of it
    EXPECT_GT(sc.lookups(), 5 * sa.lookups());
    EXPECT_LT(imageError(fa, fc).relative(), 0.02);
}

TEST(VdbStep, ProceduralFieldsKeepTheirDefault) {
    SceneDesc s; // the procedural cumulus, render.step and shadow_step 0
    const FramePlan p = planFrame(s, 1);
    EXPECT_EQ(p.step, kDefaultStep);
    EXPECT_EQ(p.shadowStep, kDefaultStep);
    EXPECT_NE(p.stepDecision.find("procedural"), std::string::npos) << p.stepDecision;
    // scaled as converge scales them: the default made explicit
    io::scaleSteps(s, 0.5);
    EXPECT_EQ(s.render.step, float(double(kDefaultStep) * 0.5));
    EXPECT_EQ(planFrame(s, 1).step, s.render.step);
}

TEST(VdbStep, ScalingLeavesTheVoxelRuleInPlace) {
    REQUIRE_DATA();
    host::Session s;
    boundPlan(s, smokeScene());
    SceneDesc scaled = s.scene();
    io::scaleSteps(scaled, 0.25);
    EXPECT_EQ(scaled.render.step, 0.0f);
    EXPECT_EQ(scaled.render.stepVoxels, float(double(RenderDesc{}.stepVoxels) * 0.25));
    const FramePlan p = planFrame(scaled, 1, s.bindings());
    EXPECT_EQ(p.step, scaled.render.stepVoxels * minComponent(gridVoxelSize(s.bindings().grid(0))));
}

TEST(VdbStep, InstanceScaleShrinksTheVoxel) {
    REQUIRE_DATA();
    host::Session s;
    const FramePlan p = boundPlan(
        s, smokeScene() + "[[instance]]\nvolume = \"field\"\nscale = [0.5, 0.5, 0.5]\n"
                          "[[instance]]\nvolume = \"field\"\ntranslate = [40.0, 0.0, 0.0]\n");
    const float voxel = minComponent(gridVoxelSize(s.bindings().grid(0)));
    EXPECT_EQ(finestVoxel(s.scene(), s.bindings()), 0.5f * voxel);
    EXPECT_EQ(p.step, RenderDesc{}.stepVoxels * 0.5f * voxel);
}

TEST(VdbStep, ExplainSaysTheRuleWithoutReadingGrids) {
    REQUIRE_DATA();
    const fs::path dir = fs::temp_directory_path() / ("nimbus_vdbstep_" + std::to_string(getpid()));
    fs::create_directories(dir);
    const fs::path scene = dir / "step.toml";
    {
        std::ofstream f(scene);
        f << smokeScene();
    }
    const CliRun r = runNimbus("render " + scene.string() + " --explain");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("march steps: primary 1 x the finest voxel (render.step_voxels"),
              std::string::npos)
        << r.output;
    fs::remove_all(dir);
}

// Steps across a VDB cloud's edge (render.step_tau): a slab of voxels of density 1 behind four
// voxels of density 0 (active, so the field's box begins there), each voxel 5 mean free paths
// deep, sunlit from the camera's side, single scattering. At a step of one voxel a camera step
// that crosses the slab's face often has its sample in the empty voxels, and a shadow step that
// leaves a point near the face its sample outside it: split only by its own sample (density 0)
// such a step stays whole, its optical depth all or nothing with the jitter. The split looks at
// the samples on both sides too (kern::splitDensity): the image comes within 6% of a march at
// a fiftieth of a voxel with whole steps (measured 4.5%; 44.2% when the test takes the step's
// own sample alone, 68.7% with whole steps).
TEST(VdbStep, StepsAcrossACloudsFaceAreSplit) {
    const fs::path dir = fs::temp_directory_path() / ("nimbus_vdbface_" + std::to_string(getpid()));
    fs::create_directories(dir);
    vdb::VdbGridSpec g;
    g.worldFromIndex = glm::scale(glm::dmat4(1.0), glm::dvec3(0.1));
    for (int k = 0; k < 12; ++k)
        for (int j = 0; j < 40; ++j)
            for (int i = 0; i < 40; ++i)
                g.voxels.push_back({ivec3(i, j, k), k < 4 ? 0.0 : 1.0, true});
    vdb::writeVdbGrids((dir / "slab.vdb").string(), {g});
    const std::string scene =
        "[camera]\nposition = [2.13, 1.87, -3.0]\nlook_at = [1.95, 2.05, 1.0]\nfov = 12.0\n"
        "width = 32\nheight = 32\n"
        "[sun]\ndirection = [0.5, 0.3, -0.8]\nirradiance = 1.0\n"
        "[sky]\nkind = \"none\"\n"
        "[medium]\nsigma_s = 50.0\nphase = \"isotropic\"\n"
        "[field]\nkind = \"vdb\"\npath = \"" +
        (dir / "slab.vdb").string() +
        "\"\n"
        "[render]\nmultiple_scattering = \"none\"\ninscatter = \"none\"\noctaves = 1\n"
        "background = \"transparent\"\nshadow_growth = 0.0\nepsilon = 0.0001\nthreads = 2\n";
    auto render = [&](const std::vector<std::string>& set) {
        host::Session s;
        boundPlan(s, scene, set);
        Framebuffer fb;
        RenderStats st;
        EXPECT_TRUE(s.render(1, fb, st).ok());
        return fb;
    };
    const Framebuffer fine =
        render({"render.step_voxels=0.02", "render.shadow_step_voxels=0.02", "render.step_tau=0"});
    const Framebuffer split = render({}); // one voxel a step, step_tau 0.5 (the defaults)
    const Framebuffer whole = render({"render.step_tau=0"});
    const ImageError e = imageError(split, fine), w = imageError(whole, fine);
    std::printf("[ step_tau ] a VDB slab's face inside a step of 5 mean free paths: split %.2f%%, "
                "whole %.2f%% (%zu pixels)\n",
                100.0 * e.relative(), 100.0 * w.relative(), e.pixels);
    EXPECT_GT(e.pixels, 32u * 32u * 9 / 10);
    EXPECT_GT(w.relative(), 0.2); // whole steps are far off: the test can tell
    EXPECT_LT(e.relative(), 0.06);
    fs::remove_all(dir);
}

TEST(VdbStep, AThinSheetBetweenTwoSamplesIsSplit) {
    // A sheet one voxel thick (its trilinear density a hat two voxels wide) seen face-on
    // through steps of four voxels, in a field whose box reaches well beyond it (a faint voxel
    // at two corners): a step's sample lands in the hat half the time, and its neighbours four
    // voxels away never do, so the density test alone leaves the other half whole at density
    // 0 and the sheet looks half as opaque as it is. render.step_tau's test also takes the
    // majorant of the cells a camera step reaches into (MarchContext::stepMajorant), which
    // splits those steps too. Closed form: alpha = 1 - exp(-sigma_t rho voxel / cos).
    const fs::path dir =
        fs::temp_directory_path() / ("nimbus_vdbsheet_" + std::to_string(getpid()));
    fs::create_directories(dir);
    const double voxel = 0.1, rho = 1.0;
    const float sigmaS = 20.0f;
    vdb::VdbGridSpec g;
    g.worldFromIndex = glm::scale(glm::dmat4(1.0), glm::dvec3(voxel));
    for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i) g.voxels.push_back({ivec3(i, j, 20), rho, true});
    g.voxels.push_back({ivec3(0, 0, 0), 1e-3, true});
    g.voxels.push_back({ivec3(39, 39, 40), 1e-3, true});
    vdb::writeVdbGrids((dir / "sheet.vdb").string(), {g});
    const std::string scene =
        "[camera]\nposition = [1.95, 1.95, -3.0]\nlook_at = [1.95, 1.95, 2.0]\nfov = 10.0\n"
        "width = 32\nheight = 32\n"
        "[sun]\ndirection = [0.0, 0.0, 1.0]\nirradiance = 0.0\n"
        "[sky]\nkind = \"none\"\n"
        "[medium]\nsigma_s = " +
        std::to_string(sigmaS) +
        "\nphase = \"isotropic\"\n"
        "[field]\nkind = \"vdb\"\npath = \"" +
        (dir / "sheet.vdb").string() +
        "\"\n"
        "[render]\nmultiple_scattering = \"none\"\ninscatter = \"none\"\noctaves = 1\n"
        "background = \"transparent\"\nstep_voxels = 4.0\nthreads = 2\n";
    const Camera cam = [&] {
        host::Session s;
        boundPlan(s, scene);
        return Camera(s.scene().camera);
    }();
    // the mean over the image of alpha / its closed form, and the density lookups
    auto alphaRatio = [&](const std::vector<std::string>& set, std::uint64_t& lookups) {
        host::Session s;
        boundPlan(s, scene, set);
        Framebuffer fb;
        RenderStats st;
        EXPECT_TRUE(s.render(1, fb, st).ok());
        lookups = st.lookups();
        double sum = 0.0;
        for (int y = 0; y < fb.height; ++y)
            for (int x = 0; x < fb.width; ++x) {
                const float cosine = cam.generate(x + 0.5f, y + 0.5f).d.z;
                const double want = 1.0 - std::exp(-double(sigmaS) * rho * voxel / cosine);
                sum += fb.rgba[4 * (size_t(y) * fb.width + x) + 3] / want;
            }
        return sum / (fb.width * fb.height);
    };
    std::uint64_t splitLookups = 0, wholeLookups = 0;
    const double split = alphaRatio({}, splitLookups); // step_tau 0.5, the default
    const double whole = alphaRatio({"render.step_tau=0"}, wholeLookups);
    std::printf("[ step_tau ] a sheet of 2 mean free paths between samples 4 voxels apart: "
                "alpha / closed form split %.3f (%llu lookups), whole %.3f (%llu)\n",
                split, (unsigned long long)splitLookups, whole, (unsigned long long)wholeLookups);
    EXPECT_LT(whole, 0.7); // whole steps miss the sheet half the time: the test can tell
    EXPECT_NEAR(split, 1.0, 0.03);
    fs::remove_all(dir);
}
