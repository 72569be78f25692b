/// @file test_color.cpp
/// @brief Tests of nimbus::io::ColorSystem: built-in OCIO config, conversions, display/view
///        transforms, chromaticities, unknown names and $OCIO.
#include "plugin/io/color.h"
#include "tests/test_util.h"

#include <OpenColorIO/OpenColorIO.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using nimbus::io::Chromaticities;
using nimbus::io::ColorSystem;
namespace chroma = nimbus::io::chroma;
namespace fs = std::filesystem;

namespace {

/// Sets (or unsets) $OCIO for the scope and restores the previous value.
class ScopedOcioEnv {
  public:
    explicit ScopedOcioEnv(const std::optional<std::string>& value) {
        if (const char* old = std::getenv("OCIO")) old_ = old;
        if (value)
            setenv("OCIO", value->c_str(), 1);
        else
            unsetenv("OCIO");
    }
    ~ScopedOcioEnv() {
        if (old_)
            setenv("OCIO", old_->c_str(), 1);
        else
            unsetenv("OCIO");
    }

  private:
    std::optional<std::string> old_;
};

class ColorTempDir : public ::testing::Test {
  protected:
    std::string writeFile(const std::string& name, const std::string& text) {
        const fs::path p = dir_ / name;
        std::ofstream(p) << text;
        return p.string();
    }
    TempDir dir_{"color"};
};

bool contains(const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
}

void expectChroma(const std::optional<Chromaticities>& got, const Chromaticities& want) {
    ASSERT_TRUE(got.has_value());
    for (int i = 0; i < 8; ++i) EXPECT_NEAR((*got)[i], want[i], 1e-6f) << "component " << i;
}

float srgbEncode(float x) {
    return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}

// A tiny user config: "linear" is numerically ACEScg (under another name), "mystery" is not
// identifiable, "aces" is the interchange space.
constexpr const char* kTinyConfig = R"(ocio_profile_version: 2
environment: {}
search_path: ""
roles:
  default: linear
  scene_linear: linear
  aces_interchange: aces
  data: raw
displays:
  Screen:
    - !<View> {name: Plain, colorspace: linear}
colorspaces:
  - !<ColorSpace>
    name: aces
    isdata: false
  - !<ColorSpace>
    name: linear
    isdata: false
    to_scene_reference: !<BuiltinTransform> {style: ACEScg_to_ACES2065-1}
  - !<ColorSpace>
    name: mystery
    isdata: false
    to_scene_reference: !<MatrixTransform> {matrix: [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}
  - !<ColorSpace>
    name: raw
    isdata: true
)";

} // namespace

TEST(ColorBuiltin, ConfigTextIsAValidOcioConfig) {
    std::istringstream in(ColorSystem::builtinConfigText());
    OCIO_NAMESPACE::ConstConfigRcPtr config;
    ASSERT_NO_THROW(config = OCIO_NAMESPACE::Config::CreateFromStream(in));
    EXPECT_NO_THROW(config->validate());
    EXPECT_STREQ(config->getColorSpace("scene_linear")->getName(), "ACEScg");
    EXPECT_STREQ(config->getColorSpace("default")->getName(), "ACEScg");
}

TEST(ColorBuiltin, LoadWithoutOcioUsesBuiltinConfigWithRequiredSpacesAndViews) {
    ScopedOcioEnv env(std::nullopt);
    const ColorSystem cs = ColorSystem::load();
    EXPECT_TRUE(cs.isBuiltin());
    EXPECT_EQ(cs.description(), "built-in Nimbus config (OCIO 2.1 BuiltinTransforms)");
    const auto names = cs.colorSpaceNames();
    for (const char* n : {"ACEScg", "ACES2065-1", "lin_rec709", "sRGB", "raw"}) {
        EXPECT_TRUE(contains(names, n)) << n;
        EXPECT_TRUE(cs.hasColorSpace(n)) << n;
    }
    EXPECT_FALSE(cs.hasColorSpace("no_such_space"));
    EXPECT_FALSE(cs.hasColorSpace(""));
    EXPECT_TRUE(cs.hasColorSpace("scene_linear")); // roles resolve
    EXPECT_EQ(cs.canonicalName("scene_linear"), "ACEScg");
    EXPECT_EQ(cs.canonicalName("lin_srgb"), "lin_rec709"); // alias
    EXPECT_EQ(cs.sceneLinearSpace(), "ACEScg");

    EXPECT_TRUE(contains(cs.displays(), "sRGB"));
    const auto views = cs.views("sRGB");
    EXPECT_TRUE(contains(views, "ACES 1.0 SDR-video"));
    EXPECT_TRUE(contains(views, "Un-tone-mapped"));
    EXPECT_EQ(cs.defaultDisplay(), "sRGB");
    EXPECT_EQ(cs.defaultView("sRGB"), "ACES 1.0 SDR-video");
}

TEST(ColorConvert, Ap1ToRec709MatchesKnownMatrixColumn) {
    const ColorSystem cs = ColorSystem::builtin();
    const glm::vec3 r = cs.convert(glm::vec3(1, 0, 0), "ACEScg", "lin_rec709");
    EXPECT_NEAR(r.x, 1.70505f, 1e-4f);
    EXPECT_NEAR(r.y, -0.13026f, 1e-4f);
    EXPECT_NEAR(r.z, -0.02400f, 1e-4f);
    // AP0 -> AP1, first column of the ACES matrix.
    const glm::vec3 a = cs.convert(glm::vec3(1, 0, 0), "ACES2065-1", "ACEScg");
    EXPECT_NEAR(a.x, 1.4514393f, 1e-5f);
    EXPECT_NEAR(a.y, -0.0765538f, 1e-5f);
    EXPECT_NEAR(a.z, 0.0083161f, 1e-5f);
    // Neutral stays neutral (both spaces are white balanced to their whites by Bradford).
    const glm::vec3 g = cs.convert(glm::vec3(0.18f), "ACEScg", "lin_rec709");
    EXPECT_NEAR(g.x, 0.18f, 1e-5f);
    EXPECT_NEAR(g.y, 0.18f, 1e-5f);
    EXPECT_NEAR(g.z, 0.18f, 1e-5f);
}

TEST(ColorConvert, RoundTripsWithin1e5) {
    const ColorSystem cs = ColorSystem::builtin();
    const std::vector<glm::vec3> colors{{1, 0, 0},           {0, 1, 0},          {0, 0, 1},
                                        {0.18f, 0.5f, 0.9f}, {3.0f, 0.2f, 7.5f}, {0, 0, 0}};
    for (const char* other : {"lin_rec709", "ACES2065-1", "sRGB", "CIE-XYZ-D65"}) {
        for (const glm::vec3& c : colors) {
            const glm::vec3 back = cs.convert(cs.convert(c, "ACEScg", other), other, "ACEScg");
            for (int i = 0; i < 3; ++i)
                EXPECT_NEAR(back[i], c[i], 1e-5f * std::max(1.0f, std::fabs(c[i])))
                    << other << " component " << i;
        }
    }
}

TEST(ColorConvert, SrgbEncodingAndRawIdentity) {
    const ColorSystem cs = ColorSystem::builtin();
    const glm::vec3 s = cs.convert(glm::vec3(0.18f, 0.0f, 1.0f), "lin_rec709", "sRGB");
    EXPECT_NEAR(s.x, srgbEncode(0.18f), 1e-5f);
    EXPECT_NEAR(s.y, 0.0f, 1e-6f);
    EXPECT_NEAR(s.z, 1.0f, 1e-5f);
    const glm::vec3 raw = cs.convert(glm::vec3(0.3f, -2.0f, 5.0f), "ACEScg", "raw");
    EXPECT_EQ(raw, glm::vec3(0.3f, -2.0f, 5.0f));
    EXPECT_TRUE(cs.isLinearConversion("ACEScg", "lin_rec709"));
    EXPECT_FALSE(cs.isLinearConversion("ACEScg", "sRGB"));
}

TEST(ColorConvert, ConvertPixelsMatchesConvertAndLeavesAlphaAlone) {
    const ColorSystem cs = ColorSystem::builtin();
    std::vector<float> px{0.2f, 0.4f, 0.6f, 0.25f, 1.0f, 0.0f, 0.0f, 1.0f, 0.1f, 0.1f, 0.1f, 0.0f};
    const std::vector<float> orig = px;
    cs.convertPixels(px.data(), 3, 1, 4, "ACEScg", "lin_rec709");
    for (int i = 0; i < 3; ++i) {
        const glm::vec3 want = cs.convert(glm::vec3(orig[i * 4], orig[i * 4 + 1], orig[i * 4 + 2]),
                                          "ACEScg", "lin_rec709");
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(px[i * 4 + c], want[c], 1e-6f);
        EXPECT_EQ(px[i * 4 + 3], orig[i * 4 + 3]) << "alpha changed";
    }
    // RGB only.
    std::vector<float> rgb{1.0f, 0.0f, 0.0f};
    cs.convertPixels(rgb.data(), 1, 1, 3, "ACEScg", "lin_rec709");
    EXPECT_NEAR(rgb[0], 1.70505f, 1e-4f);
    // Premultiplied through a non-linear conversion: unpremultiply, convert, premultiply.
    std::vector<float> pm{0.09f, 0.09f, 0.09f, 0.5f};
    cs.convertPixels(pm.data(), 1, 1, 4, "lin_rec709", "sRGB", true);
    EXPECT_NEAR(pm[0], 0.5f * srgbEncode(0.18f), 1e-5f);
    EXPECT_EQ(pm[3], 0.5f);
    EXPECT_THROW(cs.convertPixels(px.data(), 3, 1, 2, "ACEScg", "lin_rec709"), std::runtime_error);
}

TEST(ColorConvert, UnknownColorSpaceErrorNamesItAndListsValidOnes) {
    const ColorSystem cs = ColorSystem::builtin();
    auto expectError = [](const std::function<void()>& f, const std::string& unknown) {
        try {
            f();
            ADD_FAILURE() << "no exception for '" << unknown << "'";
        } catch (const std::runtime_error& e) {
            const std::string msg = e.what();
            EXPECT_NE(msg.find("'" + unknown + "'"), std::string::npos) << msg;
            EXPECT_NE(msg.find("ACEScg"), std::string::npos) << msg;
            EXPECT_NE(msg.find("lin_rec709"), std::string::npos) << msg;
        }
    };
    float px[4] = {0, 0, 0, 1};
    expectError([&] { cs.convert(glm::vec3(1), "ACEScgg", "lin_rec709"); }, "ACEScgg");
    expectError([&] { cs.convert(glm::vec3(1), "ACEScg", "Rec709"); }, "Rec709");
    expectError([&] { cs.convertPixels(px, 1, 1, 4, "bogus", "ACEScg"); }, "bogus");
    expectError([&] { cs.applyDisplayView(px, 1, 1, 4, "nope", "sRGB", "Un-tone-mapped"); },
                "nope");
    expectError([&] { cs.chromaticities("what"); }, "what");
    expectError([&] { cs.canonicalName("who"); }, "who");

    try {
        cs.applyDisplayView(px, 1, 1, 4, "ACEScg", "sRGB", "Filmic");
        ADD_FAILURE() << "no exception for an unknown view";
    } catch (const std::runtime_error& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("'Filmic'"), std::string::npos) << msg;
        EXPECT_NE(msg.find("Un-tone-mapped"), std::string::npos) << msg;
    }
    try {
        cs.applyDisplayView(px, 1, 1, 4, "ACEScg", "P3", "Un-tone-mapped");
        ADD_FAILURE() << "no exception for an unknown display";
    } catch (const std::runtime_error& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("'P3'"), std::string::npos) << msg;
        EXPECT_NE(msg.find("sRGB"), std::string::npos) << msg;
    }
}

TEST(ColorDisplayView, UntonemappedIsSrgbEncodingAndAcesViewCompresses) {
    const ColorSystem cs = ColorSystem::builtin();
    std::vector<float> px{0.18f, 0.18f, 0.18f, 0.7f};
    cs.applyDisplayView(px.data(), 1, 1, 4, "ACEScg", "sRGB", "Un-tone-mapped");
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(px[c], srgbEncode(0.18f), 1e-4f);
    EXPECT_EQ(px[3], 0.7f);

    // ACES 1.0 SDR-video: monotonic in exposure, black stays ~black, huge values roll off to
    // display white (OCIO's builtin output transform overshoots 1 by a few percent for extreme
    // values before the display clamp; the PNG writer clamps).
    std::vector<float> ramp;
    for (float v : {0.0f, 0.01f, 0.18f, 1.0f, 10.0f, 1000.0f}) ramp.insert(ramp.end(), {v, v, v});
    cs.applyDisplayView(ramp.data(), 6, 1, 3, "ACEScg", "sRGB", "ACES 1.0 SDR-video");
    EXPECT_NEAR(ramp[0], 0.0f, 1e-3f);
    for (int i = 1; i < 6; ++i) EXPECT_GT(ramp[i * 3], ramp[(i - 1) * 3]) << "step " << i;
    EXPECT_LT(ramp[15], 1.05f);
    EXPECT_GT(ramp[15], 0.95f);
    EXPECT_LT(ramp[6], srgbEncode(0.18f)); // the tone curve darkens mid grey
}

TEST(ColorChromaticities, KnownSpacesOfTheBuiltinConfig) {
    const ColorSystem cs = ColorSystem::builtin();
    expectChroma(cs.chromaticities("ACEScg"), chroma::AP1);
    expectChroma(cs.chromaticities("ACES2065-1"), chroma::AP0);
    expectChroma(cs.chromaticities("lin_rec709"), chroma::Rec709);
    expectChroma(cs.chromaticities("sRGB"), chroma::Rec709);
    expectChroma(cs.chromaticities("scene_linear"), chroma::AP1);
    EXPECT_NEAR(chroma::AP1[0], 0.713f, 1e-6f);
    EXPECT_NEAR(chroma::Rec709[6], 0.3127f, 1e-6f);
    EXPECT_FALSE(cs.chromaticities("raw").has_value());
}

TEST_F(ColorTempDir, OcioEnvironmentVariableIsHonoured) {
    const std::string path = writeFile("tiny.ocio", kTinyConfig);
    {
        ScopedOcioEnv env(path);
        const ColorSystem cs = ColorSystem::load();
        EXPECT_FALSE(cs.isBuiltin());
        EXPECT_EQ(cs.description(), "$OCIO=" + path);
        auto names = cs.colorSpaceNames();
        std::sort(names.begin(), names.end());
        EXPECT_EQ(names, (std::vector<std::string>{"aces", "linear", "mystery", "raw"}));
        EXPECT_FALSE(cs.hasColorSpace("ACEScg"));
        EXPECT_EQ(cs.sceneLinearSpace(), "linear");
        EXPECT_EQ(cs.displays(), std::vector<std::string>{"Screen"});
        // "mystery" doubles red relative to ACES2065-1.
        const glm::vec3 m = cs.convert(glm::vec3(1, 0, 0), "mystery", "aces");
        EXPECT_NEAR(m.x, 2.0f, 1e-6f);
        // Chromaticities: "linear" is identified numerically as AP1, "mystery" is not known.
        expectChroma(cs.chromaticities("linear"), chroma::AP1);
        expectChroma(cs.chromaticities("aces"), chroma::AP0);
        EXPECT_FALSE(cs.chromaticities("mystery").has_value());
        EXPECT_FALSE(cs.chromaticities("raw").has_value());
        try {
            cs.convert(glm::vec3(1), "ACEScg", "linear");
            ADD_FAILURE() << "ACEScg is not in the user config";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("mystery"), std::string::npos) << e.what();
        }
    }
    // After unsetenv: the built-in config again.
    ScopedOcioEnv none(std::nullopt);
    EXPECT_TRUE(ColorSystem::load().isBuiltin());
}

TEST_F(ColorTempDir, OcioEnvironmentWithTheBuiltinTextGivesTheSameConversions) {
    const std::string path = writeFile("nimbus.ocio", ColorSystem::builtinConfigText());
    ScopedOcioEnv env(path);
    const ColorSystem user = ColorSystem::load();
    const ColorSystem builtin = ColorSystem::builtin();
    EXPECT_EQ(user.description(), "$OCIO=" + path);
    const glm::vec3 a = user.convert(glm::vec3(0.3f, 0.6f, 0.9f), "ACEScg", "sRGB");
    const glm::vec3 b = builtin.convert(glm::vec3(0.3f, 0.6f, 0.9f), "ACEScg", "sRGB");
    for (int i = 0; i < 3; ++i) EXPECT_FLOAT_EQ(a[i], b[i]);
    // Identified numerically through the aces_interchange role.
    expectChroma(user.chromaticities("ACEScg"), chroma::AP1);
    expectChroma(user.chromaticities("sRGB"), chroma::Rec709);
}

TEST_F(ColorTempDir, UnloadableOcioConfigErrorNamesThePath) {
    const std::string path = (dir_ / "missing.ocio").string();
    ScopedOcioEnv env(path);
    try {
        ColorSystem::load();
        ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    const std::string broken = writeFile("broken.ocio", "ocio_profile_version: 2\ncolorspaces: [");
    EXPECT_THROW(ColorSystem::fromFile(broken), std::runtime_error);
}
