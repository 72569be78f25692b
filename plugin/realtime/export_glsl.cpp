/// @file export_glsl.cpp
/// @brief `nimbus export-glsl`: the feature preprocessor, the std430 layout of the parameter
/// block read from its GLSL text, and the files of an export.
#include "plugin/realtime/export_glsl.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <optional>
#include <sstream>

#include "core/kernels/source.h"
#include "core/media/medium.h"
#include "core/media/mie.h"
#include "core/render.h"
#include "plugin/realtime/march_params.h"
#include "plugin/realtime/pass_source.h"

namespace nimbus::rt {

std::vector<std::pair<std::string, bool>> featureMacros(const MarchFeatures& f) {
    return {{"RT_SUN", f.sun},
            {"RT_AMBIENT", f.ambient},
            {"RT_BACKGROUND_SKY", f.backgroundSky},
            {"RT_MULTISAMPLE", f.multisample},
            {"RT_MIE_TABLE", f.mieTable},
            {"RT_MS_DIFFUSION", f.diffusion},
            {"RT_MS_PHOTONS", f.photons},
            {"RT_PHOTON_SKIN", f.photonSkin},
            {"RT_VDB", f.vdb},
            {"RT_BAKED_NOISE", f.bakedNoise},
            {"RT_RGBA_NOISE", f.rgbaNoise},
            {"RT_SKIP", f.skip},
            {"RT_SDF", f.sdf},
            {"RT_LIGHT_VOLUME", f.lightVolume},
            {"RT_GATE_VOLUME", f.gateVolume},
            {"RT_SKY_VOLUME", f.skyVolume},
            {"RT_FORWARD_DELTA", f.forwardDelta},
            {"RT_RESUMABLE", f.resumable}};
}

namespace {

// --- the preprocessor -------------------------------------------------------------------------

using Macros = std::vector<std::pair<std::string, bool>>;

std::string_view trim(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
}

/// A directive's text without a trailing `//` or one-line `/* */` comment.
std::string_view withoutComment(std::string_view s) {
    const std::size_t a = s.find("//");
    const std::size_t b = s.find("/*");
    const std::size_t c = std::min(a, b);
    return trim(c == std::string_view::npos ? s : s.substr(0, c));
}

bool isIdentStart(char c) {
    return std::isalpha(static_cast<unsigned char>(c)) || c == '_';
}
bool isIdent(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
}

/// A condition of #if / #elif over the feature macros.
class Condition {
  public:
    Condition(std::string_view text, const Macros& macros) : s_(text), macros_(macros) {}

    /// Which names the condition uses: feature macros, others.
    void scanNames(bool& features, bool& others) const {
        features = others = false;
        for (std::size_t i = 0; i < s_.size();) {
            if (isIdentStart(s_[i])) {
                std::size_t j = i;
                while (j < s_.size() && isIdent(s_[j])) ++j;
                const std::string_view name = s_.substr(i, j - i);
                if (name != "defined") (macro(name) ? features : others) = true;
                i = j;
            } else {
                ++i;
            }
        }
    }

    /// The value, or nullopt on a syntax the evaluator does not know.
    std::optional<long> evaluate() {
        pos_ = 0;
        ok_ = true;
        const long v = orExpr();
        skipSpace();
        if (!ok_ || pos_ != s_.size()) return std::nullopt;
        return v;
    }

  private:
    const std::pair<std::string, bool>* macro(std::string_view name) const {
        for (const auto& m : macros_)
            if (m.first == name) return &m;
        return nullptr;
    }
    void skipSpace() {
        while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    }
    bool eat(std::string_view tok) {
        skipSpace();
        if (s_.substr(pos_, tok.size()) == tok) {
            pos_ += tok.size();
            return true;
        }
        return false;
    }
    std::string_view ident() {
        skipSpace();
        const std::size_t i = pos_;
        if (pos_ < s_.size() && isIdentStart(s_[pos_]))
            while (pos_ < s_.size() && isIdent(s_[pos_])) ++pos_;
        return s_.substr(i, pos_ - i);
    }
    long orExpr() {
        long v = andExpr();
        while (ok_ && eat("||")) {
            const long r = andExpr();
            v = (v || r) ? 1 : 0;
        }
        return v;
    }
    long andExpr() {
        long v = eqExpr();
        while (ok_ && eat("&&")) {
            const long r = eqExpr();
            v = (v && r) ? 1 : 0;
        }
        return v;
    }
    long eqExpr() {
        long v = unary();
        while (ok_) {
            if (eat("==")) {
                v = v == unary() ? 1 : 0;
            } else if (eat("!=")) {
                v = v != unary() ? 1 : 0;
            } else {
                break;
            }
        }
        return v;
    }
    long unary() {
        if (eat("!")) return unary() ? 0 : 1;
        return primary();
    }
    long primary() {
        skipSpace();
        if (eat("(")) {
            const long v = orExpr();
            if (!eat(")")) ok_ = false;
            return v;
        }
        if (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_]))) {
            long v = 0;
            while (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_])))
                v = v * 10 + (s_[pos_++] - '0');
            return v;
        }
        const std::string_view name = ident();
        if (name == "defined") {
            const bool paren = eat("(");
            const std::string_view m = ident();
            if (paren && !eat(")")) ok_ = false;
            if (!macro(m)) ok_ = false;
            return 1; // every feature macro is defined (to 0 or 1)
        }
        const auto* m = macro(name);
        if (!m) {
            ok_ = false;
            return 0;
        }
        return m->second ? 1 : 0;
    }

    std::string_view s_;
    const Macros& macros_;
    std::size_t pos_ = 0;
    bool ok_ = true;
};

struct Frame {
    bool feature = false; // a conditional on the feature macros (else kept for the compiler)
    bool active = true;   // the current branch is kept (feature frames)
    bool taken = false;   // some branch was true already (feature frames)
};

/// A directive's name and its argument text ("if", "RT_SUN && RT_AMBIENT").
bool directive(std::string_view line, std::string_view& name, std::string_view& rest) {
    std::string_view s = trim(line);
    if (s.empty() || s.front() != '#') return false;
    s.remove_prefix(1);
    s = trim(s);
    std::size_t i = 0;
    while (i < s.size() && isIdent(s[i])) ++i;
    name = s.substr(0, i);
    rest = withoutComment(s.substr(i));
    return true;
}

} // namespace

bool stripFeatureConditionals(std::string_view text, const Macros& macros, std::string& out,
                              std::string* error) {
    out.clear();
    std::vector<Frame> stack;
    long lineNo = 1; // the GLSL line number of the current line (follows #line)
    std::string source = "0";
    bool resync = false;
    std::size_t inputLine = 0;
    auto fail = [&](const std::string& why) {
        if (error) *error = "line " + std::to_string(inputLine) + " of the shader: " + why;
        return false;
    };
    auto keeping = [&] {
        for (const Frame& f : stack)
            if (f.feature && !f.active) return false;
        return true;
    };
    // the value of a condition on feature macros only; nullopt (with an error) when it names
    // other macros too, or its syntax is unknown
    auto featureValue = [&](std::string_view cond, bool& isFeature) -> std::optional<long> {
        Condition c(cond, macros);
        bool features = false, others = false;
        c.scanNames(features, others);
        isFeature = features;
        if (!features) return 0;
        if (others) {
            fail("the condition \"" + std::string(cond) +
                 "\" mixes the feature macros with other names");
            return std::nullopt;
        }
        const std::optional<long> v = c.evaluate();
        if (!v) fail("cannot evaluate the condition \"" + std::string(cond) + "\"");
        return v;
    };

    std::size_t start = 0;
    while (start < text.size()) {
        std::size_t end = text.find('\n', start);
        const bool lastWithoutNewline = end == std::string_view::npos;
        if (lastWithoutNewline) end = text.size();
        const std::string_view line = text.substr(start, end - start);
        start = end + 1;
        ++inputLine;
        const long thisLine = lineNo++;

        bool keep = keeping();
        std::string_view name, rest;
        const bool isDirective = directive(line, name, rest);
        if (isDirective) {
            if (name == "if" || name == "ifdef" || name == "ifndef") {
                Frame f;
                if (name == "if") {
                    bool isFeature = false;
                    const std::optional<long> v = featureValue(rest, isFeature);
                    if (!v) return false;
                    f.feature = isFeature;
                    f.active = *v != 0;
                } else {
                    bool isMacro = false;
                    for (const auto& m : macros) isMacro = isMacro || m.first == rest;
                    f.feature = isMacro;
                    f.active = name == "ifdef"; // every feature macro is defined
                }
                f.taken = f.active;
                stack.push_back(f);
                if (f.feature) keep = false;
            } else if (name == "elif" || name == "else" || name == "endif") {
                if (stack.empty()) return fail("#" + std::string(name) + " without its #if");
                Frame& f = stack.back();
                if (f.feature) {
                    keep = false;
                    if (name == "elif") {
                        bool isFeature = false;
                        const std::optional<long> v = featureValue(rest, isFeature);
                        if (!v) return false;
                        if (!isFeature)
                            return fail("#elif \"" + std::string(rest) +
                                        "\" in a conditional on the feature macros names none");
                        f.active = !f.taken && *v != 0;
                        f.taken = f.taken || f.active;
                    } else if (name == "else") {
                        f.active = !f.taken;
                        f.taken = true;
                    } else {
                        stack.pop_back();
                    }
                } else {
                    if (name == "elif") {
                        bool isFeature = false;
                        if (!featureValue(rest, isFeature)) return false;
                        if (isFeature)
                            return fail("#elif \"" + std::string(rest) +
                                        "\" names a feature macro in a conditional on others");
                    }
                    if (name == "endif") stack.pop_back();
                }
            } else if (name == "line" && keep) {
                // #line L [S]: the next line is line L of source string S
                std::istringstream in{std::string(rest)};
                long l = 0;
                std::string s;
                if (in >> l) {
                    lineNo = l;
                    if (in >> s) source = s;
                    resync = false;
                }
            }
        }
        if (keep) {
            if (resync && !(isDirective && name == "line"))
                out += "#line " + std::to_string(thisLine) + " " + source + "\n";
            resync = false;
            out.append(line);
            if (!lastWithoutNewline) out += '\n';
        } else {
            resync = true;
        }
    }
    if (!stack.empty()) {
        inputLine = 0;
        return fail("an #if without its #endif");
    }
    return true;
}

// --- unreferenced declarations ---------------------------------------------------------------

namespace {

/// A top-level item of a shader: whole lines, from after the previous item to the line that
/// ends it (a function's closing brace, or a `;` at depth 0), or one preprocessor line.
struct Item {
    std::string text;               // its lines, with their newlines
    std::string code;               // the code, comments left out
    long line = 1;                  // the GLSL line number of its first line
    std::string source = "0";       // and its source string
    bool directive = false;         // a preprocessor line
    bool isLine = false;            // a #line directive
    std::string name;               // the name it defines ("" for none: always kept)
    std::vector<std::string> words; // the identifiers of its code
};

std::vector<std::string> identifiers(std::string_view code) {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < code.size();) {
        if (isIdentStart(code[i]) && (i == 0 || !isIdent(code[i - 1]))) {
            std::size_t j = i;
            while (j < code.size() && isIdent(code[j])) ++j;
            out.emplace_back(code.substr(i, j - i));
            i = j;
        } else {
            ++i;
        }
    }
    return out;
}

/// The name an item of code defines: a function's or prototype's (the word before its first
/// `(`), a struct's, or a variable's or constant's (the last word before `=`, `[` or `;`); ""
/// for layout, precision and other declarations that define nothing to reach.
std::string definedName(std::string_view code, bool function) {
    const std::vector<std::string> words = identifiers(code);
    if (words.empty()) return "";
    if (words[0] == "layout" || words[0] == "precision") return "";
    if (words[0] == "struct") return words.size() > 1 ? words[1] : "";
    const std::size_t paren = code.find('(');
    const std::size_t stop = code.find_first_of("=[;");
    if (function || (paren != std::string_view::npos && paren < stop)) {
        const std::vector<std::string> before = identifiers(code.substr(0, paren));
        return before.empty() ? "" : before.back();
    }
    const std::vector<std::string> before = identifiers(code.substr(0, stop));
    return before.empty() ? "" : before.back();
}

} // namespace

bool removeUnreferenced(std::string_view text, std::string& out, std::string* error) {
    std::vector<Item> items;
    Item cur;
    bool curStarted = false, inBlockComment = false, function = false;
    int depth = 0;
    char lastCode = 0;
    long lineNo = 1;
    std::string source = "0";
    std::size_t inputLine = 0;
    auto finish = [&] {
        cur.words = identifiers(cur.code);
        if (!cur.directive) cur.name = definedName(cur.code, function);
        items.push_back(std::move(cur));
        cur = Item();
        curStarted = false;
        function = false;
        lastCode = 0;
    };
    std::size_t start = 0;
    while (start < text.size()) {
        std::size_t end = text.find('\n', start);
        const bool hasNewline = end != std::string_view::npos;
        if (!hasNewline) end = text.size();
        const std::string_view line = text.substr(start, end - start);
        start = end + 1;
        ++inputLine;
        const long thisLine = lineNo++;
        std::string_view name, rest;
        const bool isDirective = !inBlockComment && directive(line, name, rest);
        if (isDirective && name == "line") {
            // #line L [S]: the next line is line L of source string S (also inside a body, where
            // stripFeatureConditionals put one after a removed block)
            std::istringstream in{std::string(rest)};
            long l = 0;
            std::string s;
            if (in >> l) {
                lineNo = l;
                if (in >> s) source = s;
            }
        }
        if (isDirective && depth == 0 && cur.code.empty()) {
            if (curStarted) finish(); // comment lines before it: kept as they are
            cur.text = std::string(line) + (hasNewline ? "\n" : "");
            cur.line = thisLine;
            cur.source = source;
            cur.directive = true;
            cur.isLine = name == "line";
            curStarted = true;
            finish();
            continue;
        }
        if (isDirective) { // inside an item: kept with it, no code to scan
            cur.text.append(line);
            if (hasNewline) cur.text += '\n';
            continue;
        }
        if (!curStarted) {
            cur.line = thisLine;
            cur.source = source;
            curStarted = true;
        }
        cur.text.append(line);
        if (hasNewline) cur.text += '\n';
        bool complete = false;
        for (std::size_t i = 0; i < line.size(); ++i) {
            const char c = line[i];
            if (inBlockComment) {
                if (c == '*' && i + 1 < line.size() && line[i + 1] == '/') {
                    inBlockComment = false;
                    ++i;
                }
                continue;
            }
            if (c == '/' && i + 1 < line.size() && line[i + 1] == '/') break;
            if (c == '/' && i + 1 < line.size() && line[i + 1] == '*') {
                inBlockComment = true;
                ++i;
                continue;
            }
            cur.code += c;
            if (c == '{') {
                if (depth == 0 && lastCode == ')') function = true;
                ++depth;
            } else if (c == '}') {
                if (--depth < 0) {
                    if (error) *error = "line " + std::to_string(inputLine) + ": unbalanced }";
                    return false;
                }
                if (depth == 0 && function) complete = true;
            } else if (c == ';' && depth == 0) {
                complete = true;
            }
            if (!std::isspace(static_cast<unsigned char>(c))) lastCode = c;
        }
        cur.code += ' ';
        // a blank line ends a run of comments: a file's header stays when its first function goes
        if (complete || (trim(cur.code).empty() && trim(line).empty())) finish();
    }
    if (curStarted) {
        if (!trim(cur.code).empty() || depth != 0) {
            if (error) *error = "the shader ends inside a declaration (unbalanced braces?)";
            return false;
        }
        finish();
    }

    // what main() reaches
    std::map<std::string, std::vector<std::size_t>> byName;
    for (std::size_t i = 0; i < items.size(); ++i)
        if (!items[i].name.empty()) byName[items[i].name].push_back(i);
    if (!byName.count("main")) {
        if (error) *error = "the shader has no main()";
        return false;
    }
    std::vector<bool> keep(items.size(), false);
    std::vector<std::size_t> work;
    for (std::size_t i = 0; i < items.size(); ++i)
        if (items[i].name.empty() || items[i].name == "main") {
            keep[i] = true;
            work.push_back(i);
        }
    while (!work.empty()) {
        const std::size_t i = work.back();
        work.pop_back();
        for (const std::string& w : items[i].words) {
            const auto it = byName.find(w);
            if (it == byName.end()) continue;
            for (const std::size_t j : it->second)
                if (!keep[j]) {
                    keep[j] = true;
                    work.push_back(j);
                }
        }
    }
    out.clear();
    bool resync = false;
    for (std::size_t i = 0; i < items.size(); ++i) {
        if (!keep[i]) {
            resync = true;
            continue;
        }
        if (resync && !items[i].isLine)
            out += "#line " + std::to_string(items[i].line) + " " + items[i].source + "\n";
        resync = false;
        out += items[i].text;
    }
    return true;
}

// --- the parameter block ----------------------------------------------------------------------

bool paramBlockLayout(std::vector<ParamMember>& members, std::size_t* blockSize,
                      std::string* error) {
    members.clear();
    const std::string_view text = march_paramsSource();
    const std::size_t open = text.find("struct RtMarchParams {");
    const std::size_t close = open == std::string_view::npos ? open : text.find("};", open);
    if (close == std::string_view::npos) {
        if (error) *error = "march_params.glsl: no `struct RtMarchParams { ... };`";
        return false;
    }
    std::string_view body = text.substr(open, close - open);
    body.remove_prefix(body.find('{') + 1);
    std::size_t offset = 0, align = 4;
    std::size_t start = 0;
    while (start < body.size()) {
        std::size_t end = body.find('\n', start);
        if (end == std::string_view::npos) end = body.size();
        const std::string_view line = withoutComment(body.substr(start, end - start));
        start = end + 1;
        if (line.empty()) continue;
        std::istringstream in{std::string(line)};
        std::string type, name;
        in >> type >> name;
        if (name.empty() || name.back() != ';') {
            if (error)
                *error = "march_params.glsl: cannot read the member \"" + std::string(line) + "\"";
            return false;
        }
        name.pop_back();
        ParamMember m;
        m.name = name;
        m.type = type;
        if (type == "vec4") {
            m.size = 16;
            align = 16;
        } else if (type == "float" || type == "int" || type == "uint") {
            m.size = 4;
        } else {
            if (error)
                *error = "march_params.glsl: member " + name + " has type " + type +
                         ", which the block's layout rule leaves out (vec4 and 4-byte scalars)";
            return false;
        }
        offset = (offset + m.size - 1) / m.size * m.size; // std430: aligned to its own size
        m.offset = offset;
        offset += m.size;
        members.push_back(m);
    }
    if (blockSize) *blockSize = (offset + align - 1) / align * align;
    return true;
}

ParamDoc paramDoc(std::string_view n) {
    static const std::map<std::string_view, ParamDoc> docs = {
        {"camOrigin", {"camera position (xyz; w unused, 0)", "world units"}},
        {"sigmaTr",
         {"transport extinction per unit density, sigma_a + sigma_s (1 - g), RGB, density scale "
          "folded in (w 0): the diffusion grid's P1 term",
          "1/world unit"}},
        {"diffusionLo",
         {"lower corner of the diffusion grid's box (RT_MS_DIFFUSION; w 0)", "world units"}},
        {"diffusionVoxel", {"the diffusion grid's voxel size (xyz; w 0)", "world units"}},
        {"photonLo", {"lower corner of the photon grid's box (RT_MS_PHOTONS; w 0)", "world units"}},
        {"photonVoxel", {"the photon grid's voxel size (xyz; w 0)", "world units"}},
        {"skinLo",
         {"lower corner of the light volume holding the density integral toward the sun, for the "
          "photons' skin profile (RT_PHOTON_SKIN; w 0)",
          "world units"}},
        {"skinVoxel", {"that light volume's voxel size (xyz; w 0)", "world units"}},
        {"mieNodes", {"nodes of the Lorenz-Mie table in mie_table.bin (RT_MIE_TABLE)", "count"}},
        {"diffusionResX", {"diffusion grid voxels along x (diffusion.bin: x fastest)", "voxels"}},
        {"diffusionResY", {"diffusion grid voxels along y", "voxels"}},
        {"diffusionResZ", {"diffusion grid voxels along z", "voxels"}},
        {"photonResX", {"photon grid voxels along x (photons.bin: x fastest)", "voxels"}},
        {"photonResY", {"photon grid voxels along y", "voxels"}},
        {"photonResZ", {"photon grid voxels along z", "voxels"}},
        {"skinResX",
         {"skin profile light volume voxels along x (skin_tau.bin: x fastest; 0: none)", "voxels"}},
        {"skinResY", {"skin profile light volume voxels along y", "voxels"}},
        {"skinResZ", {"skin profile light volume voxels along z", "voxels"}},
        {"skinK",
         {"the skin profile's extinction per unit density integral toward the sun",
          "1/density integral"}},
        {"skinFloor", {"the skin profile's lower bound", "1 (a factor)"}},
        {"msP1",
         {"render.ms_p1: weight of the diffusion's P1 (gradient) term in its radiance",
          "1 (a factor)"}},
        {"mediumG", {"the phase function's mean cosine g (the diffusion's P1 term)", "1 (cosine)"}},
        {"vdbDensity",
         {"RT_VDB: the field's density scale (field.density), multiplying the grid's values; the "
          "grid's box is boundsLo/Hi",
          "1 (factor)"}},
        {"baseBakeRes",
         {"RT_BAKED_NOISE: nodes per axis of the base noise tile (noise_base.bin: baseBakeRes^3 "
          "floats, x fastest; field.base_bake_resolution; 0 without)",
          "nodes"}},
        {"detailBakeRes",
         {"RT_BAKED_NOISE: nodes per axis of the detail noise tile (noise_detail.bin; "
          "field.detail_bake_resolution; 0 without)",
          "nodes"}},
        {"lightLo",
         {"RT_LIGHT_VOLUME or RT_GATE_VOLUME: lower corner of the sun's light-attenuation "
          "volume (light_tau.bin; w 0)",
          "world units"}},
        {"lightHi",
         {"RT_LIGHT_VOLUME: upper corner of that volume: inside the box (faces included) the "
          "sun's density integral is read from it, outside a shadow march is taken (w 0)",
          "world units"}},
        {"lightVoxel", {"RT_LIGHT_VOLUME: that volume's voxel size (xyz; w 0)", "world units"}},
        {"lightResX",
         {"RT_LIGHT_VOLUME: light volume voxels along x (light_tau.bin: x fastest; 0 without)",
          "voxels"}},
        {"lightResY", {"RT_LIGHT_VOLUME: light volume voxels along y", "voxels"}},
        {"lightResZ", {"RT_LIGHT_VOLUME: light volume voxels along z", "voxels"}},
        {"skyVolumeLo",
         {"RT_SKY_VOLUME: lower corner of the single-scattered sky's volume (sky_volume.bin; w 0)",
          "world units"}},
        {"skyVolumeVoxel", {"RT_SKY_VOLUME: that volume's voxel size (xyz; w 0)", "world units"}},
        {"skyVolumeResX",
         {"RT_SKY_VOLUME: sky volume voxels along x (sky_volume.bin: x fastest; 0 without)",
          "voxels"}},
        {"skyVolumeResY", {"RT_SKY_VOLUME: sky volume voxels along y", "voxels"}},
        {"skyVolumeResZ", {"RT_SKY_VOLUME: sky volume voxels along z", "voxels"}},
        {"skyDirections",
         {"RT_SKY_VOLUME: the sky's directions K (render.sky_directions): K records at the start "
          "of sky_volume.bin and K density integrals per voxel after them",
          "count"}},
        {"majorantLo",
         {"RT_SKIP: lower corner of the majorant grid's box (majorant.bin; w 0)", "world units"}},
        {"majorantCell", {"RT_SKIP: the majorant grid's cell size (xyz; w 0)", "world units"}},
        {"majorantResX",
         {"RT_SKIP: majorant grid cells along x (majorant.bin: x fastest; 0 without)", "cells"}},
        {"majorantResY", {"RT_SKIP: majorant grid cells along y", "cells"}},
        {"majorantResZ", {"RT_SKIP: majorant grid cells along z", "cells"}},
        {"sdfScale",
         {"RT_SDF: the SDF cloud's density deep inside (field.density)", "1 (density)"}},
        {"sdfFalloff",
         {"RT_SDF: the SDF cloud's falloff width w: density = sdfScale * smoothstep(0, w, -d)",
          "world units"}},
        {"sdfNodeCount",
         {"RT_SDF: the number of SdfTreeNode entries in sdf_nodes.bin (postfix, root last)",
          "nodes"}},
        {"sliceIndex",
         {"RT_RESUMABLE only (nimbus rt's march in slices on Mesa llvmpipe; an export has none "
          "of it): the slice this dispatch marches, 0 starting the rays; an engine leaves 0",
          "1 (index)"}},
        {"sliceSteps",
         {"RT_RESUMABLE only: camera steps per ray per dispatch; an engine leaves 0", "steps"}},
        {"loopProbe",
         {"RT_RESUMABLE only: iterations of the loop that checks llvmpipe's loop budget (2); an "
          "engine leaves 0",
          "iterations"}},
        {"camForward", {"camera viewing direction (unit xyz; w 0)", "unit vector"}},
        {"camRight", {"camera right vector (unit xyz; w 0)", "unit vector"}},
        {"camUp", {"camera up vector (unit xyz; w 0)", "unit vector"}},
        {"boundsLo",
         {"lower corner of the field's box: the march walks this box (w 0)", "world units"}},
        {"boundsHi", {"upper corner of the field's box (w 0)", "world units"}},
        {"sunDirection", {"unit direction toward the sun (w 0)", "unit vector"}},
        {"sunIrradiance",
         {"sun irradiance, RGB, sun.intensity folded in (w 0)", "scene-linear RGB irradiance"}},
        {"sigmaS",
         {"scattering coefficient per unit density, RGB, medium.density_scale folded "
          "in (w 0)",
          "1/world unit"}},
        {"sigmaT",
         {"extinction coefficient per unit density, RGB, density scale folded in (w 0)",
          "1/world unit"}},
        {"skyZenith",
         {"sky radiance at the zenith (a uniform sky: everywhere), RGB (w 0)",
          "scene-linear RGB radiance"}},
        {"skyHorizon",
         {"sky radiance at the horizon (gradient sky), RGB (w 0)", "scene-linear RGB radiance"}},
        {"skySphere",
         {"mean sky radiance over the sphere times sky.ambient, RGB: the ambient "
          "term (w 0)",
          "scene-linear RGB radiance"}},
        {"baseOffset", {"cumulus base noise offset: field wind * frame time (w 0)", "world units"}},
        {"detailOffset",
         {"cumulus detail noise offset: (wind + detail wind) * frame time (w 0)", "world units"}},
        {"layerBottom", {"cloud layer base altitude (y)", "world units"}},
        {"layerTop", {"cloud layer top altitude (y)", "world units"}},
        {"heightA", {"height distribution rise rate a (large: flat base)", "1 (per layer height)"}},
        {"heightB", {"height distribution decay rate b", "1 (per layer height)"}},
        {"coverage", {"cloud coverage; the noise threshold is 1 - coverage", "fraction [0,1]"}},
        {"softness", {"width of the soft edge above the threshold", "noise units"}},
        {"erosion", {"how much the detail noise erodes the edges", "fraction [0,1)"}},
        {"towerSpacing",
         {"size of the hashed cells holding at most one tower each", "world units"}},
        {"towerRadiusMin", {"tower footprint radius (3 sigma), smallest", "world units"}},
        {"towerRadiusMax", {"tower footprint radius (3 sigma), largest", "world units"}},
        {"towerHeightMin", {"tower column height, smallest", "fraction of the layer height"}},
        {"towerHeightMax", {"tower column height, largest", "fraction of the layer height"}},
        {"towerProbability", {"chance that a cell holds a tower", "probability [0,1]"}},
        {"towerAnisotropy", {"tower footprint elongation (0 round, up to 0.9)", "1"}},
        {"fieldSeed", {"seed of the field's noise and towers", "integer"}},
        {"fieldDensity", {"scale of the cloud shape's density", "density units"}},
        {"basePeriod", {"world size of one tile of the base noise", "world units"}},
        {"baseLattice", {"lattice cells per base-noise tile (lowest octave)", "count"}},
        {"baseOctaves", {"octaves of the base noise", "count"}},
        {"detailPeriod", {"world size of one tile of the detail noise", "world units"}},
        {"detailLattice", {"lattice cells per detail-noise tile (lowest octave)", "count"}},
        {"detailOctaves", {"octaves of the detail noise", "count"}},
        {"phaseKind",
         {"phase function: 0 isotropic, 1 hg, 2 dual_hg, 3 draine, 4 mie_approx "
          "(PHASE_* of core/kernels/phase.glsl)",
          "enum"}},
        {"phaseG", {"asymmetry g (hg, draine; the first lobe of dual_hg)", "1 [-1,1]"}},
        {"phaseG2", {"asymmetry of the second lobe (dual_hg)", "1 [-1,1]"}},
        {"phaseBlend", {"weight of the second lobe (dual_hg)", "fraction [0,1]"}},
        {"phaseAlpha", {"Draine's alpha", "1"}},
        {"phaseDiameter", {"droplet diameter (mie_approx)", "micrometres"}},
        {"tanHalfY", {"tan of half the vertical field of view", "1"}},
        {"aspect", {"image width / height", "1"}},
        {"width", {"image width; the pass skips invocations at x >= width", "pixels"}},
        {"height", {"image height; the pass skips invocations at y >= height", "pixels"}},
        {"frameKey",
         {"hash of the frame and render.seed: seeds every jitter and sample of the "
          "frame (pcg(frameSeedKey ^ pcg(render.seed)))",
          "hash"}},
        {"jitter",
         {"1: jitter each ray's steps and samples (render.jitter); 0: mid-points", "bool as int"}},
        {"epsilon", {"a ray stops once its transmittance is below this in every channel", "1"}},
        {"step", {"first step of the primary march (the frame plan's step)", "world units"}},
        {"stepGrowth",
         {"growth of the primary steps past 1 / growth steps (render.step_growth)",
          "ratio per step"}},
        {"shadowStep",
         {"first step of the shadow march (the frame plan's shadow step)", "world units"}},
        {"shadowGrowth", {"growth of the shadow steps (render.shadow_growth)", "ratio per step"}},
        {"stepTau",
         {"a step (camera or shadow) thicker than this optical depth at its sample is split into "
          "sub-steps no thicker, at most 64 (render.step_tau); 0: never split",
          "optical depth"}},
        {"octaves", {"multiple-scattering octaves (Wrenninge; render.octaves)", "count"}},
        {"octaveContribution", {"octave contribution factor a", "1"}},
        {"octaveExtinction", {"octave extinction factor b", "1"}},
        {"octaveEccentricity", {"octave eccentricity factor c", "1"}},
        {"octaveGate",
         {"render.octave_gate: octaves above the first times 1 - exp(-octaveGate sigma_s tau), tau "
          "the density integral toward and away from the sun (0: off)",
          "1/density integral per sigma_s"}},
        {"inScatter",
         {"in-scatter model: 0 none, 1 olajos, 2 powder (INSCATTER_* of "
          "core/kernels/lighting.glsl)",
          "enum"}},
        {"inScatterC", {"in-scatter constant c (olajos: 1 - exp(-c density))", "1"}},
        {"inScatterStrength", {"in-scatter strength", "1"}},
        {"skyKind",
         {"sky: 0 none, 1 uniform (skyZenith), 2 gradient (skyHorizon to skyZenith)", "enum"}},
        {"ambientGround", {"ground term of the height-occluded sky ambient", "fraction"}},
        {"pixelSamples", {"samples per pixel (RT_MULTISAMPLE: one dispatch per sample)", "count"}},
        {"filterKind",
         {"pixel filter: 0 box, 1 gaussian, 2 Blackman-Harris (FILTER_* of "
          "core/kernels/pixel.glsl)",
          "enum"}},
        {"filterWidth", {"pixel filter radius", "pixels"}},
        {"sampleIndex",
         {"the pixel sample this dispatch adds: set to 0, 1, ..., pixelSamples - 1 "
          "before each dispatch (RT_MULTISAMPLE); 0 otherwise",
          "index"}},
    };
    const auto it = docs.find(n);
    return it == docs.end() ? ParamDoc{} : it->second;
}

namespace {

std::string jsonString(std::string_view s) {
    std::string o = "\"";
    for (const char c : s) {
        switch (c) {
        case '"':
            o += "\\\"";
            break;
        case '\\':
            o += "\\\\";
            break;
        case '\n':
            o += "\\n";
            break;
        case '\t':
            o += "\\t";
            break;
        default:
            if (static_cast<unsigned char>(c) < 0x20) {
                char b[8];
                std::snprintf(b, sizeof b, "\\u%04x", c);
                o += b;
            } else {
                o += c;
            }
        }
    }
    return o + "\"";
}

/// A float that reads back to the same bits (9 significant digits); false for NaN/Inf.
bool jsonFloat(float v, std::string& o) {
    if (!std::isfinite(v)) return false;
    // -0 as "-0.0": JSON readers take "-0" for the integer 0 and lose the sign (Python's json
    // did; smoke1's camera has an up vector with a z of -0)
    if (v == 0.0f && std::signbit(v)) {
        o += "-0.0";
        return true;
    }
    char b[32];
    std::snprintf(b, sizeof b, "%.9g", double(v));
    o += b;
    return true;
}

/// The workgroup size of `layout(local_size_x = X, local_size_y = Y) in;` in the text.
bool workgroupSize(std::string_view text, unsigned size[3]) {
    size[0] = size[1] = size[2] = 1;
    const std::size_t at = text.find("layout(local_size_x");
    if (at == std::string_view::npos) return false;
    const std::string_view l = text.substr(at, text.find(';', at) - at);
    const char* axes[3] = {"local_size_x", "local_size_y", "local_size_z"};
    for (int a = 0; a < 3; ++a) {
        const std::size_t p = l.find(axes[a]);
        if (p == std::string_view::npos) continue;
        const std::size_t eq = l.find('=', p);
        if (eq == std::string_view::npos) return false;
        size[a] = unsigned(std::strtoul(std::string(l.substr(eq + 1)).c_str(), nullptr, 10));
    }
    return size[0] > 0 && size[1] > 0 && size[2] > 0;
}

/// The shader storage blocks of the text: `layout(std430, binding = N) [qualifiers] buffer Name`.
struct BufferBinding {
    unsigned binding = 0;
    std::string name;
    bool readonly = false;
};
std::vector<BufferBinding> bufferBindings(std::string_view text) {
    std::vector<BufferBinding> out;
    std::size_t at = 0;
    while ((at = text.find("layout(std430, binding = ", at)) != std::string_view::npos) {
        const std::size_t eol = text.find('\n', at);
        const std::string_view l = text.substr(at, eol - at);
        at = eol;
        const std::size_t buf = l.find(" buffer ");
        if (buf == std::string_view::npos) continue;
        BufferBinding b;
        b.binding = unsigned(std::strtoul(std::string(l.substr(25)).c_str(), nullptr, 10));
        b.readonly = l.substr(0, buf).find("readonly") != std::string_view::npos;
        std::string_view n = l.substr(buf + 8);
        std::size_t e = 0;
        while (e < n.size() && isIdent(n[e])) ++e;
        b.name = std::string(n.substr(0, e));
        out.push_back(b);
    }
    return out;
}

/// What each buffer of the pass holds (march_pass.glsl).
std::string bufferMeaning(std::string_view name) {
    if (name == "RtParamBlock")
        return "the parameter block (struct RtMarchParams, std430): params.bin, described by "
               "parameter_block below";
    if (name == "RtPixels")
        return "the output: 12 floats per pixel, row-major from the top-left; zero it before a "
               "frame's first dispatch (the pass adds to it)";
    if (name == "RtCounters")
        return "one uint: samples that were NaN or infinite (left out); zero it before a frame";
    if (name == "RtMieTable")
        return "the Lorenz-Mie phase table: per node a vec4 (cos theta, R, G, B), cos theta "
               "ascending, the phase function per steradian";
    if (name == "RtDiffusionGrid")
        return "the diffusion grid's fluence for this frame: 3 floats (R, G, B) per voxel, x "
               "fastest, then y, then z; its box, resolution and voxel are in the parameter block";
    if (name == "RtPhotonGrid")
        return "the photon grid's in-scattered radiance for this frame: 3 floats (R, G, B) per "
               "voxel, x fastest, then y, then z; box and resolution in the parameter block";
    if (name == "RtSkinGrid")
        return "the density integral toward the sun at the photon grid's voxel centres (1 float "
               "per voxel, same order), for the photons' skin profile";
    if (name == "RtLightGrid")
        return "the sun's light-attenuation volume for this frame (LightVolume, "
               "core/lighting/light_volume.h, render.shadow = \"volume\"): the density integral "
               "from each voxel centre toward the sun (1 float per voxel, x fastest, then y, then "
               "z; lightResX/Y/Z voxels of lightVoxel from lightLo), read trilinearly between the "
               "centres (clamped to the outermost) and multiplied by the extinction per unit "
               "density (sigmaT) for the sun's transmittance (RT_LIGHT_VOLUME); with "
               "RT_GATE_VOLUME (octaves gated by render.octave_gate, and a volume the frame "
               "builds anyway) also read where the sun's line through a sample leaves the box on "
               "the side away from the sun (the kernel boxExitPoint), which gives the density "
               "integral along that whole line";
    if (name == "RtSkyVolume")
        return "the single-scattered sky for this frame (render.sky_shadow = \"volume\", "
               "core/lighting/sky_volume.h): first skyDirections records of 8 floats, the unit "
               "direction w_k toward the sky (xyz, then 0) and the sky's radiance there times "
               "sky.ambient (RGB, then 0); then the sky volume (SkyVolume): skyDirections density "
               "integrals per voxel, from the voxel centre toward each w_k, side by side, voxels "
               "x fastest, then y, then z (skyVolumeResX/Y/Z voxels of skyVolumeVoxel from "
               "skyVolumeLo), read trilinearly between the centres (clamped to the outermost); "
               "the light is sum_k W_k exp(-sigmaT tau_k), W_k = L_k p(d . w_k) / sum_j "
               "p(d . w_j)";
    if (name == "RtVdbGrid")
        return "the field's NanoVDB grid: the bytes of one nanovdb::FloatGrid (NanoVDB's in-memory "
               "layout, not an .nvdb file: no file header, no compression), from its GridData at "
               "byte 0 to gridSize(), read as uints through PNanoVDB (the grid at address 0); its "
               "own map (world to index) is inside it, its box is boundsLo/Hi and its density "
               "scale vdbDensity in the parameter block";
    if (name == "RtBaseNoise" || name == "RtDetailNoise")
        return std::string("the ") + (name == "RtBaseNoise" ? "base" : "detail") +
               " noise tile the CPU baked for the sequence (NoiseVolume, "
               "core/fields/cumulus.h): " +
               (name == "RtBaseNoise" ? "baseBakeRes" : "detailBakeRes") +
               "^3 floats, one per node of a periodic tile, x fastest, then y, then z; the noise "
               "with its octaves summed (one value per node, no channels); read trilinearly, "
               "wrapping, at the noise-domain point times the resolution";
    if (name == "RtMajorant")
        return "the field's majorant grid for this frame (MajorantGrid, core/tracking/majorant.h: "
               "the grid the CPU renders the frame with): first one float per cell, the cell's "
               "density bound (padded: 0 means the cell grown by 5% of its size holds no cloud), "
               "x fastest, then y, then z, majorantResX/Y/Z cells of majorantCell from "
               "majorantLo in the parameter block; then one float per block of 4x4x4 cells "
               "(ceil(majorantRes / 4) blocks per axis, x fastest): 0 when the block holds a "
               "cell whose bound is not 0, else its Chebyshev distance in blocks to the nearest "
               "such block, at most 255 (the cube of 2 d - 1 blocks around it is empty). The "
               "pass reads only whether a bound is 0, and leaps over empty cells and blocks "
               "(empty-space skipping)";
    if (name == "RtSdfNodes")
        return "the SDF cloud's tree: struct SdfTreeNode (core/kernels/sdf_tree.glsl, std430, 144 "
               "bytes each) per node in postfix order (children before their parent, root last), "
               "as SdfTree::gpuNodes holds them; sdfNodeCount in the parameter block. Per node, "
               "byte offsets: 0, 16, 32 the columns of localFromWorld (vec4, w 0); 48 "
               "localOffset (vec4, local = localFromWorld * p + localOffset); 64 p0, 80 p1 (vec4, "
               "the primitive's parameters); 96 int kind (SDF_KIND_*: 0 sphere .. 7 plane, 8 "
               "union, 9 intersection, 10 subtraction); 100 int childCount; 104 float factor; "
               "108 float k (blend width); 112 float amplitude (displacement, 0 none); 116 int "
               "noiseKind (0 Perlin, 1 Worley); 120 float frequency; 124 int octaves; 128 float "
               "gain; 132 uint seed; 136 and 140 two ints of padding";
    return "";
}

/// The file a data buffer's bytes go to ("" for buffers the engine makes itself).
const char* bufferFile(std::string_view name) {
    if (name == "RtParamBlock") return kExportParamsFile;
    if (name == "RtMieTable") return "mie_table.bin";
    if (name == "RtDiffusionGrid") return "diffusion.bin";
    if (name == "RtPhotonGrid") return "photons.bin";
    if (name == "RtSkinGrid") return "skin_tau.bin";
    if (name == "RtVdbGrid") return "vdb_grid.bin";
    if (name == "RtLightGrid") return "light_tau.bin";
    if (name == "RtSkyVolume") return "sky_volume.bin";
    if (name == "RtBaseNoise") return "noise_base.bin";
    if (name == "RtDetailNoise") return "noise_detail.bin";
    if (name == "RtMajorant") return "majorant.bin";
    if (name == "RtSdfNodes") return "sdf_nodes.bin";
    return "";
}

template <class T> std::vector<std::uint8_t> bytesOf(const std::vector<T>& v) {
    std::vector<std::uint8_t> b(v.size() * sizeof(T));
    if (!b.empty()) std::memcpy(b.data(), v.data(), b.size());
    return b;
}

} // namespace

bool exportGlsl(const SceneDesc& s, const FramePlan& p, const std::string& scenePath,
                const MarchGrids* grids, const FrameBindings* bindings, const BakedNoise* noise,
                const MajorantGrid* majorant, GlslExport& out, std::string* error) {
    const std::vector<Unsupported> no = unsupported(s, p);
    if (!no.empty()) {
        if (error) *error = no.front().message;
        return false;
    }
    {
        const MarchFeatures f = marchFeatures(s, p, majorant);
        if (const std::string e = frameDataError(s, p, grids, noise, "the export"); !e.empty()) {
            if (error) *error = e;
            return false;
        }
        // the data the shader reads besides the block: the same bytes MarchPass uploads
        static_assert(sizeof(vec3) == 3 * sizeof(float));
        out.data.clear();
        if (f.mieTable)
            out.data.emplace_back(
                bufferFile("RtMieTable"),
                bytesOf(mieTableNodes(*Medium::fromDesc(s.medium).phase.table())));
        if (f.diffusion)
            out.data.emplace_back(bufferFile("RtDiffusionGrid"), bytesOf(grids->diffusion.phi));
        if (f.photons)
            out.data.emplace_back(bufferFile("RtPhotonGrid"), bytesOf(grids->photons.radiance));
        if (f.photonSkin)
            out.data.emplace_back(bufferFile("RtSkinGrid"), bytesOf(grids->photons.sunTau->tau));
        if (f.lightVolume || f.gateVolume)
            out.data.emplace_back(bufferFile("RtLightGrid"), bytesOf(grids->towardVolume()->tau));
        if (f.skyVolume)
            out.data.emplace_back(bufferFile("RtSkyVolume"),
                                  bytesOf(skyVolumeBuffer(s, grids->sky)));
        if (f.sdf) out.data.emplace_back(bufferFile("RtSdfNodes"), bytesOf(sdfTreeNodes(s)));
        if (f.vdb) {
            const VdbGridBytes g = vdbGridBytes(bindings, error);
            if (!g.data) return false;
            const auto* b = static_cast<const std::uint8_t*>(g.data);
            out.data.emplace_back(bufferFile("RtVdbGrid"),
                                  std::vector<std::uint8_t>(b, b + g.size));
        }
        if (f.rgbaNoise) {
            out.data.emplace_back(kBaseChannelsFile, noise->base->rgba);
            out.data.emplace_back(kDetailChannelsFile, noise->detail->rgba);
        } else if (f.bakedNoise) {
            out.data.emplace_back(bufferFile("RtBaseNoise"), bytesOf(noise->base->values));
            out.data.emplace_back(bufferFile("RtDetailNoise"), bytesOf(noise->detail->values));
        }
        if (f.skip)
            out.data.emplace_back(bufferFile("RtMajorant"), bytesOf(majorantBuffer(*majorant)));
    }
    // the shader nimbus rt compiles, the disabled features' code removed
    const MarchShader m = marchShader(s, p, majorant);
    out.features = m.features;
    std::string conditional, stripped;
    if (!stripFeatureConditionals(m.source, featureMacros(m.features), conditional, error) ||
        !removeUnreferenced(conditional, stripped, error))
        return false;
    std::ostringstream head;
    const auto macros = featureMacros(m.features);
    {
        // the header goes after the #version line, which must come first
        const std::size_t eol = stripped.find('\n');
        head << stripped.substr(0, eol + 1);
        std::vector<std::string> words;
        auto say = [&](const std::string& text) {
            std::size_t a = 0;
            while (a < text.size()) {
                const std::size_t b = text.find(' ', a);
                words.push_back(text.substr(a, b == std::string::npos ? b : b - a));
                a = b == std::string::npos ? text.size() : b + 1;
            }
        };
        std::string path = scenePath; // inside a // comment: no line breaks
        for (char& c : path)
            if (static_cast<unsigned char>(c) < 0x20) c = '?';
        say("Exported by `nimbus export-glsl` from " + path + ", frame " + std::to_string(p.frame) +
            ": the GLSL march pass of `nimbus rt` with only the features this frame uses");
        std::string f = "(";
        for (std::size_t i = 0; i < macros.size(); ++i)
            f += (i ? ", " : "") + macros[i].first + (macros[i].second ? " on" : " off");
        say(f + "); the code of the others is not in this text, nor the kernels main() does "
                "not reach. Parameters: params.json and "
                "params.bin; bindings, dispatch and output: docs/realtime.md, \"Export for "
                "engines\". Source-string numbers of #line: 0 this header, the feature defines "
                "and core/kernels/prelude.glsl,");
        std::size_t i = 1;
        for (const kern::KernelSource& k : kern::kernelSources())
            say(std::to_string(i++) + "\x01" + std::string(k.path) + ","); // one word
        say(std::to_string(i) + "\x01plugin/realtime/march_params.glsl, " + std::to_string(i + 1) +
            "\x01plugin/realtime/march_data.glsl, " + std::to_string(i + 2) +
            "\x01plugin/realtime/march_pass.glsl" +
            (m.features.vdb ? ", " + std::to_string(i + 3) +
                                  "\x01nanovdb/PNanoVDB.h\x01(preprocessed\x01for\x01GLSL)."
                            : std::string(".")));
        std::string line = "//";
        for (std::string w : words) {
            std::replace(w.begin(), w.end(), '\x01', ' ');
            if (line.size() + 1 + w.size() > 96 && line != "//") {
                head << line << "\n";
                line = "//";
            }
            line += " " + w;
        }
        head << line << "\n";
        stripped = head.str() + stripped.substr(eol + 1);
    }
    out.shader = stripped;

    // the parameter block: the bytes nimbus rt uploads for the frame's first dispatch
    std::vector<ParamMember> members;
    std::size_t blockSize = 0;
    if (!paramBlockLayout(members, &blockSize, error)) return false;
    RtMarchParams P = marchParams(s, p, grids, bindings, majorant);
    P.sampleIndex = 0;
    if (members.empty() || members.back().offset + members.back().size != sizeof P) {
        if (error)
            *error =
                "the std430 layout of march_params.glsl (" +
                std::to_string(members.empty() ? 0 : members.back().offset + members.back().size) +
                " bytes) differs from the C++ struct (" + std::to_string(sizeof P) + ")";
        return false;
    }
    out.params.assign(blockSize, 0);
    std::memcpy(out.params.data(), &P, sizeof P);

    unsigned group[3];
    if (!workgroupSize(out.shader, group)) {
        if (error) *error = "the shader has no layout(local_size_x = ...)";
        return false;
    }
    const int w = s.camera.width, h = s.camera.height;
    const int passes = m.features.multisample ? std::max(1, P.pixelSamples) : 1;

    std::ostringstream j;
    j << "{\n  \"format\": \"nimbus-export-glsl\",\n  \"format_version\": 1,\n";
    j << "  \"scene\": " << jsonString(scenePath) << ",\n  \"frame\": " << p.frame
      << ",\n  \"time_seconds\": ";
    std::string t;
    jsonFloat(p.time, t);
    j << (t.empty() ? "null" : t) << ",\n";
    j << "  \"shader\": " << jsonString(kExportShaderFile) << ",\n";
    j << "  \"glsl_version\": \"430\",\n  \"features\": {";
    for (std::size_t i = 0; i < macros.size(); ++i)
        j << (i ? ", " : "") << jsonString(macros[i].first) << ": "
          << (macros[i].second ? "true" : "false");
    j << "},\n";
    j << "  \"workgroup_size\": [" << group[0] << ", " << group[1] << ", " << group[2] << "],\n";
    j << "  \"image\": {\"width\": " << w << ", \"height\": " << h << "},\n";
    j << "  \"dispatch\": {\"groups\": [" << (unsigned(w) + group[0] - 1) / group[0] << ", "
      << (unsigned(h) + group[1] - 1) / group[1] << ", 1], \"passes\": " << passes
      << ", \"per_pass\": \"set sampleIndex to the pass number (0 .. passes - 1) before each "
         "dispatch; the output buffer accumulates\"},\n";
    j << "  \"buffers\": [\n";
    const std::vector<BufferBinding> buffers = bufferBindings(out.shader);
    for (std::size_t i = 0; i < buffers.size(); ++i) {
        const BufferBinding& b = buffers[i];
        std::size_t bytes = 0;
        if (b.name == "RtParamBlock") bytes = blockSize;
        if (b.name == "RtPixels") bytes = std::size_t(w) * std::size_t(h) * 12 * sizeof(float);
        if (b.name == "RtCounters") bytes = 4;
        for (const auto& [file, data] : out.data)
            if (file == bufferFile(b.name)) bytes = data.size();
        j << "    {\"binding\": " << b.binding << ", \"block\": " << jsonString(b.name)
          << ", \"layout\": \"std430\", \"access\": \"" << (b.readonly ? "readonly" : "read-write")
          << "\", \"bytes\": " << bytes;
        if (*bufferFile(b.name)) j << ", \"file\": " << jsonString(bufferFile(b.name));
        j << ", \"meaning\": " << jsonString(bufferMeaning(b.name)) << "}"
          << (i + 1 < buffers.size() ? "," : "") << "\n";
    }
    j << "  ],\n";
    j << "  \"output\": {\"buffer_binding\": 1, \"floats_per_pixel\": 12, \"order\": \"row-major "
         "from the top-left pixel\", \"floats\": [\"sum w*R\", \"sum w*G\", \"sum w*B\", \"sum "
         "w*alpha\", \"sum w*T_R\", \"sum w*T_G\", \"sum w*T_B\", \"sum w\", \"sum w*depth\", "
         "\"sum w (samples with a depth)\", \"unused\", \"unused\"], \"resolve\": \"RGBA = "
         "sums[0..3] / sum w and transmittance = sums[4..6] / sum w where sum w > 0; depth = "
         "sums[8] / sums[9] where sums[9] > 0, else 0. Premultiplied scene-linear RGB in the "
         "working space (before nimbus rt's output colour transform); depth in world units along "
         "the ray\"},\n";
    j << "  \"textures\": [";
    if (m.features.rgbaNoise) {
        // Olajos' channel layout (field.evaluation = "rgba"): the sampler3D units of
        // march_data.glsl
        const CumulusDesc& c = s.field.cumulus;
        const struct {
            const char* sampler;
            int unit, res;
            const char* file;
            const char* meaning;
        } tex[2] = {
            {"rtBaseChannels", 4, c.baseBakeResolution, kBaseChannelsFile,
             "the base noise in Olajos' channel layout (kern::cumulusBaseChannels, "
             "core/kernels/cloud.glsl): R the Perlin FBM mapped to [0, 1], G, B, A the Worley "
             "noise at 1, 2 and 4 times the lattice frequency; the shader combines the filtered "
             "channels (cumulusBaseFromChannels)"},
            {"rtDetailChannels", 5, c.detailBakeResolution, kDetailChannelsFile,
             "the detail noise in Olajos' channel layout (kern::cumulusDetailChannels): R, G, B "
             "its Worley octaves 0, 1, 2, A the octaves from 3 on averaged with their weights; "
             "combined after the filter (cumulusDetailFromChannels)"}};
        for (int k = 0; k < 2; ++k)
            j << (k ? "," : "") << "\n    {\"sampler\": " << jsonString(tex[k].sampler)
              << ", \"unit\": " << tex[k].unit << ", \"target\": \"GL_TEXTURE_3D\", \"size\": ["
              << tex[k].res << ", " << tex[k].res << ", " << tex[k].res
              << "], \"format\": \"GL_RGBA8\", \"filter\": \"GL_LINEAR\", \"wrap\": "
                 "\"GL_REPEAT\", \"file\": "
              << jsonString(tex[k].file)
              << ", \"layout\": \"4 bytes (R, G, B, A) per texel, x fastest, then y, then z; "
                 "the tile is periodic\", \"meaning\": "
              << jsonString(tex[k].meaning) << "}";
        j << "\n  ";
    }
    j << "],\n";
    j << "  \"parameter_block\": {\"struct\": \"RtMarchParams\", \"block\": \"RtParamBlock\", "
         "\"binding\": 0, \"bytes\": "
      << blockSize << ", \"file\": " << jsonString(kExportParamsFile) << ",\n    \"members\": [\n";
    for (std::size_t i = 0; i < members.size(); ++i) {
        const ParamMember& mb = members[i];
        const ParamDoc d = paramDoc(mb.name);
        if (d.meaning.empty()) {
            if (error) *error = "march_params.glsl: member " + mb.name + " has no documentation";
            return false;
        }
        std::string v;
        const std::uint8_t* at = out.params.data() + mb.offset;
        bool finite = true;
        if (mb.type == "vec4") {
            float f[4];
            std::memcpy(f, at, sizeof f);
            v = "[";
            for (int c = 0; c < 4; ++c) {
                if (c) v += ", ";
                finite = jsonFloat(f[c], v) && finite;
            }
            v += "]";
        } else if (mb.type == "float") {
            float f;
            std::memcpy(&f, at, sizeof f);
            finite = jsonFloat(f, v);
        } else if (mb.type == "int") {
            std::int32_t x;
            std::memcpy(&x, at, sizeof x);
            v = std::to_string(x);
        } else {
            std::uint32_t x;
            std::memcpy(&x, at, sizeof x);
            v = std::to_string(x);
        }
        if (!finite) {
            if (error) *error = "parameter " + mb.name + " is not finite for this frame";
            return false;
        }
        j << "      {\"name\": " << jsonString(mb.name) << ", \"type\": " << jsonString(mb.type)
          << ", \"offset\": " << mb.offset << ", \"bytes\": " << mb.size << ", \"value\": " << v
          << ",\n       \"meaning\": " << jsonString(d.meaning)
          << ", \"units\": " << jsonString(d.units) << "}" << (i + 1 < members.size() ? "," : "")
          << "\n";
    }
    j << "    ]}\n}\n";
    out.json = j.str();
    return true;
}

} // namespace nimbus::rt
