/// @file test_rt_march.cpp
/// @brief The GLSL march pass (plugin/realtime/rt_march.h) against the CPU `march` integrator:
/// the shared parameter block unpacks to the kernel structs the CPU uses, the default scene's
/// field renders on the GPU (Mesa llvmpipe through EGL here) at PSNR >= 45 dB against the CPU at
/// equal settings, unsupported settings are refused by key, and `nimbus rt` writes a valid EXR
/// through the same output code as `nimbus render` and exits 2 on an unsupported scene.
///
/// Like the kernel parity tests (tests/test_glsl_parity.cpp), the GPU tests fail, with the EGL
/// error, when no headless OpenGL 4.5 context can be made: the packages are required.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/fields/cumulus.h"
#include "core/media/phase.h"
#include "plugin/host/session.h"
#include "plugin/io/image_output.h"
#include "plugin/realtime/gl_compute.h"
#include "plugin/realtime/march_params.h"
#include "plugin/realtime/rt_march.h"
#include "tests/test_util.h"

using namespace nimbus;

namespace {

const std::string kDefaultScene = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/cumulus.toml";

/// The default scene at a small size with multiple scattering off (the GPU subset) and the
/// noise evaluated directly on the CPU too.
std::vector<std::string> paritySettings(int w, int h) {
    return {"camera.width=" + std::to_string(w), "camera.height=" + std::to_string(h),
            "render.multiple_scattering=\"none\"", "field.evaluation=\"direct\""};
}

/// PSNR in dB of `test` against `ref` over the RGB of premultiplied RGBA pixels, the peak being
/// the reference's largest RGB value (an HDR image has no fixed white).
double psnrRgb(const std::vector<float>& ref, const std::vector<float>& test, double* maxAbs) {
    double peak = 0.0, se = 0.0;
    *maxAbs = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
        if (i % 4 == 3) continue;
        const double d = double(test[i]) - double(ref[i]);
        peak = std::max(peak, double(ref[i]));
        se += d * d;
        *maxAbs = std::max(*maxAbs, std::abs(d));
        ++n;
    }
    const double mse = se / double(n);
    return mse > 0.0 ? 10.0 * std::log10(peak * peak / mse) : 1e9;
}

gl::ComputeContext* requireContext() {
    std::string error;
    gl::ComputeContext* c = gl::ComputeContext::shared(&error);
    EXPECT_NE(c, nullptr) << "no headless OpenGL 4.5 context (EGL surfaceless, Mesa llvmpipe; "
                             "packages libegl-dev libopengl-dev libgl1-mesa-dri): "
                          << error;
    return c;
}

} // namespace

// The block the shader reads rebuilds exactly the kernel structs the CPU renders with.
TEST(RtMarchParams, UnpackToTheCpuKernelStructs) {
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, paritySettings(160, 90)).ok());
    const SceneDesc& s = session.scene();
    for (int frame : {1, 12}) {
        const FramePlan plan = session.plan(frame);
        const rt::RtMarchParams P = rt::marchParams(s, plan);
        const kern::CumulusParams want = cumulusParams(s.field.cumulus, plan.time);
        const kern::CumulusParams got = kern::rtCumulusParams(P);
        static_assert(sizeof want == 28 * 4, "CumulusParams has no padding to compare");
        EXPECT_EQ(std::memcmp(&want, &got, sizeof want), 0) << "frame " << frame;
        const kern::PhaseParams pw = phaseParams(s.medium), pg = kern::rtPhaseParams(P);
        EXPECT_EQ(std::memcmp(&pw, &pg, sizeof pw), 0);
        EXPECT_EQ(P.width, 160);
        EXPECT_EQ(P.height, 90);
        EXPECT_EQ(P.step, plan.step);
        EXPECT_EQ(P.shadowStep, plan.shadowStep);
    }
}

// What the GPU path cannot do is named by its key; the parity settings need nothing else.
TEST(RtMarchSupport, RefusesByKey) {
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, paritySettings(32, 18)).ok());
    const SceneDesc base = session.scene();
    EXPECT_TRUE(rt::unsupported(base, planFrame(base, 1)).empty());
    auto keysOf = [](const SceneDesc& s) {
        std::string keys;
        for (const rt::Unsupported& u : rt::unsupported(s, planFrame(s, 1))) keys += u.key + ";";
        return keys;
    };
    SceneDesc s = base;
    s.render.multipleScattering = MultipleScattering::Grid;
    EXPECT_EQ(keysOf(s), "render.multiple_scattering;");
    s = base;
    s.render.multipleScattering = MultipleScattering::Photons;
    EXPECT_EQ(keysOf(s), "render.multiple_scattering;");
    s = base;
    s.field.kind = FieldKind::Vdb;
    EXPECT_TRUE(contains(keysOf(s), "field.kind;"));
    s = base;
    s.field.cumulus.eval = NoiseEval::Baked;
    EXPECT_EQ(keysOf(s), "field.evaluation;");
    s = base;
    s.render.integrator = Integrator::PathTrace;
    EXPECT_EQ(keysOf(s), "render.integrator;");
    s = base;
    s.render.shadow = ShadowMethod::Volume;
    EXPECT_EQ(keysOf(s), "render.shadow;");
    s = base;
    s.render.skyOcclusion = SkyOcclusion::Column;
    EXPECT_EQ(keysOf(s), "render.sky_occlusion;");
    s = base;
    s.render.skyScattering = SkyScattering::Single;
    EXPECT_EQ(keysOf(s), "render.sky_scattering;");
    s = base;
    s.medium.phase = PhaseKind::MieTable;
    EXPECT_EQ(keysOf(s), "medium.phase;");
    s = base;
    s.ground.enabled = true;
    EXPECT_EQ(keysOf(s), "ground.enabled;");
}

// The shader carries only the features a frame uses.
TEST(RtMarchShader, DefinesOnlyTheFeaturesInUse) {
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, paritySettings(32, 18)).ok());
    SceneDesc s = session.scene();
    rt::MarchFeatures f = rt::marchFeatures(s, planFrame(s, 1));
    EXPECT_TRUE(f.sun && f.ambient && f.backgroundSky && !f.multisample);
    s.sun.enabled = false;
    s.sky.kind = SkyKind::None;
    s.render.background = Background::Transparent;
    s.render.pixelSamples = 4;
    f = rt::marchFeatures(s, planFrame(s, 1));
    EXPECT_TRUE(!f.sun && !f.ambient && !f.backgroundSky && f.multisample);
    const std::string text = rt::marchShaderSource(f);
    EXPECT_TRUE(contains(text, "#define RT_SUN 0\n"));
    EXPECT_TRUE(contains(text, "#define RT_MULTISAMPLE 1\n"));
    EXPECT_TRUE(contains(text, "NB_FN float cumulusDensity(")); // the embedded kernel text
}

/// Renders frame `frame` of the default scene with `extra` settings on the CPU (march) and on
/// the GPU; returns the PSNR of the GPU image against the CPU image (and records it).
double gpuAgainstCpu(int frame, const std::vector<std::string>& extra, const std::string& tag,
                     double* maxAbs) {
    std::vector<std::string> settings = paritySettings(160, 90);
    settings.insert(settings.end(), extra.begin(), extra.end());
    host::Session session;
    const host::Status st = session.load(kDefaultScene, settings);
    EXPECT_TRUE(st.ok()) << st.message;
    Framebuffer cpu, gpu;
    RenderStats cpuStats;
    EXPECT_TRUE(session.render(frame, cpu, cpuStats).ok());
    rt::MarchPass pass;
    rt::MarchStats gpuStats;
    std::string error;
    EXPECT_TRUE(pass.render(session.scene(), session.plan(frame), gpu, gpuStats, &error)) << error;
    EXPECT_EQ(gpu.rgba.size(), cpu.rgba.size());
    if (gpu.rgba.size() != cpu.rgba.size()) return 0.0;
    EXPECT_EQ(gpuStats.nonFinite, 0u);
    // the picture is not trivially empty: the field covers a good part of the frame
    std::size_t cloudy = 0;
    for (std::size_t i = 0; i < cpu.transmittance.size(); i += 3)
        if (cpu.transmittance[i] < 0.9f) ++cloudy;
    EXPECT_GT(cloudy, cpu.transmittance.size() / 3 / 10) << tag;
    const double psnr = psnrRgb(cpu.rgba, gpu.rgba, maxAbs);
    ::testing::Test::RecordProperty("psnr_db_" + tag, std::to_string(psnr));
    ::testing::Test::RecordProperty("max_abs_" + tag, std::to_string(*maxAbs));
    ::testing::Test::RecordProperty("gpu_seconds_" + tag, std::to_string(gpuStats.frameSeconds));
    std::printf("[ rt parity ] %s: PSNR %.2f dB, largest difference %.3g, GPU %.3f s "
                "(compile %.3f s)\n",
                tag.c_str(), psnr, *maxAbs, gpuStats.frameSeconds, gpuStats.compileSeconds);
    // the AOVs too: transmittance and depth are written by the same pass
    if (!cpu.transmittance.empty()) {
        double dT = 0.0;
        for (std::size_t i = 0; i < cpu.transmittance.size(); ++i)
            dT = std::max(dT, double(std::abs(cpu.transmittance[i] - gpu.transmittance[i])));
        ::testing::Test::RecordProperty("max_abs_transmittance_" + tag, std::to_string(dT));
    }
    return psnr;
}

TEST(RtMarchParity, DefaultSceneFrame1) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {}, "default_frame1", &maxAbs), 45.0);
}

// frame 12: the wind offsets of the field, the frame's own seeds
TEST(RtMarchParity, DefaultSceneFrame12) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(12, {}, "default_frame12", &maxAbs), 45.0);
}

// the other branches of the pass: Olajos in-scatter, a Draine phase function, one octave,
// several filtered samples per pixel, no jitter, a transparent background
TEST(RtMarchParity, OtherSettings) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(
        gpuAgainstCpu(1,
                      {"render.inscatter=\"olajos\"", "medium.phase=\"draine\"", "medium.g=0.6",
                       "render.octaves=1", "render.pixel_samples=4", "render.filter=\"gaussian\"",
                       "render.filter_width=2.0", "render.background=\"transparent\""},
                      "variant", &maxAbs),
        45.0);
    EXPECT_GE(gpuAgainstCpu(1, {"render.jitter=false", "medium.phase=\"mie_approx\""},
                            "no_jitter_mie_approx", &maxAbs),
              45.0);
}

// `nimbus rt` writes the frame through the output code of `nimbus render` (colour conversion to
// output.color_space, metadata, AOVs): both EXRs of the same frame agree at PSNR >= 45 dB.
TEST(RtCli, WritesTheSameExrAsRender) {
    TempDir dir("rt_cli");
    const std::string sets = " --set camera.width=64 --set camera.height=36 --set "
                             "'render.multiple_scattering=\"none\"' --set "
                             "'field.evaluation=\"direct\"'";
    auto preview = [&](const std::string& name) {
        return " --set 'output.preview=\"" + dir.string() + "/" + name + ".####.png\"'";
    };
    const CliRun gpu = runNimbus("rt " + kDefaultScene + " --frames 3 -o " + dir.string() +
                                 "/gpu.####.exr" + sets + preview("gpu"));
    ASSERT_EQ(gpu.exitCode, 0) << gpu.output;
    EXPECT_TRUE(contains(gpu.output, "frame 3: 64x36,"));
    const CliRun cpu = runNimbus("render " + kDefaultScene + " --frames 3 --progress none -o " +
                                 dir.string() + "/cpu.####.exr" + sets + preview("cpu"));
    ASSERT_EQ(cpu.exitCode, 0) << cpu.output;
    const io::ExrImage g = io::readExr(dir.string() + "/gpu.0003.exr");
    const io::ExrImage c = io::readExr(dir.string() + "/cpu.0003.exr");
    ASSERT_EQ(g.width, 64);
    ASSERT_EQ(g.height, 36);
    EXPECT_EQ(g.channels, c.channels);
    EXPECT_EQ(g.attributes.at("nimbus/colorSpace"), c.attributes.at("nimbus/colorSpace"));
    EXPECT_TRUE(contains(g.attributes.at("nimbus/settings/renderer"), "GLSL march pass"));
    const int ia = g.channelIndex("A");
    ASSERT_GE(ia, 0);
    std::vector<float> gr, cr;
    for (int y = 0; y < g.height; ++y)
        for (int x = 0; x < g.width; ++x)
            for (const char* ch : {"R", "G", "B", "A"}) {
                const float gv = g.at(x, y, g.channelIndex(ch));
                ASSERT_TRUE(std::isfinite(gv));
                gr.push_back(gv);
                cr.push_back(c.at(x, y, c.channelIndex(ch)));
            }
    double maxAbs = 0.0;
    const double psnr = psnrRgb(cr, gr, &maxAbs);
    RecordProperty("psnr_db_cli_64x36", std::to_string(psnr));
    EXPECT_GE(psnr, 45.0);
}

// An unsupported scene is refused before any GPU work, with exit 2 and the key in the message;
// no file is written.
TEST(RtCli, RefusesUnsupportedSceneWithExit2) {
    TempDir dir("rt_refuse");
    // the default scene as it is: multiple_scattering = "grid"
    const CliRun r = runNimbus("rt " + kDefaultScene + " --frames 1 -o " + dir.string() +
                               "/x.####.exr --set camera.width=32 --set camera.height=18");
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "render.multiple_scattering"));
    EXPECT_FALSE(std::filesystem::exists(dir.string() + "/x.0001.exr"));
    const CliRun b = runNimbus("rt " + kDefaultScene +
                               " --frames 1 --set "
                               "'render.multiple_scattering=\"none\"' --set "
                               "'field.evaluation=\"baked\"' --explain");
    EXPECT_EQ(b.exitCode, 2) << b.output;
    EXPECT_TRUE(contains(b.output, "field.evaluation"));
    const CliRun e = runNimbus("rt " + kDefaultScene +
                               " --frames 1 --set "
                               "'render.multiple_scattering=\"none\"' --explain");
    EXPECT_EQ(e.exitCode, 0) << e.output;
    EXPECT_TRUE(contains(e.output, "#define RT_SUN 1"));
}
