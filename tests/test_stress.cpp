// The stress suite (issue 17): `nimbus stress --quick` as a real CLI run, and the two checks of
// it that make claims about the renderer's physics tested directly: scale invariance (the world
// scaled by k and the coefficients by 1/k render the same image) and the white furnace (an
// albedo-1 medium under a uniform sky of 1 returns at most 1).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/media/phase.h"
#include "core/sampler.h"
#include "core/tracking/tracking.h"
#include "plugin/cli/stress_checks.h"
#include "render_util.h"
#include "test_util.h"

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

/// The homogeneous cube [-1, 1]^3 (sigma_s 2, g 0.8) lit by a sun from the side, seen from -z
/// on a transparent background: the image of scale invariance.
SceneDesc litCube(Integrator integrator) {
    SceneDesc s =
        homogeneousBox(Box{vec3(-1.0f), vec3(1.0f)}, 1.0f,
                       cameraLookingAt(vec3(0.0f, 0.0f, -4.0f), vec3(0.0f), 16, 9, 45.0f));
    s.medium.sigma_s = vec3(2.0f);
    s.medium.sigma_a = vec3(0.1f);
    s.sun.direction = glm::normalize(vec3(0.5f, 0.6f, 0.4f));
    s.sun.irradiance = vec3(3.0f);
    s.render.integrator = integrator;
    s.render.multipleScattering = MultipleScattering::None;
    s.render.step = s.render.shadowStep = 0.05f;
    s.render.background = Background::Transparent;
    s.render.spp = 64;
    return s;
}

/// The lit cube with photons handing off to the diffusion grid after 8 scatterings.
SceneDesc photonCube(float sigma_s, float sigma_a) {
    SceneDesc s = litCube(Integrator::March);
    s.medium.sigma_s = vec3(sigma_s);
    s.medium.sigma_a = vec3(sigma_a);
    s.render.multipleScattering = MultipleScattering::Photons;
    s.render.photons = 20000;
    s.render.photonBounces = 8;
    s.render.maxDepth = 1 << 20;
    s.render.lightVolumeCell = 0.25f;
    return s;
}

} // namespace

TEST(StressChecks, MarchIsScaleInvariantFrom1e4To1e6) {
    const SceneDesc s = litCube(Integrator::March);
    const Framebuffer ref = renderScene(s);
    ASSERT_GT(meanRgb(ref), 0.01);
    for (double k : {1e-4, 1e-2, 1e3, 1e6}) {
        const Framebuffer f = renderScene(stress::scaleWorld(s, k));
        const double d = stress::relativeDifference(f, ref);
        EXPECT_LT(d, 2e-3) << "k = " << k;
        RecordProperty("diff_k" + std::to_string(int(std::log10(k))), std::to_string(d));
    }
}

TEST(StressChecks, ScaleInvarianceCheckSeesAWrongScaling) {
    // the check has power: sigma scaled by 1/k^2 instead of 1/k changes every optical depth
    const SceneDesc s = litCube(Integrator::March);
    const Framebuffer ref = renderScene(s);
    SceneDesc wrong = stress::scaleWorld(s, 10.0);
    wrong.medium.sigma_s /= 10.0f;
    wrong.medium.sigma_a /= 10.0f;
    EXPECT_GT(stress::relativeDifference(renderScene(wrong), ref), 0.05);
    // and a camera left unscaled
    SceneDesc moved = stress::scaleWorld(s, 10.0);
    moved.camera.position = s.camera.position;
    EXPECT_GT(stress::relativeDifference(renderScene(moved), ref), 0.05);
}

TEST(StressChecks, PathtraceIsScaleInvariantInTheMean) {
    // pathtrace: the same seed, but the paths' floats differ once scaled: compare the image
    // means (Z-test over 4 seeds each)
    SceneDesc s = litCube(Integrator::PathTrace);
    s.render.spp = 32;
    const Estimate a = renderSeeds(s, 4);
    const Estimate b = renderSeeds(stress::scaleWorld(s, 1e4), 4, FrameValues::Rgb, 5000);
    double ma = 0.0, mb = 0.0, va = 0.0, vb = 0.0;
    for (size_t i = 0; i < a.mean.size(); ++i) {
        ma += a.mean[i];
        mb += b.mean[i];
        va += a.variance[i] / a.n;
        vb += b.variance[i] / b.n;
    }
    const double z = (ma - mb) / std::sqrt(va + vb);
    EXPECT_LT(std::abs(z), 3.5) << ma << " vs " << mb;
    EXPECT_GT(ma, 0.01 * double(a.mean.size()));
}

TEST(StressChecks, WhiteFurnaceIsBoundedForEveryMethodInAThickCube) {
    // 2,000 mean free paths, albedo 1, uniform sky of 1: at most 1 + noise everywhere
    for (int m = 0; m < 4; ++m) {
        SceneDesc s = whiteFurnace(
            homogeneousBox(Box{vec3(-1.0f), vec3(1.0f)}, 1.0f,
                           cameraLookingAt(vec3(0.0f, 0.0f, -4.0f), vec3(0.0f), 12, 8, 40.0f)),
            vec3(1.0f));
        s.medium.sigma_s = vec3(1000.0f);
        s.render.background = Background::Sky;
        s.render.multipleScattering = MultipleScattering::None;
        if (m == 1) {
            s.render.integrator = Integrator::PathTrace;
            s.render.spp = 64;
            s.render.maxDepth = 1 << 30;
        }
        if (m == 2) s.render.multipleScattering = MultipleScattering::Grid;
        if (m == 3) s.render.shadow = ShadowMethod::Volume;
        const Framebuffer fb = renderScene(s);
        const stress::Furnace f = stress::furnace(fb);
        EXPECT_TRUE(f.bounded(1.0)) << "method " << m << ": mean " << f.mean << " se " << f.se;
        EXPECT_GT(f.mean, 0.5) << "method " << m;
        if (m == 1) EXPECT_NEAR(f.mean, 1.0, 4.0 * f.se + 1e-3); // unbiased: exactly the sky
    }
}

TEST(StressChecks, WhiteFurnaceCheckSeesEnergyGain) {
    // a sun on top of the uniform sky adds light: the furnace must then exceed 1
    SceneDesc s = whiteFurnace(
        homogeneousBox(Box{vec3(-1.0f), vec3(1.0f)}, 1.0f,
                       cameraLookingAt(vec3(0.0f, 0.0f, -4.0f), vec3(0.0f), 12, 8, 40.0f)),
        vec3(1.0f));
    s.render.background = Background::Sky;
    s.sun.enabled = true;
    s.sun.irradiance = vec3(2.0f);
    s.sun.direction = vec3(0.0f, 0.0f, -1.0f); // from behind the cube toward the camera
    s.medium.sigma_s = vec3(1.0f);
    EXPECT_FALSE(stress::furnace(renderScene(s)).bounded(1.0));
}

TEST(StressChecks, FrameCheckCountsBadValues) {
    Framebuffer fb;
    fb.resize(2, 1, AovSet{true, true});
    EXPECT_TRUE(stress::checkFrame(fb).ok());
    fb.rgba[0] = NAN;
    fb.rgba[7] = 1.5f;           // alpha
    fb.transmittance[2] = -0.5f; // negative and outside
    fb.depth[1] = INFINITY;
    const stress::FrameCheck c = stress::checkFrame(fb);
    EXPECT_EQ(c.nonFinite, 2u);
    EXPECT_EQ(c.alphaOutside, 1u);
    EXPECT_EQ(c.transOutside, 1u);
    EXPECT_EQ(c.negative, 1u);
    EXPECT_FALSE(c.ok());
}

TEST(StressCli, QuickRunPassesAndListsEveryCase) {
    const fs::path csv =
        fs::temp_directory_path() / ("nimbus_stress_" + std::to_string(getpid()) + ".csv");
    const CliRun r = runNimbus("stress --quick --csv " + csv.string());
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "summary: "));
    // every case is a CSV row with a verdict, and the summary counts them all
    std::ifstream in(csv);
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "case,verdict,seconds,figures,notes");
    std::map<std::string, int> verdicts;
    int rows = 0;
    std::vector<std::string> groups;
    while (std::getline(in, line)) {
        ++rows;
        const size_t a = line.find("\","), b = line.find(',', a + 2);
        ASSERT_NE(a, std::string::npos) << line;
        const std::string name = line.substr(1, a - 1), verdict = line.substr(a + 2, b - a - 2);
        ++verdicts[verdict];
        EXPECT_TRUE(verdict == "PASS" || verdict == "DEGRADED") << name << ": " << verdict;
        // printed in the table too
        EXPECT_TRUE(contains(r.output, name)) << name;
        groups.push_back(name.substr(0, name.find('/')));
    }
    EXPECT_GT(rows, 50);
    EXPECT_EQ(verdicts["FAIL"], 0);
    // photon frames' energy checks average over seeds (their noise is shared by the pixels)
    EXPECT_TRUE(contains(r.output, "seeds=5"));
    std::ostringstream summary;
    summary << "summary: " << rows << " cases: " << verdicts["PASS"] << " PASS, "
            << verdicts["DEGRADED"] << " DEGRADED, 0 FAIL";
    EXPECT_TRUE(contains(r.output, summary.str()));
    // every group of the list is in the quick run
    for (const char* g : {"field", "tau", "density", "stiff", "phase", "sun", "camera", "scale",
                          "step", "order", "transmittance", "voxels", "frames"})
        EXPECT_NE(std::find(groups.begin(), groups.end(), g), groups.end()) << g;
    fs::remove(csv);
}

// A case that runs past --case-limit ends the run: exit 1, the case named, the rows before it
// in the CSV (written as they come). The tau/ group has cases over 50 ms (its photonsky at a
// thickness of 1e4 takes about a second), so a limit of 0.05 s stops one of them.
TEST(StressCli, ACaseOverTheLimitStopsTheRunNamingIt) {
    const fs::path csv =
        fs::temp_directory_path() / ("nimbus_stress_limit_" + std::to_string(getpid()) + ".csv");
    const CliRun r =
        runNimbus("stress --quick --filter tau/ --case-limit 0.05 --csv " + csv.string());
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, "nimbus: error: stress: case tau/"));
    EXPECT_TRUE(contains(r.output, "over the limit of 0.05 s per case (--case-limit)"));
    EXPECT_FALSE(contains(r.output, "summary: "));
    // the named case is the one after the last printed row
    const size_t at = r.output.find("stress: case ") + 13;
    const std::string named = r.output.substr(at, r.output.find(' ', at) - at);
    EXPECT_EQ(r.output.find("\n" + named + " "), std::string::npos) << "it has a row";
    // every printed row is in the CSV already
    int printed = 0, rows = -1; // the CSV's header
    std::istringstream out(r.output);
    std::string line;
    while (std::getline(out, line)) printed += line.rfind("tau/", 0) == 0;
    std::ifstream in(csv);
    while (std::getline(in, line)) ++rows;
    EXPECT_EQ(rows, printed);
    fs::remove(csv);
    EXPECT_NE(runNimbus("stress --quick --case-limit 0").exitCode, 0);
}

TEST(StressCli, FilterSelectsTheCases) {
    // a filter that matches nothing is a usage error
    const CliRun none = runNimbus("stress --quick --filter no-such-case");
    EXPECT_EQ(none.exitCode, 2) << none.output;
    EXPECT_TRUE(contains(none.output, "no case matches"));
    const CliRun frames = runNimbus("stress --filter frames/1-1000001");
    EXPECT_EQ(frames.exitCode, 0) << frames.output;
    EXPECT_TRUE(contains(frames.output, "summary: 1 cases: 1 PASS"));
}

TEST(StressChecks, HenyeyGreensteinAtGOfPlusMinusOneIsFinite) {
    // a delta, which the scene file refuses; core must still give finite values (0 / 0 was NaN
    // at the peak)
    for (float g : {1.0f, -1.0f}) {
        const PhaseFunction p(kern::phaseParamsHG(g));
        for (float mu : {-1.0f, -0.5f, 0.0f, 0.999f, 1.0f}) {
            EXPECT_TRUE(std::isfinite(p.eval(mu).x)) << "g " << g << " cos " << mu;
            EXPECT_GE(p.eval(mu).x, 0.0f);
        }
        for (float u : {0.0f, 0.3f, 0.999f}) {
            const PhaseSample s = p.sample(vec2(u, 0.5f));
            EXPECT_EQ(s.cosTheta, g) << "the delta's direction";
            EXPECT_TRUE(std::isfinite(s.pdf));
        }
    }
    // and near +-1 the kernel is unchanged: HG(1, 0.999) = (1 + g) / (4 pi (1 - g)^2)
    const PhaseFunction p(kern::phaseParamsHG(0.999f));
    EXPECT_NEAR(p.eval(1.0f).x / (1.999 / (4.0 * M_PI * 1e-6)), 1.0, 2e-3);
}

namespace {

/// One majorant segment [t0, t1] at sigma_maj.
struct OneSegment {
    MajorantSegment seg;
    bool done = false;
    bool next(MajorantSegment& s) {
        if (done) return false;
        s = seg;
        done = true;
        return true;
    }
};

} // namespace

TEST(StressChecks, TrackingLeavesASegmentWhoseFlightsAreBelowFloatResolution) {
    // sigma_maj 1e15 at t = 5: every flight (1e-15) is far below t's ulp (4.8e-7), so t never
    // advanced and a walk through density 0 (every collision null) never ended. Now 8 such flights
    // in a row move it one ulp: the walk leaves the segment after about 8 x 2^21 flights.
    OneSegment segs{MajorantSegment{5.0f, 6.0f, 1.0f}};
    Sampler rng{12345u, 0};
    std::uint64_t flights = 0;
    const bool left = sampleTmaj(segs, 1e15f, rng, [&](float, const MajorantSegment&, float) {
        return ++flights < 100000000u; // a null collision; give up after 1e8
    });
    EXPECT_TRUE(left) << "stopped after " << flights << " flights";
    EXPECT_LT(flights, 30000000u);
    // at an ordinary majorant the walk is unchanged: about sigma_maj x length flights
    OneSegment thin{MajorantSegment{5.0f, 6.0f, 1.0f}};
    flights = 0;
    EXPECT_TRUE(sampleTmaj(thin, 1000.0f, rng, [&](float, const MajorantSegment&, float) {
        ++flights;
        return true;
    }));
    EXPECT_NEAR(double(flights), 1000.0, 5.0 * std::sqrt(1000.0));
}

TEST(StressChecks, PhotonHandOffStaysBoundedFrom1e2To1e6MeanFreePaths) {
    // photons handing their light to the diffusion grid (render.photon_bounces) in the lit cube
    // made 100 to 1,000,000 mean free paths across at albedo 1: every walk ends in the first
    // voxel under the lit faces, whose diffusion resistance grows with the density. No bad
    // value, the light handed off, and no pixel brighter than the sun's irradiance (a white
    // diffuser returns E / pi; the history's blow-up was 2,000 E, docs/stress.md).
    for (float sigma : {100.0f, 1e4f, 1e6f}) {
        const SceneDesc s = photonCube(sigma, 0.0f);
        RenderStats st;
        const Framebuffer fb = renderScene(s, &st);
        const stress::FrameCheck c = stress::checkFrame(fb);
        EXPECT_TRUE(c.ok()) << sigma << ": " << c.nonFinite << " non-finite, " << c.negative
                            << " negative";
        EXPECT_GT(st.photonsHandedOff, 0u) << sigma;
        EXPECT_LT(c.maxRgb, double(s.sun.irradiance.x)) << sigma;
        EXPECT_GT(c.meanRgb, 0.0) << sigma;
        RecordProperty("max_rgb_" + std::to_string(int(std::log10(sigma))),
                       std::to_string(c.maxRgb));
        RecordProperty("handed_off_" + std::to_string(int(std::log10(sigma))),
                       std::to_string(st.photonsHandedOff));
    }
}

TEST(StressChecks, SkyPhotonsStayBoundedFrom1e2To1e6MeanFreePaths) {
    // the sky's light traced by photons too (render.photon_sky), handing off after 8
    // scatterings, in the lit cube made 100 to 1,000,000 mean free paths across at albedo 1 and
    // 0.9: no bad value, photons left the sky, and no pixel brighter than a white diffuser under
    // the sun and the whole sky could make it (E / pi plus the sky's brightest radiance; the
    // bound is the sun's E plus that)
    for (float albedo : {1.0f, 0.9f})
        for (float sigma : {100.0f, 1e4f, 1e6f}) {
            SceneDesc s = photonCube(albedo * sigma, (1.0f - albedo) * sigma);
            s.render.photonSky = true;
            s.render.skyShadow = SkyShadow::Volume;
            RenderStats st;
            const Framebuffer fb = renderScene(s, &st);
            const stress::FrameCheck c = stress::checkFrame(fb);
            const std::string at = std::to_string(sigma) + " at albedo " + std::to_string(albedo);
            EXPECT_TRUE(c.ok()) << at << ": " << c.nonFinite << " non-finite, " << c.negative
                                << " negative";
            EXPECT_GT(st.photonsFromSky, 0u) << at;
            const float skyMax = std::max(maxComponent(s.sky.zenith), maxComponent(s.sky.horizon));
            EXPECT_LT(c.maxRgb, double(s.sun.irradiance.x + skyMax)) << at;
            EXPECT_GT(c.meanRgb, 0.0) << at;
        }
}
