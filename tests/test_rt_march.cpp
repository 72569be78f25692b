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

/// The default scene at a small size with multiple scattering `ms` ("none": octaves and the sky
/// ambient only; "grid", "photons": the grids computed on the CPU) and the noise evaluated
/// directly on the CPU too.
std::vector<std::string> paritySettings(int w, int h, const std::string& ms = "none") {
    return {"camera.width=" + std::to_string(w), "camera.height=" + std::to_string(h),
            "render.multiple_scattering=\"" + ms + "\"", "field.evaluation=\"direct\""};
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
    // the diffusion and photon grids (with the photons' skin profile) and the Mie table
    SceneDesc s = base;
    s.render.multipleScattering = MultipleScattering::Grid;
    EXPECT_EQ(keysOf(s), "");
    s.render.multipleScattering = MultipleScattering::Photons;
    EXPECT_EQ(keysOf(s), "");
    s.render.photonSkin = 0.2f;
    EXPECT_EQ(keysOf(s), "");
    s = base;
    s.medium.phase = PhaseKind::MieTable;
    EXPECT_EQ(keysOf(s), "");
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
    EXPECT_TRUE(!f.mieTable && !f.diffusion && !f.photons);
    EXPECT_TRUE(contains(f.defines(), "#define RT_MIE_TABLE 0\n"));
    EXPECT_TRUE(contains(f.defines(), "#define RT_MS_DIFFUSION 0\n"));
    {
        // the table with the sun; the diffusion grid replaces the sky ambient; photons carry the
        // sun's higher orders and the diffusion grid the sky's
        SceneDesc m = s;
        m.medium.phase = PhaseKind::MieTable;
        m.render.multipleScattering = MultipleScattering::Grid;
        rt::MarchFeatures g = rt::marchFeatures(m, planFrame(m, 1));
        EXPECT_TRUE(g.mieTable && g.diffusion && !g.photons && !g.ambient);
        EXPECT_TRUE(contains(g.defines(), "#define RT_MIE_TABLE 1\n"));
        EXPECT_TRUE(contains(g.defines(), "#define RT_MS_DIFFUSION 1\n"));
        m.render.multipleScattering = MultipleScattering::Photons;
        g = rt::marchFeatures(m, planFrame(m, 1));
        EXPECT_TRUE(g.diffusion && g.photons && !g.ambient);
        EXPECT_TRUE(contains(g.defines(), "#define RT_MS_PHOTONS 1\n"));
        EXPECT_TRUE(contains(g.defines(), "#define RT_PHOTON_SKIN 0\n"));
        m.render.photonSkin = 0.2f;
        EXPECT_TRUE(rt::marchFeatures(m, planFrame(m, 1)).photonSkin);
        m.sun.enabled = false; // no sun: no octaves, so no table (and no photons)
        g = rt::marchFeatures(m, planFrame(m, 1));
        EXPECT_TRUE(!g.mieTable && !g.photons && g.diffusion);
    }
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
                     double* maxAbs, const std::string& ms = "none") {
    std::vector<std::string> settings = paritySettings(160, 90, ms);
    settings.insert(settings.end(), extra.begin(), extra.end());
    host::Session session;
    const host::Status st = session.load(kDefaultScene, settings);
    EXPECT_TRUE(st.ok()) << st.message;
    Framebuffer cpu, gpu;
    RenderStats cpuStats;
    EXPECT_TRUE(session.render(frame, cpu, cpuStats).ok());
    const FramePlan plan = session.plan(frame);
    // the multiple-scattering grids as the CPU frame built them (Renderer::marchGrids)
    RenderStats gridStats;
    const MarchGrids grids = session.renderer().marchGrids(plan, session.bindings(), gridStats);
    EXPECT_EQ(grids.hasDiffusion, plan.diffusion) << tag;
    EXPECT_EQ(grids.hasPhotons, plan.photons) << tag;
    rt::MarchPass pass;
    rt::MarchStats gpuStats;
    std::string error;
    EXPECT_TRUE(pass.render(session.scene(), plan, &grids, gpu, gpuStats, &error)) << error;
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

// the Lorenz-Mie table (render.phase = "mie_table"), read from a buffer as MieTable::eval reads
// it, through the octaves (PhaseFunction::octave blends it toward isotropic)
TEST(RtMarchParity, MieTable) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {"medium.phase=\"mie_table\""}, "mie_table", &maxAbs), 45.0);
}

// render.multiple_scattering = "grid": the diffusion grid the CPU solved, read trilinearly with
// its gradient (the P1 radiance), in place of the sky ambient; the default scene as it ships
TEST(RtMarchParity, DiffusionGrid) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {}, "ms_grid", &maxAbs, "grid"), 45.0);
    // with the Mie table too (the diffusion's P1 term takes the table's mean cosine)
    EXPECT_GE(
        gpuAgainstCpu(1, {"medium.phase=\"mie_table\""}, "ms_grid_mie_table", &maxAbs, "grid"),
        45.0);
}

// render.multiple_scattering = "photons": the sun's photon grid (one octave) and the sky's
// diffusion grid
TEST(RtMarchParity, PhotonGrid) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {}, "ms_photons", &maxAbs, "photons"), 45.0);
    // with the skin profile (the density integral toward the sun from the light volume)
    EXPECT_GE(gpuAgainstCpu(1, {"render.photon_skin=0.2"}, "ms_photons_skin", &maxAbs, "photons"),
              45.0);
}

// `nimbus rt` writes the frame through the output code of `nimbus render` (colour conversion to
// output.color_space, metadata, AOVs): both EXRs of the same frame agree at PSNR >= 45 dB; with
// multiple_scattering = "grid" (the default scene's) the CLI computes the grid on the CPU first.
TEST(RtCli, WritesTheSameExrAsRender) {
    for (const std::string ms : {"none", "grid"}) {
        TempDir dir("rt_cli");
        const std::string sets = " --set camera.width=64 --set camera.height=36 --set "
                                 "'render.multiple_scattering=\"" +
                                 ms + "\"' --set 'field.evaluation=\"direct\"'";
        auto preview = [&](const std::string& name) {
            return " --set 'output.preview=\"" + dir.string() + "/" + name + ".####.png\"'";
        };
        const CliRun gpu = runNimbus("rt " + kDefaultScene + " --frames 3 -o " + dir.string() +
                                     "/gpu.####.exr" + sets + preview("gpu"));
        ASSERT_EQ(gpu.exitCode, 0) << gpu.output;
        EXPECT_TRUE(contains(gpu.output, "frame 3: 64x36,"));
        EXPECT_EQ(contains(gpu.output, "multiple-scattering grid computed on the CPU"),
                  ms == "grid")
            << gpu.output;
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
        RecordProperty("psnr_db_cli_64x36_" + ms, std::to_string(psnr));
        std::printf("[ rt parity ] cli 64x36 multiple_scattering %s: PSNR %.2f dB\n", ms.c_str(),
                    psnr);
        EXPECT_GE(psnr, 45.0) << ms;
    }
}

// An unsupported scene is refused before any GPU work, with exit 2 and the key in the message;
// no file is written.
TEST(RtCli, RefusesUnsupportedSceneWithExit2) {
    TempDir dir("rt_refuse");
    // the default scene with the sun's light-attenuation volume
    const CliRun r = runNimbus("rt " + kDefaultScene + " --frames 1 -o " + dir.string() +
                               "/x.####.exr --set camera.width=32 --set camera.height=18 --set "
                               "'render.shadow=\"volume\"'");
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "render.shadow"));
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
