/// @file test_rt_display.cpp
/// @brief OpenColorIO's display/view transform on the GPU (plugin/realtime/ocio_gpu.h, `nimbus rt
/// --gpu-display`) against OCIO's CPU processor (io::ColorSystem::applyDisplayView, what
/// `nimbus render` writes its previews with), on the same linear images: the built-in config's
/// views (analytic, no LUT), and a config whose view goes through a 1D LUT, a 3D LUT and a long
/// 1D LUT (the 1D, 3D and 2D-folded textures). Measured values are in docs/realtime.md
/// ("The preview's display transform on the GPU").
///
/// As the other GL tests, these fail (with the EGL error) when no headless OpenGL 4.5 context
/// can be made.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "plugin/io/color.h"
#include "plugin/io/image_output.h"
#include "plugin/realtime/gl_compute.h"
#include "plugin/realtime/ocio_gpu.h"
#include "tests/gl_context.h"
#include "tests/test_util.h"

using namespace nimbus;

namespace {

/// A linear RGB test image, w x h: every channel from an integer hash, spread over
/// [lo, hi] (log2-uniform when `log`), plus a first row of greys from lo to hi and a few exact
/// zeros and negatives.
std::vector<float> testImage(int w, int h, float lo, float hi, bool log) {
    std::vector<float> rgb(std::size_t(w) * std::size_t(h) * 3);
    std::uint32_t s = 12345u;
    auto next = [&s]() {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        return float(s >> 8) / float(1u << 24);
    };
    auto spread = [&](float u) {
        return log ? std::exp2(std::log2(lo) + u * (std::log2(hi) - std::log2(lo)))
                   : lo + u * (hi - lo);
    };
    for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = spread(next());
    for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
            rgb[3 * std::size_t(x) + std::size_t(c)] = spread(float(x) / float(w - 1));
    rgb[3 * std::size_t(w)] = rgb[3 * std::size_t(w) + 1] = rgb[3 * std::size_t(w) + 2] = 0.0f;
    rgb[3 * std::size_t(w) + 3] = -0.05f;
    rgb[3 * std::size_t(w) + 7] = -0.5f;
    return rgb;
}

struct Parity {
    double maxAbs = 0.0;      ///< largest difference of the display-encoded floats
    int maxCode = 0;          ///< largest difference of the 8-bit codes
    std::size_t codesOff = 0; ///< 8-bit values that differ
    double psnr8 = 0.0;       ///< PSNR over the 8-bit values (peak 255)
};

/// The 8-bit code the preview writes (io::writeEncodedPreviewPng).
int code(float v) {
    v = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
    return int(std::lround(v * 255.0f));
}

/// The GPU's display transform of `linear` against the CPU's.
Parity gpuAgainstCpu(const io::ColorSystem& cs, const std::vector<float>& linear, int w, int h,
                     const std::string& from, const std::string& display, const std::string& view,
                     std::size_t* textures = nullptr) {
    Parity p;
    std::vector<float> cpu = linear;
    cs.applyDisplayView(cpu.data(), w, h, 3, from, display, view);
    const io::GpuDisplayShader shader = cs.displayViewGpuShader(from, display, view);
    const rt::GpuDisplayTransform t(shader);
    EXPECT_TRUE(t.valid()) << t.error();
    if (textures) *textures = t.textureCount();
    std::vector<float> gpu = linear;
    std::string error;
    double seconds = 0.0;
    EXPECT_TRUE(t.apply(gpu, w, h, &error, &seconds)) << error;
    double se = 0.0;
    for (std::size_t i = 0; i < cpu.size(); ++i) {
        EXPECT_TRUE(std::isfinite(gpu[i])) << i;
        p.maxAbs = std::max(p.maxAbs, double(std::abs(gpu[i] - cpu[i])));
        const int d = std::abs(code(gpu[i]) - code(cpu[i]));
        p.maxCode = std::max(p.maxCode, d);
        p.codesOff += d > 0 ? 1 : 0;
        se += double(d) * double(d);
    }
    p.psnr8 = se > 0.0 ? 10.0 * std::log10(255.0 * 255.0 / (se / double(cpu.size()))) : 1e9;
    const std::string tag = display + " / " + view;
    ::testing::Test::RecordProperty("max_abs " + tag, std::to_string(p.maxAbs));
    ::testing::Test::RecordProperty("psnr8 " + tag, std::to_string(p.psnr8));
    std::printf("[ rt display ] %s from %s, %dx%d: largest float difference %.3g, 8-bit: %zu of "
                "%zu values off (largest %d), PSNR %.2f dB; GPU %.4f s\n",
                tag.c_str(), from.c_str(), w, h, p.maxAbs, p.codesOff, cpu.size(), p.maxCode,
                p.psnr8, seconds);
    return p;
}

} // namespace

// The shader OCIO generates for the built-in views, wrapped for a compute pass.
TEST(RtDisplay, ShaderText) {
    const io::ColorSystem cs = io::ColorSystem::builtin();
    const io::GpuDisplayShader s = cs.displayViewGpuShader("ACEScg", "sRGB", "ACES 1.0 SDR-video");
    EXPECT_EQ(s.function, "OCIODisplay");
    EXPECT_TRUE(contains(s.text, "vec4 OCIODisplay(")) << s.text;
    EXPECT_FALSE(s.cacheId.empty());
    const std::string src = rt::displayComputeSource(s);
    EXPECT_EQ(src.rfind("#version 430\n", 0), 0u);
    EXPECT_TRUE(contains(src, "OCIODisplay(vec4(rgbIn[i]"));
    // errors name the unknown view and list the valid ones, as the CPU path's
    try {
        cs.displayViewGpuShader("ACEScg", "sRGB", "Nope");
        ADD_FAILURE() << "an unknown view was accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_TRUE(contains(e.what(), "unknown view 'Nope'"));
        EXPECT_TRUE(contains(e.what(), "Un-tone-mapped"));
    }
}

// The built-in config's views from ACEScg (the working space): HDR values from 2^-12 to 2^6.
TEST(RtDisplay, BuiltinViewsAsTheCpu) {
    if (!requireContext()) return;
    const io::ColorSystem cs = io::ColorSystem::builtin();
    const int w = 256, h = 128;
    const std::vector<float> img = testImage(w, h, 1.0f / 4096.0f, 64.0f, true);
    for (const char* view : {"ACES 1.0 SDR-video", "Un-tone-mapped"}) {
        for (const char* from : {"ACEScg", "lin_rec709"}) {
            const Parity p = gpuAgainstCpu(cs, img, w, h, from, "sRGB", view);
            EXPECT_LT(p.maxAbs, 1.0 / 255.0) << view << " from " << from;
            EXPECT_LE(p.maxCode, 1) << view << " from " << from;
            EXPECT_GE(p.psnr8, 45.0) << view << " from " << from;
        }
    }
}

// A view through LUTs: a 1D LUT (1,024 entries: a 1D texture), a 3D LUT (17^3: a 3D texture)
// and a 1D LUT of 8,192 entries (longer than OCIO's texture width of 4,096: folded into a 2D
// texture), each linearly interpolated.
TEST(RtDisplay, LutViewAsTheCpu) {
    if (!requireContext()) return;
    TempDir dir("rt_display");
    auto spi1d = [](int n, double gamma) {
        std::string t =
            "Version 1\nFrom 0.0 1.0\nLength " + std::to_string(n) + "\nComponents 1\n{\n";
        for (int i = 0; i < n; ++i) {
            char b[32];
            std::snprintf(b, sizeof b, "%.7f\n", std::pow(double(i) / (n - 1), gamma));
            t += b;
        }
        return t + "}\n";
    };
    writeText(dir.string() + "/short.spi1d", spi1d(1024, 1.0 / 2.2));
    writeText(dir.string() + "/long.spi1d", spi1d(8192, 1.3));
    std::string cube = "LUT_3D_SIZE 17\n";
    for (int b = 0; b < 17; ++b)
        for (int g = 0; g < 17; ++g)
            for (int r = 0; r < 17; ++r) {
                const double R = r / 16.0, G = g / 16.0, B = b / 16.0;
                char line[96];
                std::snprintf(line, sizeof line, "%.6f %.6f %.6f\n", 0.8 * R + 0.2 * G * G,
                              0.7 * G + 0.3 * R * B, 0.6 * B * B + 0.4 * std::sqrt(R));
                cube += line;
            }
    writeText(dir.string() + "/grade.cube", cube);
    const std::string config = R"(ocio_profile_version: 2
environment: {}
search_path: ""
roles:
  default: linear
  scene_linear: linear
  data: raw
displays:
  Screen:
    - !<View> {name: Graded, colorspace: graded}
colorspaces:
  - !<ColorSpace>
    name: linear
    isdata: false
  - !<ColorSpace>
    name: graded
    isdata: false
    from_scene_reference: !<GroupTransform>
      children:
        - !<FileTransform> {src: short.spi1d, interpolation: linear}
        - !<FileTransform> {src: grade.cube, interpolation: linear}
        - !<FileTransform> {src: long.spi1d, interpolation: linear}
  - !<ColorSpace>
    name: raw
    isdata: true
)";
    writeText(dir.string() + "/luts.ocio", config);
    const io::ColorSystem cs = io::ColorSystem::fromFile(dir.string() + "/luts.ocio");
    const io::GpuDisplayShader s = cs.displayViewGpuShader("linear", "Screen", "Graded");
    int n1 = 0, n2 = 0, n3 = 0;
    for (const io::GpuDisplayShader::Texture& t : s.textures) {
        n3 += t.depth > 0 ? 1 : 0;
        n2 += t.depth == 0 && t.height > 1 ? 1 : 0;
        n1 += t.depth == 0 && t.height <= 1 ? 1 : 0;
        EXPECT_TRUE(t.linear) << t.sampler;
    }
    EXPECT_EQ(n1, 1);
    EXPECT_EQ(n2, 1);
    EXPECT_EQ(n3, 1);
    const int w = 256, h = 128;
    const std::vector<float> img = testImage(w, h, -0.1f, 1.2f, false);
    std::size_t textures = 0;
    const Parity p = gpuAgainstCpu(cs, img, w, h, "linear", "Screen", "Graded", &textures);
    EXPECT_EQ(textures, 3u);
    EXPECT_LT(p.maxAbs, 1.0 / 255.0);
    EXPECT_LE(p.maxCode, 1);
    EXPECT_GE(p.psnr8, 45.0);
}

// `nimbus rt --gpu-display` writes the same EXR as without it and a preview PNG within one 8-bit
// code of the CPU's (OCIO's CPU processor, the default), the default view (ACES 1.0 SDR-video).
TEST(RtDisplayCli, GpuPreviewAsTheCpuPreview) {
    TempDir dir("rt_display_cli");
    const std::string scene = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/cumulus.toml";
    const std::string sets = " --frames 2 --set camera.width=64 --set camera.height=36 --set "
                             "'render.multiple_scattering=\"none\"' --set "
                             "'field.evaluation=\"direct\"'";
    auto run = [&](const std::string& name, const std::string& extra) {
        return runNimbus("rt " + scene + sets + " -o " + dir.string() + "/" + name +
                         ".####.exr --set 'output.preview=\"" + dir.string() + "/" + name +
                         ".####.png\"'" + extra);
    };
    const CliRun gpu = run("gpu", " --gpu-display");
    ASSERT_EQ(gpu.exitCode, 0) << gpu.output;
    EXPECT_TRUE(contains(gpu.output, "on the GPU (OpenColorIO's GLSL"));
    EXPECT_TRUE(contains(gpu.output, "frame 2: preview's display transform"));
    const CliRun cpu = run("cpu", "");
    ASSERT_EQ(cpu.exitCode, 0) << cpu.output;
    EXPECT_EQ(cpu.output.find("display transform"), std::string::npos) << cpu.output;
    const io::ExrImage ge = io::readExr(dir.string() + "/gpu.0002.exr");
    const io::ExrImage ce = io::readExr(dir.string() + "/cpu.0002.exr");
    EXPECT_EQ(ge.pixels, ce.pixels); // the render is deterministic; only the preview differs
    const io::ExrImage gp = io::readExr(dir.string() + "/gpu.0002.png");
    const io::ExrImage cp = io::readExr(dir.string() + "/cpu.0002.png");
    ASSERT_EQ(gp.width, 64);
    ASSERT_EQ(gp.pixels.size(), cp.pixels.size());
    int maxCode = 0;
    std::size_t off = 0;
    for (std::size_t i = 0; i < gp.pixels.size(); ++i) {
        const int d = int(std::lround(std::abs(gp.pixels[i] - cp.pixels[i]) * 255.0f));
        maxCode = std::max(maxCode, d);
        off += d > 0 ? 1 : 0;
    }
    std::printf("[ rt display ] nimbus rt --gpu-display, 64x36 preview: %zu of %zu values off "
                "the CPU's (largest %d)\n",
                off, gp.pixels.size(), maxCode);
    EXPECT_LE(maxCode, 1);
    // written by the preview writer the CPU path uses (io::writeEncodedPreviewPng)
    EXPECT_TRUE(contains(gp.attributes.count("Software") ? gp.attributes.at("Software") : "",
                         "Nimbus preview: sRGB / ACES 1.0 SDR-video"));
    // a scene without a preview: a warning, the frame still written
    const CliRun none = runNimbus("rt " + scene + sets + " -o " + dir.string() +
                                  "/none.####.exr --set 'output.preview=\"\"' --gpu-display");
    EXPECT_EQ(none.exitCode, 0) << none.output;
    EXPECT_TRUE(contains(none.output, "--gpu-display: the scene writes no preview"));
}
