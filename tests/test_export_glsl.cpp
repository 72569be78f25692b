/// @file test_export_glsl.cpp
/// @brief `nimbus export-glsl` (plugin/realtime/export_glsl.h): the feature preprocessor and the
/// removal of unreferenced declarations on texts with known answers, the JSON's std430 offsets
/// against the C++ struct's offsetof, a disabled feature's code absent from the exported text
/// (present when enabled), and an export written by the command, read back from its files alone
/// (march.comp, params.json) and dispatched through the EGL compute context, against `nimbus rt`'s
/// pass on the same frame. The command line's errors and glslangValidator on every variant:
/// tests/export_glsl_check.py.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "plugin/host/session.h"
#include "plugin/realtime/export_glsl.h"
#include "plugin/realtime/gl_compute.h"
#include "plugin/realtime/march_params.h"
#include "plugin/realtime/rt_march.h"
#include "tests/rt_vdb_scene.h"
#include "tests/test_util.h"

using namespace nimbus;

namespace {

const std::string kScene = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/cumulus.toml";

const std::vector<std::pair<std::string, bool>> kMacros = {{"RT_A", true}, {"RT_B", false}};

std::string strip(const std::string& text, std::string* error = nullptr) {
    std::string out, e;
    if (!rt::stripFeatureConditionals(text, kMacros, out, &e)) {
        if (error) *error = e;
        return "<error: " + e + ">";
    }
    return out;
}

// --- a small JSON reader (the export's JSON only needs objects, arrays, strings, numbers,
// booleans); numbers keep their text so floats are read with strtof, exactly -----------------

struct Json {
    enum Kind { Null, Bool, Number, String, Array, Object } kind = Null;
    bool b = false;
    std::string text; // number text or string
    std::vector<Json> items;
    std::vector<std::pair<std::string, Json>> members;

    const Json& operator[](const std::string& k) const {
        for (const auto& m : members)
            if (m.first == k) return m.second;
        static const Json none;
        ADD_FAILURE() << "JSON: no member " << k;
        return none;
    }
    long integer() const { return std::strtol(text.c_str(), nullptr, 10); }
    bool has(const std::string& k) const {
        for (const auto& m : members)
            if (m.first == k) return true;
        return false;
    }
};

class JsonReader {
  public:
    explicit JsonReader(const std::string& s) : s_(s) {}
    bool read(Json& v) {
        value(v);
        space();
        return ok_ && i_ == s_.size();
    }

  private:
    void space() {
        while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
    }
    bool eat(char c) {
        space();
        if (i_ < s_.size() && s_[i_] == c) {
            ++i_;
            return true;
        }
        return false;
    }
    void string(std::string& out) {
        if (!eat('"')) {
            ok_ = false;
            return;
        }
        while (i_ < s_.size() && s_[i_] != '"') {
            if (s_[i_] == '\\' && i_ + 1 < s_.size()) {
                const char e = s_[++i_];
                out += e == 'n' ? '\n' : e == 't' ? '\t' : e;
                if (e == 'u') i_ += 4; // (control characters only; not used by the export)
            } else {
                out += s_[i_];
            }
            ++i_;
        }
        ok_ = ok_ && eat('"');
    }
    void value(Json& v) {
        space();
        if (i_ >= s_.size()) {
            ok_ = false;
            return;
        }
        const char c = s_[i_];
        if (c == '{') {
            ++i_;
            v.kind = Json::Object;
            if (eat('}')) return;
            do {
                std::pair<std::string, Json> m;
                string(m.first);
                if (!eat(':')) ok_ = false;
                value(m.second);
                v.members.push_back(std::move(m));
            } while (ok_ && eat(','));
            ok_ = ok_ && eat('}');
        } else if (c == '[') {
            ++i_;
            v.kind = Json::Array;
            if (eat(']')) return;
            do {
                v.items.emplace_back();
                value(v.items.back());
            } while (ok_ && eat(','));
            ok_ = ok_ && eat(']');
        } else if (c == '"') {
            v.kind = Json::String;
            string(v.text);
        } else if (s_.compare(i_, 4, "true") == 0 || s_.compare(i_, 5, "false") == 0) {
            v.kind = Json::Bool;
            v.b = s_[i_] == 't';
            i_ += v.b ? 4 : 5;
        } else if (s_.compare(i_, 4, "null") == 0) {
            i_ += 4;
        } else {
            v.kind = Json::Number;
            const std::size_t j = i_;
            while (i_ < s_.size() && (std::isdigit(static_cast<unsigned char>(s_[i_])) ||
                                      std::strchr("+-.eE", s_[i_])))
                ++i_;
            v.text = s_.substr(j, i_ - j);
            ok_ = ok_ && !v.text.empty();
        }
    }
    const std::string& s_;
    std::size_t i_ = 0;
    bool ok_ = true;
};

std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// The parameter block packed from the JSON's members alone (name, type, offset, value).
std::vector<std::uint8_t> packFromJson(const Json& block) {
    std::vector<std::uint8_t> out(std::size_t(block["bytes"].integer()), 0);
    for (const Json& m : block["members"].items) {
        const std::string type = m["type"].text;
        std::uint8_t* at = out.data() + m["offset"].integer();
        if (type == "vec4") {
            for (int c = 0; c < 4; ++c) {
                const float f =
                    std::strtof(m["value"].items.at(std::size_t(c)).text.c_str(), nullptr);
                std::memcpy(at + 4 * c, &f, 4);
            }
        } else if (type == "float") {
            const float f = std::strtof(m["value"].text.c_str(), nullptr);
            std::memcpy(at, &f, 4);
        } else if (type == "int") {
            const std::int32_t x = std::int32_t(std::strtol(m["value"].text.c_str(), nullptr, 10));
            std::memcpy(at, &x, 4);
        } else {
            const std::uint32_t x =
                std::uint32_t(std::strtoul(m["value"].text.c_str(), nullptr, 10));
            std::memcpy(at, &x, 4);
        }
    }
    return out;
}

} // namespace

// --- the preprocessor -------------------------------------------------------------------------

TEST(ExportGlslStrip, KeepsTrueBranchesAndDropsFalseOnes) {
    EXPECT_EQ(strip("a\n#if RT_A\nb\n#endif\nc\n"), "a\n#line 3 0\nb\n#line 5 0\nc\n");
    EXPECT_EQ(strip("a\n#if RT_B\nb\n#endif\nc\n"), "a\n#line 5 0\nc\n");
    EXPECT_EQ(strip("#if RT_B\nb\n#else\nc\n#endif\n"), "#line 4 0\nc\n");
    EXPECT_EQ(strip("#if RT_B\nb\n#elif RT_A\nc\n#else\nd\n#endif\n"), "#line 4 0\nc\n");
    EXPECT_EQ(strip("#if !RT_B && (RT_A || RT_B)\nx\n#endif\n"), "#line 2 0\nx\n");
    EXPECT_EQ(strip("#if RT_A == 0\nx\n#endif\ny\n"), "#line 4 0\ny\n");
    EXPECT_EQ(strip("#ifdef RT_B\nx\n#endif\n#ifndef RT_A\ny\n#endif\n"), "#line 2 0\nx\n");
    // nested: an inner block of a removed branch goes with it, whatever its own value
    EXPECT_EQ(strip("#if RT_B\n#if RT_A\nx\n#endif\n#endif\nz\n"), "#line 6 0\nz\n");
    // a comment after the directive, indentation
    EXPECT_EQ(strip("  #  if RT_B // the sun\nx\n  #endif // RT_B\nz"), "#line 4 0\nz");
    // #line directives renumber: after a removed block the numbering of the source string goes on
    EXPECT_EQ(strip("#line 1 7\na\n#if RT_B\nb\n#endif\nc\n"), "#line 1 7\na\n#line 5 7\nc\n");
}

TEST(ExportGlslStrip, LeavesOtherConditionalsToTheCompiler) {
    EXPECT_EQ(strip("#if FOO\na\n#else\nb\n#endif\n"), "#if FOO\na\n#else\nb\n#endif\n");
    EXPECT_EQ(strip("#ifdef GL_ES\n#if RT_B\nx\n#endif\ny\n#endif\n"),
              "#ifdef GL_ES\n#line 5 0\ny\n#endif\n");
    // a foreign block inside a removed one is removed with it
    EXPECT_EQ(strip("#if RT_B\n#ifdef GL_ES\nx\n#endif\n#endif\n"), "");
    EXPECT_EQ(strip("#define RT_A 1\n#version 430\n"), "#define RT_A 1\n#version 430\n");
}

TEST(ExportGlslStrip, RefusesWhatItCannotDecide) {
    std::string e;
    strip("#if RT_A && FOO\nx\n#endif\n", &e);
    EXPECT_TRUE(contains(e, "mixes the feature macros")) << e;
    e.clear();
    strip("#if RT_A\nx\n", &e);
    EXPECT_TRUE(contains(e, "without its #endif")) << e;
    e.clear();
    strip("x\n#endif\n", &e);
    EXPECT_TRUE(contains(e, "line 2")) << e;
    e.clear();
    strip("#if RT_A +\nx\n#endif\n", &e);
    EXPECT_TRUE(contains(e, "cannot evaluate")) << e;
    e.clear();
    strip("#ifdef FOO\n#elif RT_A\n#endif\n", &e);
    EXPECT_TRUE(contains(e, "names a feature macro")) << e;
}

// --- unreferenced declarations ---------------------------------------------------------------

std::string prune(const std::string& text, std::string* error = nullptr) {
    std::string out, e;
    if (!rt::removeUnreferenced(text, out, &e)) {
        if (error) *error = e;
        return "<error: " + e + ">";
    }
    return out;
}

TEST(ExportGlslPrune, KeepsWhatMainReaches) {
    const std::string text = "#version 430\n"
                             "const int A = 1;\n"
                             "const int B = A + 1;\n"
                             "const int C = 3;\n"
                             "struct S {\n    int x;\n};\n"
                             "struct Unused {\n    int y;\n};\n"
                             "// f's comment\n"
                             "int f(S s) { return s.x + B; }\n"
                             "\n"
                             "// g's comment, with { and ; in it\n"
                             "int g() {\n    return C; // not A\n}\n"
                             "int h(int v);\n"
                             "layout(std430, binding = 0) buffer Out { int o[]; };\n"
                             "void main() {\n    S s;\n    o[0] = f(s);\n}\n";
    EXPECT_EQ(prune(text), "#version 430\n"
                           "const int A = 1;\n"
                           "const int B = A + 1;\n"
                           "#line 5 0\n"
                           "struct S {\n    int x;\n};\n"
                           "#line 11 0\n"
                           "// f's comment\n"
                           "int f(S s) { return s.x + B; }\n"
                           "\n"
                           "#line 19 0\n"
                           "layout(std430, binding = 0) buffer Out { int o[]; };\n"
                           "void main() {\n    S s;\n    o[0] = f(s);\n}\n");
    // #line directives, also inside a body, set the numbers the renumbering uses
    EXPECT_EQ(prune("#line 1 4\nint u() {\n#line 40 4\n return 0;\n}\nint k = 2;\n"
                    "void main() { k; }\n"),
              "#line 1 4\n#line 42 4\nint k = 2;\nvoid main() { k; }\n");
}

TEST(ExportGlslPrune, RefusesWhatItCannotSplit) {
    std::string e;
    prune("void main() {\n", &e);
    EXPECT_TRUE(contains(e, "unbalanced")) << e;
    e.clear();
    prune("int f() { return 1; }\n", &e);
    EXPECT_TRUE(contains(e, "no main()")) << e;
    e.clear();
    prune("}\nvoid main() {}\n", &e);
    EXPECT_TRUE(contains(e, "line 1")) << e;
}

// --- the parameter block ----------------------------------------------------------------------

// The layout read from march_params.glsl by the std430 rules is the C++ struct's: every member
// at its offsetof, in order, with nothing left out.
TEST(ExportGlslParams, Std430OffsetsAreTheCppOffsets) {
    std::vector<rt::ParamMember> members;
    std::size_t bytes = 0;
    std::string error;
    ASSERT_TRUE(rt::paramBlockLayout(members, &bytes, &error)) << error;
    using P = rt::RtMarchParams;
    const std::vector<std::pair<std::string, std::size_t>> cpp = {
#define NB_MEMBER(m) {#m, offsetof(P, m)}
        NB_MEMBER(camOrigin),
        NB_MEMBER(camForward),
        NB_MEMBER(camRight),
        NB_MEMBER(camUp),
        NB_MEMBER(boundsLo),
        NB_MEMBER(boundsHi),
        NB_MEMBER(sunDirection),
        NB_MEMBER(sunIrradiance),
        NB_MEMBER(sigmaS),
        NB_MEMBER(sigmaT),
        NB_MEMBER(skyZenith),
        NB_MEMBER(skyHorizon),
        NB_MEMBER(skySphere),
        NB_MEMBER(baseOffset),
        NB_MEMBER(detailOffset),
        NB_MEMBER(sigmaTr),
        NB_MEMBER(diffusionLo),
        NB_MEMBER(diffusionVoxel),
        NB_MEMBER(photonLo),
        NB_MEMBER(photonVoxel),
        NB_MEMBER(skinLo),
        NB_MEMBER(skinVoxel),
        NB_MEMBER(majorantLo),
        NB_MEMBER(majorantCell),
        NB_MEMBER(lightLo),
        NB_MEMBER(lightHi),
        NB_MEMBER(lightVoxel),
        NB_MEMBER(skyVolumeLo),
        NB_MEMBER(skyVolumeVoxel),
        NB_MEMBER(layerBottom),
        NB_MEMBER(layerTop),
        NB_MEMBER(heightA),
        NB_MEMBER(heightB),
        NB_MEMBER(coverage),
        NB_MEMBER(softness),
        NB_MEMBER(erosion),
        NB_MEMBER(towerSpacing),
        NB_MEMBER(towerRadiusMin),
        NB_MEMBER(towerRadiusMax),
        NB_MEMBER(towerHeightMin),
        NB_MEMBER(towerHeightMax),
        NB_MEMBER(towerProbability),
        NB_MEMBER(towerAnisotropy),
        NB_MEMBER(fieldSeed),
        NB_MEMBER(fieldDensity),
        NB_MEMBER(basePeriod),
        NB_MEMBER(baseLattice),
        NB_MEMBER(baseOctaves),
        NB_MEMBER(detailPeriod),
        NB_MEMBER(detailLattice),
        NB_MEMBER(detailOctaves),
        NB_MEMBER(phaseKind),
        NB_MEMBER(phaseG),
        NB_MEMBER(phaseG2),
        NB_MEMBER(phaseBlend),
        NB_MEMBER(phaseAlpha),
        NB_MEMBER(phaseDiameter),
        NB_MEMBER(tanHalfY),
        NB_MEMBER(aspect),
        NB_MEMBER(width),
        NB_MEMBER(height),
        NB_MEMBER(frameKey),
        NB_MEMBER(jitter),
        NB_MEMBER(epsilon),
        NB_MEMBER(step),
        NB_MEMBER(stepGrowth),
        NB_MEMBER(shadowStep),
        NB_MEMBER(shadowGrowth),
        NB_MEMBER(stepTau),
        NB_MEMBER(octaves),
        NB_MEMBER(octaveContribution),
        NB_MEMBER(octaveExtinction),
        NB_MEMBER(octaveEccentricity),
        NB_MEMBER(octaveGate),
        NB_MEMBER(inScatter),
        NB_MEMBER(inScatterC),
        NB_MEMBER(inScatterStrength),
        NB_MEMBER(skyKind),
        NB_MEMBER(ambientGround),
        NB_MEMBER(pixelSamples),
        NB_MEMBER(filterKind),
        NB_MEMBER(filterWidth),
        NB_MEMBER(sampleIndex),
        NB_MEMBER(mieNodes),
        NB_MEMBER(diffusionResX),
        NB_MEMBER(diffusionResY),
        NB_MEMBER(diffusionResZ),
        NB_MEMBER(photonResX),
        NB_MEMBER(photonResY),
        NB_MEMBER(photonResZ),
        NB_MEMBER(skinResX),
        NB_MEMBER(skinResY),
        NB_MEMBER(skinResZ),
        NB_MEMBER(skinK),
        NB_MEMBER(skinFloor),
        NB_MEMBER(msP1),
        NB_MEMBER(mediumG),
        NB_MEMBER(vdbDensity),
        NB_MEMBER(baseBakeRes),
        NB_MEMBER(detailBakeRes),
        NB_MEMBER(majorantResX),
        NB_MEMBER(majorantResY),
        NB_MEMBER(majorantResZ),
        NB_MEMBER(lightResX),
        NB_MEMBER(lightResY),
        NB_MEMBER(lightResZ),
        NB_MEMBER(skyVolumeResX),
        NB_MEMBER(skyVolumeResY),
        NB_MEMBER(skyVolumeResZ),
        NB_MEMBER(skyDirections),
        NB_MEMBER(sdfScale),
        NB_MEMBER(sdfFalloff),
        NB_MEMBER(sdfNodeCount),
        NB_MEMBER(sliceIndex),
        NB_MEMBER(sliceSteps),
        NB_MEMBER(loopProbe),
#undef NB_MEMBER
    };
    ASSERT_EQ(members.size(), cpp.size());
    for (std::size_t i = 0; i < cpp.size(); ++i) {
        EXPECT_EQ(members[i].name, cpp[i].first);
        EXPECT_EQ(members[i].offset, cpp[i].second) << cpp[i].first;
        EXPECT_FALSE(rt::paramDoc(members[i].name).meaning.empty()) << members[i].name;
        EXPECT_FALSE(rt::paramDoc(members[i].name).units.empty()) << members[i].name;
    }
    EXPECT_EQ(members.back().offset + members.back().size, sizeof(P));
    EXPECT_EQ(bytes, (sizeof(P) + 15) / 16 * 16);
}

// The JSON of an export parses, and its offsets and values are the struct's, by offsetof.
TEST(ExportGlslParams, JsonMatchesTheStruct) {
    host::Session session;
    ASSERT_TRUE(session
                    .load(kScene, {"camera.width=48", "camera.height=27",
                                   "render.multiple_scattering=\"none\"", "render.pixel_samples=4"})
                    .ok());
    const FramePlan plan = session.plan(7);
    // (4 samples per pixel: the plan bakes the noise under "auto", the export needs the tiles)
    const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
    rt::GlslExport e;
    std::string error;
    ASSERT_TRUE(rt::exportGlsl(session.scene(), plan, kScene, nullptr, &session.bindings(), &noise,
                               e, &error))
        << error;
    Json doc;
    ASSERT_TRUE(JsonReader(e.json).read(doc)) << e.json;
    EXPECT_EQ(doc["frame"].integer(), 7);
    const Json& block = doc["parameter_block"];
    rt::RtMarchParams P = rt::marchParams(session.scene(), plan);
    P.sampleIndex = 0;
    const std::vector<std::uint8_t> packed = packFromJson(block);
    ASSERT_GE(packed.size(), sizeof P);
    EXPECT_EQ(std::memcmp(packed.data(), &P, sizeof P), 0);
    EXPECT_EQ(packed, e.params);
    for (const Json& m : block["members"].items)
        if (m["name"].text == "frameKey") {
            EXPECT_EQ(std::uint32_t(std::strtoul(m["value"].text.c_str(), nullptr, 10)),
                      P.frameKey);
            EXPECT_EQ(m["offset"].integer(), long(offsetof(rt::RtMarchParams, frameKey)));
        }
    EXPECT_EQ(doc["dispatch"]["passes"].integer(), 4);
    EXPECT_EQ(doc["workgroup_size"].items.at(0).integer(), 8);
}

// --- the shader text --------------------------------------------------------------------------

// A disabled feature's code is not in the exported text; an enabled one's is, without its #if.
TEST(ExportGlslShader, DisabledFeaturesAreAbsent) {
    host::Session session;
    ASSERT_TRUE(session
                    .load(kScene, {"camera.width=32", "camera.height=18",
                                   "render.multiple_scattering=\"none\""})
                    .ok());
    SceneDesc on = session.scene();
    on.render.pixelSamples = 4;
    SceneDesc off = session.scene();
    off.sun.enabled = false;
    off.sky.ambient = 0.0f;
    off.render.background = Background::Transparent;
    rt::GlslExport a, b;
    std::string error;
    // `on` skips empty space with the frame's majorant grid (RT_SKIP); `off` has no grid
    const MajorantGrid majorant =
        rt::majorantGrid(session.renderer(), session.plan(1), session.bindings());
    ASSERT_TRUE(rt::exportGlsl(on, planFrame(on, 1), kScene, nullptr, nullptr, nullptr, &majorant,
                               a, &error))
        << error;
    ASSERT_TRUE(rt::exportGlsl(off, planFrame(off, 1), kScene, b, &error)) << error;
    EXPECT_TRUE(a.features.sun && a.features.ambient && a.features.backgroundSky &&
                a.features.multisample && a.features.skip);
    EXPECT_TRUE(!b.features.sun && !b.features.ambient && !b.features.backgroundSky &&
                !b.features.multisample && !b.features.skip);
    const std::vector<std::string> sun = {"float rtDensityIntegral(", "rtDensityIntegral(F, p",
                                          "vec3 ph = vec3(phaseEval(octavePhase, cosTheta));",
                                          "sun += octaveSun(ph, sigmaT"};
    const std::vector<std::string> others = {
        "skyHeightInScatter(rtXyz(P.skySphere)", "L += T * rtSkyRadiance(P, d);",
        "pixelSampleOffset(k, ns",
        // RT_SKIP: the majorant grid's buffer, its lookup and the jump, in both marches
        "buffer RtMajorant", "bool rtEmptyCell(", "int rtSkipTo(",
        "n = rtSkipTo(s, n, tExit, tOut);", "rtEmptyCell(o, d, o + d * (tA + jitter * dt), tExit)",
        "bool rtEdgeStep("};
    for (const std::string& s : sun) {
        EXPECT_TRUE(contains(a.shader, s)) << s;
        EXPECT_FALSE(contains(b.shader, s)) << s;
    }
    for (const std::string& s : others) {
        EXPECT_TRUE(contains(a.shader, s)) << s;
        EXPECT_FALSE(contains(b.shader, s)) << s;
    }
    // the shadow march is gone as a word, not only as a call
    EXPECT_EQ(b.shader.find("rtDensityIntegral"), std::string::npos);
    // and the kernels only a disabled feature calls are gone too (removeUnreferenced)
    for (const std::string s :
         {"NB_FN vec3 octaveSun(", "NB_FN float inScatterFactor(", "NB_FN PhaseParams phaseOctave(",
          "NB_FN vec3 skyHeightInScatter(", "NB_FN vec2 pixelSampleOffset(",
          "NB_FN float pixelFilterWeight("}) {
        EXPECT_TRUE(contains(a.shader, s)) << s;
        EXPECT_FALSE(contains(b.shader, s)) << s;
    }
    // the kernels of other fields are in nimbus rt's text, not in either export
    const std::string rtText = rt::marchShader(on, planFrame(on, 1)).source;
    for (const std::string s : {"NB_FN float sdSphere(", "sdBox("}) {
        EXPECT_TRUE(contains(rtText, s)) << s;
        EXPECT_FALSE(contains(a.shader, s)) << s;
        EXPECT_FALSE(contains(b.shader, s)) << s;
    }
    // the skipping words are gone from the text without RT_SKIP, not only their calls
    for (const std::string s : {"rtEmptyCell", "rtSkipTo", "rtMajorant", "majorant.bin"})
        EXPECT_FALSE(contains(b.shader, s)) << s;
    EXPECT_EQ(a.data.size(), 1u);
    if (!a.data.empty()) EXPECT_EQ(a.data.back().first, "majorant.bin");
    EXPECT_TRUE(b.data.empty());
    for (const std::string* t : {&a.shader, &b.shader}) {
        EXPECT_FALSE(contains(*t, "#if RT_"));
        EXPECT_FALSE(contains(*t, "#endif // RT_SUN"));
        EXPECT_EQ(t->rfind("#version 430\n", 0), 0u);
    }
    // nimbus rt's own shader of the sunless frame has the shadow march, switched off by #if
    EXPECT_TRUE(contains(rt::marchShader(off, planFrame(off, 1)).source, "rtDensityIntegral"));
}

// --- the export on the GPU --------------------------------------------------------------------

/// Exports frame 3 of the default scene with `sets` through the command, then compiles the
/// written march.comp and dispatches it with buffers and dispatch taken from params.json alone;
/// returns the PSNR of its RGBA against `nimbus rt`'s pass (MarchPass) on the same frame.
double exportAgainstRt(const std::vector<std::string>& sets, const std::string& tag,
                       std::vector<std::string>& dataFiles, const std::string& scene = kScene,
                       int frame = 3, std::string* shaderOut = nullptr) {
    std::string error;
    gl::ComputeContext* context = gl::ComputeContext::shared(&error);
    EXPECT_NE(context, nullptr) << "no headless OpenGL 4.5 context: " << error;
    if (!context) return 0.0;
    TempDir dir("export_glsl_" + tag);
    std::string args =
        "export-glsl " + scene + " -o " + dir.string() + " --frame " + std::to_string(frame);
    for (const std::string& s : sets) args += " --set '" + s + "'";
    const CliRun run = runNimbus(args);
    EXPECT_EQ(run.exitCode, 0) << run.output;
    Json doc;
    EXPECT_TRUE(JsonReader(readFile(dir.string() + "/params.json")).read(doc));
    const std::string shader = readFile(dir.string() + "/march.comp");
    if (shaderOut) *shaderOut = shader;
    if (run.exitCode != 0 || shader.empty()) return 0.0;

    // the engine's side: the program, the buffers of the JSON, the passes
    gl::ComputeProgram program(shader);
    EXPECT_TRUE(program.valid()) << program.log();
    if (!program.valid()) return 0.0;
    const Json& block = doc["parameter_block"];
    std::vector<std::uint8_t> params = packFromJson(block);
    EXPECT_EQ(params, std::vector<std::uint8_t>([&] {
                  const std::string b = readFile(dir.string() + "/params.bin");
                  return std::vector<std::uint8_t>(b.begin(), b.end());
              }()));
    long sampleOffset = -1;
    for (const Json& m : block["members"].items)
        if (m["name"].text == "sampleIndex") sampleOffset = m["offset"].integer();
    EXPECT_GE(sampleOffset, 0);
    const int w = int(doc["image"]["width"].integer()), h = int(doc["image"]["height"].integer());
    std::size_t pixelBytes = 0, counterBytes = 0;
    long pixelBinding = -1, counterBinding = -1;
    for (const Json& b : doc["buffers"].items) {
        if (b["block"].text == "RtPixels") {
            pixelBytes = std::size_t(b["bytes"].integer());
            pixelBinding = b["binding"].integer();
        }
        if (b["block"].text == "RtCounters") {
            counterBytes = std::size_t(b["bytes"].integer());
            counterBinding = b["binding"].integer();
        }
    }
    EXPECT_EQ(pixelBytes, std::size_t(w) * std::size_t(h) * 12 * 4);
    // the data buffers (Mie table, multiple-scattering grids): the files the JSON names
    std::vector<std::unique_ptr<gl::StorageBuffer>> data;
    for (const Json& b : doc["buffers"].items) {
        if (!b.has("file") || b["block"].text == "RtParamBlock") continue;
        const std::string bytes = readFile(dir.string() + "/" + b["file"].text);
        EXPECT_EQ(bytes.size(), std::size_t(b["bytes"].integer())) << b["file"].text;
        EXPECT_FALSE(bytes.empty()) << b["file"].text;
        data.push_back(std::make_unique<gl::StorageBuffer>(bytes.size(), bytes.data()));
        data.back()->bind(unsigned(b["binding"].integer()));
        dataFiles.push_back(b["file"].text);
    }
    // the 3D textures the JSON names (field.evaluation = "rgba": RGBA8, linear, repeat)
    std::vector<std::unique_ptr<gl::Texture3D>> textures;
    for (const Json& t : doc["textures"].items) {
        const std::string bytes = readFile(dir.string() + "/" + t["file"].text);
        const long res = t["size"].items.at(0).integer();
        EXPECT_EQ(t["size"].items.at(1).integer(), res);
        EXPECT_EQ(t["format"].text, "GL_RGBA8");
        EXPECT_EQ(bytes.size(), std::size_t(4 * res * res * res)) << t["file"].text;
        textures.push_back(std::make_unique<gl::Texture3D>(
            int(res), reinterpret_cast<const std::uint8_t*>(bytes.data())));
        textures.back()->bind(unsigned(t["unit"].integer()));
        dataFiles.push_back(t["file"].text);
    }
    const gl::StorageBuffer pixels(pixelBytes);
    const gl::StorageBuffer counters(counterBytes);
    pixels.bind(unsigned(pixelBinding));
    counters.bind(unsigned(counterBinding));
    const long passes = doc["dispatch"]["passes"].integer();
    const Json& groups = doc["dispatch"]["groups"];
    for (long k = 0; k < passes; ++k) {
        const std::int32_t index = std::int32_t(k);
        std::memcpy(params.data() + sampleOffset, &index, 4);
        const gl::StorageBuffer p(params.size(), params.data());
        p.bind(unsigned(block["binding"].integer()));
        program.dispatch(unsigned(groups.items.at(0).integer()),
                         unsigned(groups.items.at(1).integer()),
                         unsigned(groups.items.at(2).integer()));
    }
    std::vector<float> sums(pixelBytes / 4);
    pixels.read(sums.data(), pixelBytes);
    EXPECT_EQ(gl::glErrors(), "");
    std::vector<float> rgba(std::size_t(w) * std::size_t(h) * 4);
    std::size_t cloudy = 0; // pixels the export sees clouds in: transmittance (red) below 0.9
    for (std::size_t i = 0; i < std::size_t(w) * std::size_t(h); ++i) {
        const float* q = &sums[12 * i];
        if (q[7] > 0.0f && q[4] / q[7] < 0.9f) ++cloudy;
        for (int c = 0; c < 4; ++c) rgba[4 * i + std::size_t(c)] = q[7] > 0.0f ? q[c] / q[7] : q[c];
    }

    // nimbus rt's pass on the same frame
    host::Session session;
    EXPECT_TRUE(session.load(scene, sets).ok());
    EXPECT_TRUE(session.bind(frame).ok()); // a VDB field's grid
    Framebuffer fb;
    rt::MarchStats stats;
    rt::MarchPass pass;
    const FramePlan plan = session.plan(frame);
    MarchGrids grids;
    if (rt::readsMarchGrids(plan)) {
        RenderStats gridStats;
        grids = session.renderer().marchGrids(plan, session.bindings(), gridStats);
    }
    const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
    // the majorant grid `nimbus rt` and the export skip with (RT_SKIP)
    const MajorantGrid majorant = rt::majorantGrid(session.renderer(), plan, session.bindings());
    EXPECT_TRUE(pass.render(session.scene(), plan, &grids, &session.bindings(), &noise, &majorant,
                            fb, stats, &error))
        << error;
    EXPECT_EQ(fb.rgba.size(), rgba.size());
    if (fb.rgba.size() != rgba.size()) return 0.0;
    double peak = 0.0, se = 0.0, maxAbs = 0.0;
    std::size_t same = 0;
    for (std::size_t i = 0; i < rgba.size(); ++i) {
        const double d = double(rgba[i]) - double(fb.rgba[i]);
        if (std::memcmp(&rgba[i], &fb.rgba[i], 4) == 0) ++same;
        if (i % 4 == 3) continue;
        peak = std::max(peak, double(fb.rgba[i]));
        se += d * d;
        maxAbs = std::max(maxAbs, std::abs(d));
    }
    const double mse = se / double(rgba.size() / 4 * 3);
    const double psnr = mse > 0.0 ? 10.0 * std::log10(peak * peak / mse) : 1e9;
    ::testing::Test::RecordProperty("psnr_db_" + tag, std::to_string(psnr));
    ::testing::Test::RecordProperty("bit_identical_floats_" + tag,
                                    std::to_string(same) + "/" + std::to_string(rgba.size()));
    std::printf("[ export ] %s: %dx%d, %ld pass(es), PSNR %s dB, largest difference %.3g, %zu of "
                "%zu floats bit-identical, %zu cloudy pixels\n",
                tag.c_str(), w, h, passes, mse > 0.0 ? std::to_string(psnr).c_str() : "inf", maxAbs,
                same, rgba.size(), cloudy);
    EXPECT_GT(peak, 0.0) << tag;
    EXPECT_GT(cloudy, std::size_t(w) * std::size_t(h) / 10) << tag << ": too few cloudy pixels";
    return psnr;
}

TEST(ExportGlslGpu, SameImageAsRt) {
    std::vector<std::string> files;
    EXPECT_GE(exportAgainstRt(
                  {"camera.width=64", "camera.height=36", "render.multiple_scattering=\"none\""},
                  "sun_ambient_sky", files),
              45.0);
    // no Mie table, no grid: only the noise tiles, which the plan bakes at this size ("auto"),
    // and the majorant grid (RT_SKIP)
    EXPECT_EQ(files,
              (std::vector<std::string>{"noise_base.bin", "noise_detail.bin", "majorant.bin"}));
}

TEST(ExportGlslGpu, SameImageAsRtMultisampleNoSun) {
    std::vector<std::string> files;
    EXPECT_GE(exportAgainstRt({"camera.width=48", "camera.height=27",
                               "render.multiple_scattering=\"none\"", "sun.enabled=false",
                               "render.pixel_samples=4", "render.background=\"transparent\""},
                              "no_sun_4spp_transparent", files),
              45.0);
}

TEST(ExportGlslGpu, SameImageAsRtWithTheDiffusionGridAndTheMieTable) {
    // the default scene as it ships (the diffusion grid) with the Lorenz-Mie phase table: the
    // grid of the frame and the table go out as files, read back here alone (the grid on voxels
    // of 0.5, not the scene's 0.117: built twice here, by the export and for nimbus rt's pass,
    // it was most of the test's time)
    std::vector<std::string> files;
    EXPECT_GE(exportAgainstRt({"camera.width=64", "camera.height=36", "medium.phase=\"mie_table\"",
                               "render.light_volume_cell=0.5"},
                              "grid_mie_table", files),
              45.0);
    // (the sun-depth volume the grid's sun source needs, which the octave gate reads too:
    // RT_GATE_VOLUME; and the noise tiles: the plan bakes the noise at this size under "auto")
    EXPECT_EQ(files,
              (std::vector<std::string>{"mie_table.bin", "diffusion.bin", "light_tau.bin",
                                        "noise_base.bin", "noise_detail.bin", "majorant.bin"}));
}

TEST(ExportGlslGpu, SameImageAsRtWithThePhotonGridAndItsSkin) {
    std::vector<std::string> files;
    EXPECT_GE(exportAgainstRt({"camera.width=48", "camera.height=27",
                               "render.multiple_scattering=\"photons\"", "render.photons=50000",
                               "render.photon_skin=0.2"},
                              "photons_skin", files),
              45.0);
    // the sun's light through the photon grid, the sky's through the diffusion grid
    // (and the noise tiles the plan bakes under "auto")
    EXPECT_EQ(files,
              (std::vector<std::string>{"diffusion.bin", "photons.bin", "skin_tau.bin",
                                        "noise_base.bin", "noise_detail.bin", "majorant.bin"}));
}

// A VDB field (a grid the test writes, tests/rt_vdb_scene.h): its NanoVDB grid goes out as
// vdb_grid.bin (the bytes nimbus rt uploads), the shader reads it through PNanoVDB's functions
// (only those main() reaches are left) and has no cumulus code; the image is nimbus rt's.
TEST(ExportGlslGpu, SameImageAsRtWithAVdbGrid) {
    TempDir dir("export_glsl_vdb_scene");
    const std::string scene = writeRtVdbScene(dir.string());
    std::vector<std::string> files;
    std::string shader;
    EXPECT_GE(
        exportAgainstRt({"camera.width=64", "camera.height=36"}, "vdb", files, scene, 1, &shader),
        45.0);
    EXPECT_EQ(files, (std::vector<std::string>{"vdb_grid.bin", "majorant.bin"}));
    EXPECT_TRUE(contains(shader, "buffer RtVdbGrid { uint pnanovdb_buf_data[]; };"));
    EXPECT_TRUE(contains(shader, "pnanovdb_readaccessor_get_value_address("));
    EXPECT_TRUE(contains(shader, "#define RT_VDB 1"));
    EXPECT_FALSE(contains(shader, "cumulusDensity(")); // (the word stays in comments)
    EXPECT_FALSE(contains(shader, "rtCumulusParams("));
    EXPECT_FALSE(contains(shader, "NB_FN float perlinNoise(")); // the cumulus' noise kernels
    EXPECT_FALSE(contains(shader, "#if RT_"));
    // PNanoVDB functions the pass does not call are gone (its HDDA, its double reads)
    EXPECT_FALSE(contains(shader, "pnanovdb_hdda_"));
    EXPECT_FALSE(contains(shader, "pnanovdb_uint64_as_double"));
    // the bytes of the file are the grid's
    host::Session session;
    ASSERT_TRUE(session.load(scene, {}).ok());
    ASSERT_TRUE(session.bind(1).ok());
    std::string error;
    const rt::VdbGridBytes g = rt::vdbGridBytes(&session.bindings(), &error);
    ASSERT_NE(g.data, nullptr) << error;
    rt::GlslExport e;
    ASSERT_TRUE(rt::exportGlsl(session.scene(), session.plan(1), scene, nullptr,
                               &session.bindings(), e, &error))
        << error;
    ASSERT_EQ(e.data.size(), 1u);
    EXPECT_EQ(e.data[0].first, "vdb_grid.bin");
    ASSERT_EQ(e.data[0].second.size(), g.size);
    EXPECT_EQ(std::memcmp(e.data[0].second.data(), g.data, g.size), 0);
    // a cumulus export has no PNanoVDB
    host::Session cumulus;
    ASSERT_TRUE(cumulus.load(kScene, {"render.multiple_scattering=\"none\""}).ok());
    rt::GlslExport c;
    const rt::BakedNoise noise =
        rt::bakedNoise(cumulus.renderer(), cumulus.plan(1), cumulus.bindings());
    ASSERT_TRUE(rt::exportGlsl(cumulus.scene(), cumulus.plan(1), kScene, nullptr,
                               &cumulus.bindings(), &noise, c, &error))
        << error;
    EXPECT_FALSE(contains(c.shader, "pnanovdb"));
    EXPECT_FALSE(contains(c.shader, "RtVdbGrid"));
    EXPECT_TRUE(contains(c.shader, "cumulusEnvelope(")); // (its noise baked at this size)
}

// field.evaluation = "baked": the CPU's noise tiles go out as noise_base.bin and noise_detail.bin
// (the floats nimbus rt uploads, res^3 each), the shader reads them (RT_BAKED_NOISE) and the
// image is nimbus rt's; without the tiles the export refuses the frame.
// An SDF cloud (RT_SDF, examples/scenes/sdf_cloud.toml with the sun's shadow marched): the
// exported shader, sdf_nodes.bin bound at 12 (and the majorant grid at 13: the SDF cloud's grid
// has empty cells) as params.json says, gives nimbus rt's image. The
// steps are coarse so that a whole ray fits in llvmpipe's loop budget: the export marches each
// ray in one dispatch (no RT_RESUMABLE), which on llvmpipe cuts longer marches short.
TEST(ExportGlslGpu, SameImageAsRtWithAnSdfCloud) {
    const std::string sdfCloud = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/sdf_cloud.toml";
    const std::vector<std::string> sets = {
        "camera.width=48",         "camera.height=27",
        "render.shadow=\"march\"", "render.multiple_scattering=\"none\"",
        "render.step=0.3",         "render.shadow_step=0.5"};
    std::vector<std::string> files;
    std::string shader;
    EXPECT_GE(exportAgainstRt(sets, "sdf_cloud", files, sdfCloud, 1, &shader), 45.0);
    EXPECT_EQ(files, (std::vector<std::string>{"majorant.bin", "sdf_nodes.bin"}));
    EXPECT_TRUE(contains(shader, "#define RT_SDF 1"));
    EXPECT_TRUE(contains(shader, "layout(std430, binding = 12) readonly buffer RtSdfNodes"));
    EXPECT_TRUE(contains(shader, "NB_FN void sdfTreeStep("));
    EXPECT_FALSE(contains(shader, "rtCumulusParams("));
    EXPECT_FALSE(contains(shader, "buffer RtSlices")); // nimbus rt's slices are not exported
    EXPECT_FALSE(contains(shader, "#if RT_"));
    // the file holds the tree's nodes as the pass uploads them
    host::Session session;
    ASSERT_TRUE(session.load(sdfCloud, sets).ok());
    std::string error;
    rt::GlslExport e;
    ASSERT_TRUE(rt::exportGlsl(session.scene(), session.plan(1), sdfCloud, e, &error)) << error;
    ASSERT_EQ(e.data.size(), 1u);
    const std::vector<kern::SdfTreeNode> nodes = rt::sdfTreeNodes(session.scene());
    ASSERT_EQ(nodes.size(), 16u);
    ASSERT_EQ(e.data[0].second.size(), nodes.size() * sizeof(kern::SdfTreeNode));
    EXPECT_EQ(std::memcmp(e.data[0].second.data(), nodes.data(), e.data[0].second.size()), 0);
    EXPECT_TRUE(contains(e.json, "\"sdf_nodes.bin\""));
    EXPECT_TRUE(contains(e.json, "132 uint seed"));
}

namespace {

/// One frame of a scene exported with the CPU's grids, as `nimbus export-glsl` exports it: the
/// session (the grids' bindings point into it), the frame's plan, its grids and the export.
struct GridExport {
    host::Session session;
    FramePlan plan;
    MarchGrids grids;
    rt::GlslExport e;
};

/// Loads `sets` over kScene into x, plans frame `frame`, builds its grids and exports it.
::testing::AssertionResult exportWithGrids(const std::vector<std::string>& sets, int frame,
                                           GridExport& x) {
    if (!x.session.load(kScene, sets).ok()) return ::testing::AssertionFailure() << "load";
    x.plan = x.session.plan(frame);
    RenderStats stats;
    x.grids = x.session.renderer().marchGrids(x.plan, x.session.bindings(), stats);
    std::string error;
    if (!rt::exportGlsl(x.session.scene(), x.plan, kScene, &x.grids, &x.session.bindings(), nullptr,
                        x.e, &error))
        return ::testing::AssertionFailure() << error;
    return ::testing::AssertionSuccess();
}

} // namespace

// render.shadow = "volume": the CPU's light-attenuation volume goes out as light_tau.bin (the
// floats `nimbus rt` uploads, binding 15), the shader reads the sun's density integral from it
// (RT_LIGHT_VOLUME) and the image from the files alone is nimbus rt's; without the setting
// neither the file nor the lookup is there.
TEST(ExportGlslGpu, SameImageAsRtWithTheLightVolume) {
    std::vector<std::string> files;
    std::string shader;
    // (render.octave_gate off: llvmpipe's loop budget, as in SameImageAsRtWithTheMajorantGrid)
    std::vector<std::string> sets = {"camera.width=64",
                                     "camera.height=36",
                                     "render.multiple_scattering=\"none\"",
                                     "field.evaluation=\"direct\"",
                                     "render.octave_gate=0",
                                     "render.shadow=\"volume\""};
    EXPECT_GE(exportAgainstRt(sets, "light_volume", files, kScene, 3, &shader), 45.0);
    EXPECT_EQ(files, (std::vector<std::string>{"light_tau.bin", "majorant.bin"}));
    EXPECT_TRUE(contains(shader, "#define RT_LIGHT_VOLUME 1"));
    EXPECT_TRUE(contains(shader, "buffer RtLightGrid { float rtLightTau[]; };"));
    EXPECT_TRUE(contains(shader, "rtLightVolumeSample(p)"));
    // the file is the volume's floats
    GridExport x;
    ASSERT_TRUE(exportWithGrids(sets, 3, x));
    const rt::GlslExport& e = x.e;
    const MarchGrids& grids = x.grids;
    ASSERT_NE(grids.towardVolume(), nullptr);
    ASSERT_EQ(e.data.size(), 1u);
    EXPECT_EQ(e.data[0].first, "light_tau.bin");
    const std::vector<float>& tau = grids.towardVolume()->tau;
    ASSERT_EQ(e.data[0].second.size(), tau.size() * sizeof(float));
    EXPECT_EQ(std::memcmp(e.data[0].second.data(), tau.data(), e.data[0].second.size()), 0);
    EXPECT_TRUE(contains(e.json, "\"lightResX\""));
    // without the grids the export refuses the frame
    rt::GlslExport none;
    std::string error;
    EXPECT_FALSE(rt::exportGlsl(x.session.scene(), x.plan, kScene, none, &error));
    EXPECT_TRUE(contains(error, "light-attenuation volume")) << error;
    // render.shadow = "march": no file, no lookup
    sets.back() = "render.shadow=\"march\"";
    files.clear();
    EXPECT_GE(exportAgainstRt(sets, "light_volume_off", files, kScene, 3, &shader), 45.0);
    EXPECT_EQ(files, (std::vector<std::string>{"majorant.bin"}));
    EXPECT_TRUE(contains(shader, "#define RT_LIGHT_VOLUME 0"));
    EXPECT_FALSE(contains(shader, "RtLightGrid"));
    EXPECT_FALSE(contains(shader, "rtLightVolumeSample"));
}

// render.sky_scattering = "single" with render.sky_shadow = "volume": the sky's directions and
// radiances and the CPU's sky volume go out as sky_volume.bin (the floats `nimbus rt` uploads,
// binding 7), the shader integrates the sky's first scattering from it (RT_SKY_VOLUME), and the
// image from the files alone is nimbus rt's.
TEST(ExportGlslGpu, SameImageAsRtWithTheSkyVolume) {
    std::vector<std::string> files;
    std::string shader;
    const std::vector<std::string> sets = {
        "camera.width=64", "camera.height=36", "render.multiple_scattering=\"none\"",
        "field.evaluation=\"direct\"", "render.sky_scattering=\"single\"",
        "render.sky_shadow=\"volume\"",
        // llvmpipe's loop budget (SameImageAsRtWithTheMajorantGrid)
        "render.octave_gate=0"};
    EXPECT_GE(exportAgainstRt(sets, "sky_volume", files, kScene, 3, &shader), 45.0);
    EXPECT_EQ(files, (std::vector<std::string>{"sky_volume.bin", "majorant.bin"}));
    EXPECT_TRUE(contains(shader, "#define RT_SKY_VOLUME 1"));
    EXPECT_TRUE(contains(shader, "buffer RtSkyVolume { float rtSkyVolume[]; };"));
    EXPECT_TRUE(contains(shader, "#define RT_AMBIENT 0"));
    // the file: 8 floats per direction (w_k, L_k), then the volume's floats
    GridExport x;
    ASSERT_TRUE(exportWithGrids(sets, 3, x));
    const rt::GlslExport& e = x.e;
    const MarchGrids& grids = x.grids;
    ASSERT_TRUE(grids.hasSky);
    ASSERT_EQ(e.data.size(), 1u);
    EXPECT_EQ(e.data[0].first, "sky_volume.bin");
    const int K = grids.sky.count();
    ASSERT_EQ(K, x.plan.skyDirections);
    ASSERT_EQ(e.data[0].second.size(), (8 * std::size_t(K) + grids.sky.tau.size()) * sizeof(float));
    std::vector<float> floats(e.data[0].second.size() / sizeof(float));
    std::memcpy(floats.data(), e.data[0].second.data(), e.data[0].second.size());
    for (int k = 0; k < K; ++k) {
        const vec3 w(floats[8 * k], floats[8 * k + 1], floats[8 * k + 2]);
        EXPECT_EQ(w, grids.sky.directions[std::size_t(k)]) << k;
    }
    EXPECT_EQ(std::memcmp(floats.data() + 8 * K, grids.sky.tau.data(),
                          grids.sky.tau.size() * sizeof(float)),
              0);
    EXPECT_TRUE(contains(e.json, "\"skyVolumeResX\""));
    EXPECT_TRUE(contains(e.json, "\"sky_volume.bin\""));
    // without the grids the export refuses the frame
    rt::GlslExport none;
    std::string error;
    EXPECT_FALSE(rt::exportGlsl(x.session.scene(), x.plan, kScene, none, &error));
    EXPECT_TRUE(contains(error, "sky volume")) << error;
}

// field.evaluation = "rgba": Olajos' channel layout goes out as two RGBA8 3D textures
// (noise_base_rgba.bin, noise_detail_rgba.bin: the CPU's bytes), described in params.json's
// "textures" (units 4 and 5, GL_LINEAR, GL_REPEAT); the shader samples them
// (RT_RGBA_NOISE) and has neither the float tiles' buffers nor the noise functions; the image
// from the files alone is nimbus rt's. Without the mode no texture is exported.
TEST(ExportGlslGpu, SameImageAsRtWithRgbaNoise) {
    std::vector<std::string> files;
    std::string shader;
    const std::vector<std::string> sets = {"camera.width=64", "camera.height=36",
                                           "render.multiple_scattering=\"none\"",
                                           "field.evaluation=\"rgba\""};
    EXPECT_GE(exportAgainstRt(sets, "rgba_noise", files, kScene, 3, &shader), 45.0);
    EXPECT_EQ(files, (std::vector<std::string>{"majorant.bin", "noise_base_rgba.bin",
                                               "noise_detail_rgba.bin"}));
    EXPECT_TRUE(contains(shader, "#define RT_RGBA_NOISE 1"));
    EXPECT_TRUE(contains(shader, "layout(binding = 4) uniform sampler3D rtBaseChannels;"));
    EXPECT_TRUE(contains(shader, "cumulusBaseFromChannels(rtChannels("));
    EXPECT_FALSE(contains(shader, "RtBaseNoise"));
    EXPECT_FALSE(contains(shader, "rtNoiseSample("));
    EXPECT_FALSE(contains(shader, "NB_FN float worleyFbm(")); // the noise is not evaluated
    host::Session session;
    ASSERT_TRUE(session.load(kScene, sets).ok());
    const FramePlan plan = session.plan(3);
    const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
    ASSERT_TRUE(noise.base && noise.base->channels());
    std::string error;
    rt::GlslExport e;
    ASSERT_TRUE(rt::exportGlsl(session.scene(), plan, kScene, nullptr, &session.bindings(), &noise,
                               e, &error))
        << error;
    ASSERT_EQ(e.data.size(), 2u);
    EXPECT_EQ(e.data[0].first, "noise_base_rgba.bin");
    EXPECT_EQ(e.data[0].second, noise.base->rgba);
    EXPECT_EQ(e.data[1].second, noise.detail->rgba);
    EXPECT_TRUE(contains(e.json, "\"sampler\": \"rtBaseChannels\", \"unit\": 4"));
    EXPECT_TRUE(contains(e.json, "\"wrap\": \"GL_REPEAT\""));
    // float tiles: no texture
    rt::GlslExport floats;
    host::Session baked;
    ASSERT_TRUE(
        baked
            .load(kScene, {"camera.width=64", "camera.height=36",
                           "render.multiple_scattering=\"none\"", "field.evaluation=\"baked\""})
            .ok());
    const rt::BakedNoise bn = rt::bakedNoise(baked.renderer(), baked.plan(3), baked.bindings());
    ASSERT_TRUE(rt::exportGlsl(baked.scene(), baked.plan(3), kScene, nullptr, &baked.bindings(),
                               &bn, floats, &error))
        << error;
    EXPECT_TRUE(contains(floats.json, "\"textures\": [],"));
    EXPECT_FALSE(contains(floats.shader, "sampler3D"));
    EXPECT_TRUE(contains(floats.shader, "#define RT_RGBA_NOISE 0"));
}

TEST(ExportGlslGpu, SameImageAsRtWithBakedNoise) {
    std::vector<std::string> files;
    std::string shader;
    EXPECT_GE(exportAgainstRt({"camera.width=64", "camera.height=36",
                               "render.multiple_scattering=\"none\"", "field.evaluation=\"baked\""},
                              "baked_noise", files, kScene, 3, &shader),
              45.0);
    EXPECT_EQ(files,
              (std::vector<std::string>{"noise_base.bin", "noise_detail.bin", "majorant.bin"}));
    EXPECT_TRUE(contains(shader, "#define RT_BAKED_NOISE 1"));
    EXPECT_TRUE(contains(shader, "buffer RtBaseNoise { float rtBaseNoise[]; };"));
    EXPECT_TRUE(contains(shader, "rtBakedCumulusDensity("));
    EXPECT_FALSE(contains(shader, "NB_FN float worleyFbm(")); // the noise is not evaluated
    host::Session session;
    ASSERT_TRUE(
        session
            .load(kScene, {"camera.width=64", "camera.height=36",
                           "render.multiple_scattering=\"none\"", "field.evaluation=\"baked\""})
            .ok());
    const FramePlan plan = session.plan(3);
    const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
    ASSERT_TRUE(noise.base && noise.detail);
    std::string error;
    rt::GlslExport e;
    ASSERT_TRUE(rt::exportGlsl(session.scene(), plan, kScene, nullptr, &session.bindings(), &noise,
                               e, &error))
        << error;
    ASSERT_EQ(e.data.size(), 2u);
    const int rb = session.scene().field.cumulus.baseBakeResolution;
    const int rd = session.scene().field.cumulus.detailBakeResolution;
    ASSERT_EQ(e.data[0].second.size(), std::size_t(rb) * rb * rb * 4);
    ASSERT_EQ(e.data[1].second.size(), std::size_t(rd) * rd * rd * 4);
    EXPECT_EQ(
        std::memcmp(e.data[0].second.data(), noise.base->values.data(), e.data[0].second.size()),
        0);
    EXPECT_EQ(
        std::memcmp(e.data[1].second.data(), noise.detail->values.data(), e.data[1].second.size()),
        0);
    EXPECT_TRUE(contains(e.json, "\"noise_base.bin\""));
    EXPECT_TRUE(contains(e.json, "\"baseBakeRes\""));
    rt::GlslExport none;
    EXPECT_FALSE(rt::exportGlsl(session.scene(), plan, kScene, none, &error));
    EXPECT_TRUE(contains(error, "tiles were not given")) << error;
}

// Empty-space skipping (RT_SKIP): the export writes the frame's majorant grid as majorant.bin (the
// floats `nimbus rt` uploads, one per cell, x fastest; binding 13), the shader skips its empty
// cells and the image read back from the files alone is nimbus rt's bit for bit, on the default
// scene and on a sparse VDB grid; with render.skip_empty = false neither the file nor the code
// is there.
TEST(ExportGlslGpu, SameImageAsRtWithTheMajorantGrid) {
    std::vector<std::string> files;
    std::string shader;
    // thick steps split (render.step_tau, the default): each iteration of the step loops looks
    // up one density at most (RtStepper), so the whole rays fit llvmpipe's loop budget in one
    // batch, which the export, without slices, needs (docs/realtime.md, "SDF clouds")
    // (render.octave_gate off: its second shadow march per sample takes some of the default
    // scene's whole rays past that budget; `nimbus rt` marches in slices and RtMarchParity
    // checks the gate there)
    const std::vector<std::string> sets = {"camera.width=64", "camera.height=36",
                                           "render.multiple_scattering=\"none\"",
                                           "field.evaluation=\"direct\"", "render.octave_gate=0"};
    EXPECT_EQ(exportAgainstRt(sets, "skip", files, kScene, 3, &shader), 1e9); // bit-identical
    EXPECT_EQ(files, (std::vector<std::string>{"majorant.bin"}));
    EXPECT_TRUE(contains(shader, "#define RT_SKIP 1"));
    EXPECT_TRUE(contains(shader, "buffer RtMajorant { float rtMajorant[]; };"));
    TempDir dir("export_glsl_skip_vdb");
    files.clear();
    EXPECT_EQ(exportAgainstRt({"camera.width=64", "camera.height=36"}, "skip_vdb", files,
                              writeRtVdbScene(dir.string()), 1),
              1e9);
    EXPECT_EQ(files, (std::vector<std::string>{"vdb_grid.bin", "majorant.bin"}));
    // the file is the grid's floats; the block has its geometry
    host::Session session;
    ASSERT_TRUE(session.load(kScene, sets).ok());
    const FramePlan plan = session.plan(3);
    const MajorantGrid g = rt::majorantGrid(session.renderer(), plan, session.bindings());
    rt::GlslExport e;
    std::string error;
    ASSERT_TRUE(rt::exportGlsl(session.scene(), plan, kScene, nullptr, &session.bindings(), nullptr,
                               &g, e, &error))
        << error;
    ASSERT_EQ(e.data.size(), 1u);
    EXPECT_EQ(e.data[0].first, "majorant.bin");
    // the cells' bounds, then the blocks' distances
    const std::vector<float> want = rt::majorantBuffer(g);
    ASSERT_EQ(want.size(), g.maj.size() + g.blockDistance.size());
    ASSERT_EQ(e.data[0].second.size(), want.size() * sizeof(float));
    EXPECT_EQ(std::memcmp(e.data[0].second.data(), want.data(), e.data[0].second.size()), 0);
    EXPECT_TRUE(contains(e.json, "\"majorant.bin\""));
    EXPECT_TRUE(contains(e.json, "\"majorantResX\""));
    // render.skip_empty = false: no grid, no file, no code
    std::vector<std::string> off = sets;
    off.push_back("render.skip_empty=false");
    files.clear();
    EXPECT_GE(exportAgainstRt(off, "no_skip", files, kScene, 3, &shader), 45.0);
    EXPECT_TRUE(files.empty());
    EXPECT_TRUE(contains(shader, "#define RT_SKIP 0"));
    EXPECT_FALSE(contains(shader, "rtEmptyCell"));
}
