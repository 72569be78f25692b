/// @file scene_file.cpp
/// @brief The scene-file parameter table, strict TOML validation, `--set` overrides and the
///        generated reference (see scene_file.h).
///
/// Layout of this file:
///  1. text helpers, source locations and the problem list;
///  2. the parameter table (registry()): one row per key with type, range, doc and accessors;
///  3. the rules across keys (rules()), each with its one-line doc;
///  4. reading TOML nodes against a row, overrides, validation;
///  5. the reference generator, which walks the same two tables.
/// Adding a key = adding one row to registry(); parser, errors, warnings and reference follow.
#include "plugin/io/scene_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <utility>

#include <toml++/toml.h>

#include "core/tracking/volumes.h"
#include "plugin/io/frames.h"

namespace nimbus::io {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ------------------------------------------------------------------------------------------
// 1. Text helpers, locations, problems
// ------------------------------------------------------------------------------------------

/// Shortest text that reads back as the same float (values are stored as float).
std::string formatFloat(double x) {
    char buf[64];
    auto r = std::to_chars(buf, buf + sizeof buf, float(x));
    return std::string(buf, r.ptr);
}

/// Shortest text of a double: what the user wrote, for error messages.
std::string formatDouble(double x) {
    char buf[64];
    auto r = std::to_chars(buf, buf + sizeof buf, x);
    return std::string(buf, r.ptr);
}

/// A TOML basic string.
std::string quote(std::string_view s) {
    std::string out = "\"";
    for (char c : s) {
        switch (c) {
        case '"':
            out += "\\\"";
            break;
        case '\\':
            out += "\\\\";
            break;
        case '\n':
            out += "\\n";
            break;
        case '\t':
            out += "\\t";
            break;
        case '\r':
            out += "\\r";
            break;
        default:
            if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
                char buf[8];
                std::snprintf(buf, sizeof buf, "\\u%04x", unsigned(static_cast<unsigned char>(c)));
                out += buf;
            } else {
                out += c;
            }
        }
    }
    return out + "\"";
}

std::string trim(std::string_view s) {
    size_t a = s.find_first_not_of(" \t");
    if (a == std::string_view::npos) return {};
    size_t b = s.find_last_not_of(" \t");
    return std::string(s.substr(a, b - a + 1));
}

std::string join(const std::vector<std::string>& items, std::string_view sep) {
    std::string out;
    for (size_t i = 0; i < items.size(); ++i) out += (i ? std::string(sep) : "") + items[i];
    return out;
}

std::string quotedList(const std::vector<std::string>& words) {
    std::vector<std::string> q;
    for (const std::string& w : words) q.push_back(quote(w));
    return join(q, ", ");
}

size_t editDistance(std::string_view a, std::string_view b) {
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diag = row[0];
        row[0] = i;
        for (size_t j = 1; j <= b.size(); ++j) {
            size_t up = row[j];
            char ca = char(std::tolower(static_cast<unsigned char>(a[i - 1])));
            char cb = char(std::tolower(static_cast<unsigned char>(b[j - 1])));
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (ca == cb ? 0 : 1)});
            diag = up;
        }
    }
    return row[b.size()];
}

/// " (did you mean "x"?)" for the closest candidate, or "".
std::string suggestion(std::string_view word, const std::vector<std::string>& candidates) {
    std::string best;
    size_t bestDistance = std::max<size_t>(2, word.size() / 3) + 1;
    for (const std::string& c : candidates) {
        size_t d = editDistance(word, c);
        if (d < bestDistance) {
            bestDistance = d;
            best = c;
        }
    }
    return best.empty() ? "" : " (did you mean " + quote(best) + "?)";
}

/// Where a problem is: "file:line:column" or the override it came from.
struct Where {
    std::string prefix;
    int rank = 0; ///< 0: the file; 1 + i: override i (overrides sort after the file)
    int line = 0;
    int column = 0;
};

struct Context {
    std::string sourceName;
    std::vector<std::string> labels; ///< "--set section.key=value", one per override

    Where at(const toml::source_region& r) const {
        if (r.path)
            for (size_t i = 0; i < labels.size(); ++i)
                if (*r.path == labels[i]) return {labels[i], int(i) + 1, 0, 0};
        int line = std::max(1, int(r.begin.line));
        int column = std::max(1, int(r.begin.column));
        return {sourceName + ":" + std::to_string(line) + ":" + std::to_string(column), 0, line,
                column};
    }
    Where at(const toml::node& n) const { return at(n.source()); }
    /// For unknown keys: the key itself in the file, or the override that introduced it.
    Where atKey(const toml::key& k, const toml::node& n) const {
        Where w = at(n);
        if (w.rank > 0 || k.source().begin.line == 0) return w;
        return at(k.source());
    }
};

struct Problems {
    std::vector<std::pair<Where, std::string>> items;

    void add(Where w, std::string text) { items.emplace_back(std::move(w), std::move(text)); }
    bool empty() const { return items.empty(); }

    /// All problems, one per line, in file order then override order.
    std::vector<std::string> lines(std::string_view tag = "") {
        std::stable_sort(items.begin(), items.end(), [](const auto& a, const auto& b) {
            return std::tie(a.first.rank, a.first.line, a.first.column) <
                   std::tie(b.first.rank, b.first.line, b.first.column);
        });
        std::vector<std::string> out;
        for (const auto& [w, text] : items)
            out.push_back(w.prefix + ": " + std::string(tag) + text);
        return out;
    }
    [[noreturn]] void raise() { throw SceneError(join(lines(), "\n")); }
};

/// What a node holds, for "found ..." in messages.
std::string describe(const toml::node& n) {
    if (auto s = n.as_string()) {
        std::string v = s->get();
        if (v.size() > 60) v = v.substr(0, 57) + "...";
        return "string " + quote(v);
    }
    if (auto i = n.as_integer()) return std::to_string(i->get());
    if (auto f = n.as_floating_point()) {
        std::string text = formatDouble(f->get());
        if (std::isfinite(f->get()) && !std::isfinite(float(f->get())))
            text += " (too large for a float)";
        return text;
    }
    if (auto b = n.as_boolean()) return std::string("boolean ") + (b->get() ? "true" : "false");
    if (auto a = n.as_array()) {
        if (a->empty()) return "an empty array";
        return "an array of " + std::to_string(a->size()) +
               (a->size() == 1 ? " element" : " elements");
    }
    if (n.is_table()) return "a table";
    if (n.is_date()) return "a date";
    if (n.is_time()) return "a time";
    if (n.is_date_time()) return "a date-time";
    return "a value of unknown type";
}

// ------------------------------------------------------------------------------------------
// 2. The parameter table
// ------------------------------------------------------------------------------------------

enum class Type { Bool, Int, Number, Vec3, Rgb, Pair, String, Word, WordList, Frames };

std::string typeName(Type t) {
    switch (t) {
    case Type::Bool:
        return "bool";
    case Type::Int:
        return "integer";
    case Type::Number:
        return "number";
    case Type::Vec3:
        return "[x, y, z]";
    case Type::Rgb:
        return "RGB";
    case Type::Pair:
        return "[min, max]";
    case Type::String:
        return "string";
    case Type::Word:
        return "word";
    case Type::WordList:
        return "words";
    case Type::Frames:
        return "frame spec";
    }
    return "?";
}

/// An interval; every numeric component must lie in it (and be finite).
struct Range {
    double lo = -kInf;
    double hi = kInf;
    bool loOpen = false;
    bool hiOpen = false;

    bool any() const { return lo == -kInf && hi == kInf; }
    bool contains(double x) const {
        if (!std::isfinite(x)) return false;
        return (loOpen ? x > lo : x >= lo) && (hiOpen ? x < hi : x <= hi);
    }
    std::string text(bool integer) const {
        auto num = [&](double x) {
            return integer ? std::to_string(std::int64_t(x)) : formatFloat(x);
        };
        if (any()) return "";
        if (hi == kInf) return (loOpen ? "> " : ">= ") + num(lo);
        if (lo == -kInf) return (hiOpen ? "< " : "<= ") + num(hi);
        return (loOpen ? "(" : "[") + num(lo) + ", " + num(hi) + (hiOpen ? ")" : "]");
    }
    /// " in [0, 1]", " > 0" or "" — appended to "a number".
    std::string suffix(bool integer) const {
        std::string t = text(integer);
        if (t.empty()) return "";
        return (t[0] == '[' || t[0] == '(' ? " in " : " ") + t;
    }
};

Range atLeast(double lo) {
    return {lo, kInf, false, false};
}
Range above(double lo) {
    return {lo, kInf, true, false};
}
Range closed(double lo, double hi) {
    return {lo, hi, false, false};
}
Range open(double lo, double hi) {
    return {lo, hi, true, true};
}
Range closedOpen(double lo, double hi) {
    return {lo, hi, false, true};
}
Range openClosed(double lo, double hi) {
    return {lo, hi, true, false};
}
const Range kUInt32 = closed(0.0, 4294967295.0);

/// A parsed value; which members are meaningful depends on the Type.
struct Value {
    bool b = false;
    std::int64_t i = 0;
    double x = 0.0;
    std::array<double, 3> v{};
    std::string s;
    std::vector<std::string> list;
};

/// What a file is parsed into: the SceneFile plus the keys that have no member of their own.
struct Staging {
    SceneFile file;
    std::optional<double> sunElevation; ///< degrees
    std::optional<double> sunAzimuth;   ///< degrees from +z toward +x
    float sunIntensity = 1.0f;
    std::map<std::string, Where> given; ///< "section.key" -> location of its value

    // [[array]] tables
    size_t element = 0; ///< index of the element being read
    struct Placement {
        std::string volume = "field";
        Where where;
    };
    std::vector<Placement> instanceVolumes; ///< per [[instance]]: the volume's name
    std::vector<Where> volumeWhere;         ///< per [[volume]]
    std::vector<Where> meshWhere;           ///< per [[mesh]]
    struct Scatter {
        std::string volume = "field";
        Where where;
        std::int64_t count = 100;
        std::uint32_t seed = 1;
        vec3 regionMin{-10.0f, 2.0f, -10.0f};
        vec3 regionMax{10.0f, 3.0f, 10.0f};
        float scaleMin = 1.0f, scaleMax = 1.0f;
        float yawMin = 0.0f, yawMax = 360.0f;
        float densityMin = 1.0f, densityMax = 1.0f;
    };
    std::vector<Scatter> scatters;
};

struct Param {
    std::string section; ///< "" = top level
    std::string key;
    Type type = Type::Number;
    Range range;
    std::vector<std::string> words; ///< Word / WordList
    std::string doc;
    std::optional<FieldKind> kind; ///< set: belongs to [field] of this kind only
    std::string usedWhenText;      ///< condition under which the key matters (docs, warnings)
    std::function<bool(const SceneFile&)> used;
    std::function<std::string(const Value&)> check; ///< extra test; returns the problem or ""
    std::function<void(Staging&, const Value&)> set;
    std::function<std::optional<Value>(Staging&)> get; ///< nullopt: no default ("unset")

    std::string full() const { return section.empty() ? key : section + "." + key; }
    std::string expected() const;

    Param& onlyFor(FieldKind k) {
        kind = k;
        return *this;
    }
    Param& usedWhen(std::string text, std::function<bool(const SceneFile&)> pred) {
        usedWhenText = std::move(text);
        used = std::move(pred);
        return *this;
    }
    Param& checkedBy(std::function<std::string(const Value&)> fn) {
        check = std::move(fn);
        return *this;
    }
};

std::string Param::expected() const {
    switch (type) {
    case Type::Bool:
        return "true or false";
    case Type::Int:
        return "an integer" + range.suffix(true);
    case Type::Number:
        return "a number" + range.suffix(false);
    case Type::Vec3:
        return "an array of 3 numbers [x, y, z]" +
               (range.any() ? "" : ", each" + range.suffix(false));
    case Type::Rgb:
        return "an RGB colour: [r, g, b] or one grey number, each" + range.suffix(false);
    case Type::Pair:
        return "an array of 2 numbers [min, max], each" + range.suffix(false) + ", min <= max";
    case Type::String:
        return "a string";
    case Type::Word:
        return "one of " + quotedList(words);
    case Type::WordList:
        return "an array of words from " + quotedList(words);
    case Type::Frames:
        return "a frame spec string such as \"1-24\" (or one integer)";
    }
    return "?";
}

template <class F> using Target = std::remove_reference_t<std::invoke_result_t<F, Staging&>>;

Param row(std::string section, std::string key, Type type, Range range, std::string doc) {
    Param p;
    p.section = std::move(section);
    p.key = std::move(key);
    p.type = type;
    p.range = range;
    p.doc = std::move(doc);
    return p;
}

template <class F> Param flag(std::string sec, std::string key, std::string doc, F ref) {
    Param p = row(std::move(sec), std::move(key), Type::Bool, {}, std::move(doc));
    p.set = [ref](Staging& s, const Value& v) { ref(s) = v.b; };
    p.get = [ref](Staging& s) -> std::optional<Value> {
        Value v;
        v.b = ref(s);
        return v;
    };
    return p;
}

/// int or std::uint32_t member.
template <class F>
Param integer(std::string sec, std::string key, Range r, std::string doc, F ref) {
    Param p = row(std::move(sec), std::move(key), Type::Int, r, std::move(doc));
    p.set = [ref](Staging& s, const Value& v) { ref(s) = Target<F>(v.i); };
    p.get = [ref](Staging& s) -> std::optional<Value> {
        Value v;
        v.i = std::int64_t(ref(s));
        return v;
    };
    return p;
}

template <class F> Param number(std::string sec, std::string key, Range r, std::string doc, F ref) {
    Param p = row(std::move(sec), std::move(key), Type::Number, r, std::move(doc));
    p.set = [ref](Staging& s, const Value& v) { ref(s) = float(v.x); };
    p.get = [ref](Staging& s) -> std::optional<Value> {
        Value v;
        v.x = ref(s);
        return v;
    };
    return p;
}

/// vec3 member: a point/direction (Type::Vec3) or a colour (Type::Rgb).
template <class F>
Param vector(std::string sec, std::string key, Type type, Range r, std::string doc, F ref) {
    Param p = row(std::move(sec), std::move(key), type, r, std::move(doc));
    p.set = [ref](Staging& s, const Value& v) {
        ref(s) = vec3(float(v.v[0]), float(v.v[1]), float(v.v[2]));
    };
    p.get = [ref](Staging& s) -> std::optional<Value> {
        Value v;
        const vec3& x = ref(s);
        v.v = {x.x, x.y, x.z};
        return v;
    };
    return p;
}

/// Two float members given as one [min, max] array.
template <class F, class G>
Param pair(std::string sec, std::string key, Range r, std::string doc, F refMin, G refMax) {
    Param p = row(std::move(sec), std::move(key), Type::Pair, r, std::move(doc));
    p.set = [refMin, refMax](Staging& s, const Value& v) {
        refMin(s) = float(v.v[0]);
        refMax(s) = float(v.v[1]);
    };
    p.get = [refMin, refMax](Staging& s) -> std::optional<Value> {
        Value v;
        v.v = {refMin(s), refMax(s), 0.0};
        return v;
    };
    p.check = [](const Value& v) -> std::string {
        if (v.v[0] <= v.v[1]) return "";
        return "min " + formatFloat(v.v[0]) + " exceeds max " + formatFloat(v.v[1]) +
               "; expected [min, max] with min <= max";
    };
    return p;
}

template <class F> Param text(std::string sec, std::string key, std::string doc, F ref) {
    Param p = row(std::move(sec), std::move(key), Type::String, {}, std::move(doc));
    p.set = [ref](Staging& s, const Value& v) { ref(s) = v.s; };
    p.get = [ref](Staging& s) -> std::optional<Value> {
        Value v;
        v.s = ref(s);
        return v;
    };
    return p;
}

template <class E> using WordTable = std::vector<std::pair<std::string, E>>;

template <class F, class E>
Param word(std::string sec, std::string key, WordTable<E> table, std::string doc, F ref) {
    Param p = row(std::move(sec), std::move(key), Type::Word, {}, std::move(doc));
    for (const auto& [name, e] : table) p.words.push_back(name);
    p.set = [ref, table](Staging& s, const Value& v) {
        for (const auto& [name, e] : table)
            if (name == v.s) ref(s) = e;
    };
    p.get = [ref, table](Staging& s) -> std::optional<Value> {
        Value v;
        for (const auto& [name, e] : table)
            if (e == ref(s)) v.s = name;
        return v;
    };
    return p;
}

std::string nonEmpty(const Value& v) {
    return v.s.empty() ? "expected a non-empty string" : "";
}

bool endsWithNoCase(const std::string& s, std::string_view suffix) {
    if (s.size() < suffix.size()) return false;
    for (size_t i = 0; i < suffix.size(); ++i)
        if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + i])) != suffix[i])
            return false;
    return true;
}

std::string nonZero(const Value& v) {
    if (v.v[0] != 0.0 || v.v[1] != 0.0 || v.v[2] != 0.0) return "";
    return "expected a non-zero vector, found [0, 0, 0]";
}

const WordTable<FieldKind> kFieldKinds = {{"cumulus", FieldKind::Cumulus},
                                          {"homogeneous", FieldKind::Homogeneous},
                                          {"vdb", FieldKind::Vdb}};

std::string fieldKindName(FieldKind k) {
    for (const auto& [name, e] : kFieldKinds)
        if (e == k) return name;
    return "?";
}

// clang-format off
#define NIMBUS_AT(member) [](Staging& s) -> auto& { return s.file.member; }
// clang-format on

/// Every key a scene file may contain, in reference order. The only place that knows them.
const std::vector<Param>& registry() {
    static const std::vector<Param> table = [] {
        std::vector<Param> t;
        const std::string top, cam = "camera", sun = "sun", sky = "sky", med = "medium",
                               fld = "field", ren = "render", out = "output";

        // --- top level
        t.push_back(text(top, "color_space",
                         "Colour space of the light and medium colours in this file (an OCIO "
                         "colour-space name, checked against the OCIO config by `nimbus`).",
                         NIMBUS_AT(inputColorSpace))
                        .checkedBy(nonEmpty));
        {
            Param p = row(top, "frames", Type::Frames, {},
                          "Frames to render (a frame spec, see below); `--frames` on the command "
                          "line replaces it.");
            p.set = [](Staging& s, const Value& v) { s.file.frames = v.s; };
            p.get = [](Staging& s) -> std::optional<Value> {
                Value v;
                v.s = s.file.frames;
                return v;
            };
            t.push_back(p);
        }

        // --- [camera]
        t.push_back(vector(cam, "position", Type::Vec3, {}, "Camera position (world units).",
                           NIMBUS_AT(scene.camera.position)));
        t.push_back(vector(cam, "look_at", Type::Vec3, {},
                           "Point the camera looks at; must differ from `position`.",
                           NIMBUS_AT(scene.camera.lookAt)));
        t.push_back(vector(cam, "up", Type::Vec3, {},
                           "Up direction of the image; must not be parallel to the view direction.",
                           NIMBUS_AT(scene.camera.up))
                        .checkedBy(nonZero));
        t.push_back(number(cam, "fov", open(0, 180), "Vertical field of view in degrees.",
                           NIMBUS_AT(scene.camera.fovY)));
        t.push_back(integer(cam, "width", closed(1, 16384), "Image width in pixels.",
                            NIMBUS_AT(scene.camera.width)));
        t.push_back(integer(cam, "height", closed(1, 16384), "Image height in pixels.",
                            NIMBUS_AT(scene.camera.height)));

        // --- [sun]
        auto sunOn = [](const SceneFile& f) { return f.scene.sun.enabled; };
        t.push_back(
            flag(sun, "enabled", "Light the scene with the sun.", NIMBUS_AT(scene.sun.enabled)));
        t.push_back(vector(sun, "direction", Type::Vec3, {},
                           "Direction toward the sun, normalised on load. Give either `direction` "
                           "or `elevation` and `azimuth`.",
                           NIMBUS_AT(scene.sun.direction))
                        .checkedBy(nonZero)
                        .usedWhen("sun.enabled = true", sunOn));
        {
            Param p = row(sun, "elevation", Type::Number, closed(-90, 90),
                          "Sun elevation in degrees: 0 = horizon, 90 = zenith. Needs `azimuth`; "
                          "replaces `direction`.");
            p.set = [](Staging& s, const Value& v) { s.sunElevation = v.x; };
            p.get = [](Staging& s) -> std::optional<Value> {
                if (!s.sunElevation) return std::nullopt;
                Value v;
                v.x = *s.sunElevation;
                return v;
            };
            t.push_back(p.usedWhen("sun.enabled = true", sunOn));
        }
        {
            Param p = row(sun, "azimuth", Type::Number, closed(-360, 360),
                          "Sun azimuth in degrees, measured from +z toward +x (90 = +x). Needs "
                          "`elevation`.");
            p.set = [](Staging& s, const Value& v) { s.sunAzimuth = v.x; };
            p.get = [](Staging& s) -> std::optional<Value> {
                if (!s.sunAzimuth) return std::nullopt;
                Value v;
                v.x = *s.sunAzimuth;
                return v;
            };
            t.push_back(p.usedWhen("sun.enabled = true", sunOn));
        }
        t.push_back(vector(sun, "irradiance", Type::Rgb, atLeast(0),
                           "Sun irradiance, in `color_space`.", NIMBUS_AT(scene.sun.irradiance))
                        .usedWhen("sun.enabled = true", sunOn));
        t.push_back(number(sun, "intensity", atLeast(0), "Scalar multiplier of `irradiance`.",
                           [](Staging& s) -> float& { return s.sunIntensity; })
                        .usedWhen("sun.enabled = true", sunOn));

        // --- [sky]
        auto skyOn = [](const SceneFile& f) { return f.scene.sky.kind != SkyKind::None; };
        t.push_back(word(sky, "kind",
                         WordTable<SkyKind>{{"none", SkyKind::None},
                                            {"uniform", SkyKind::Uniform},
                                            {"gradient", SkyKind::Gradient}},
                         "Sky light: none (black), uniform (`zenith` in every direction) or "
                         "gradient (`zenith` overhead blending to `horizon` at the horizon).",
                         NIMBUS_AT(scene.sky.kind)));
        t.push_back(vector(sky, "zenith", Type::Rgb, atLeast(0),
                           "Sky radiance straight up (uniform sky: everywhere), in `color_space`.",
                           NIMBUS_AT(scene.sky.zenith))
                        .usedWhen("sky.kind != \"none\"", skyOn));
        t.push_back(vector(sky, "horizon", Type::Rgb, atLeast(0),
                           "Sky radiance at the horizon and below, in `color_space`.",
                           NIMBUS_AT(scene.sky.horizon))
                        .usedWhen("sky.kind = \"gradient\"", [](const SceneFile& f) {
                            return f.scene.sky.kind == SkyKind::Gradient;
                        }));
        t.push_back(number(sky, "ambient", atLeast(0), "Scale of the sky light inside the medium.",
                           NIMBUS_AT(scene.sky.ambient))
                        .usedWhen("sky.kind != \"none\"", skyOn));

        // --- [medium]
        t.push_back(vector(med, "sigma_s", Type::Rgb, atLeast(0),
                           "Scattering coefficient per unit density (1/world unit).",
                           NIMBUS_AT(scene.medium.sigma_s)));
        t.push_back(vector(med, "sigma_a", Type::Rgb, atLeast(0),
                           "Absorption coefficient per unit density (1/world unit).",
                           NIMBUS_AT(scene.medium.sigma_a)));
        t.push_back(number(med, "density_scale", atLeast(0), "Multiplies the field's density.",
                           NIMBUS_AT(scene.medium.densityScale)));
        t.push_back(word(med, "phase",
                         WordTable<PhaseKind>{{"isotropic", PhaseKind::Isotropic},
                                              {"hg", PhaseKind::HenyeyGreenstein},
                                              {"dual_hg", PhaseKind::DualHG},
                                              {"draine", PhaseKind::Draine},
                                              {"mie_approx", PhaseKind::MieApprox},
                                              {"mie_table", PhaseKind::MieTable}},
                         "Phase function: isotropic; hg (Henyey-Greenstein, `g`); dual_hg (two "
                         "HG lobes `g`, `g2` mixed by `blend`); draine (Draine 2003, `g`, "
                         "`alpha`); mie_approx (Jendersie & d'Eon 2023: HG + Draine fitted to "
                         "Lorenz-Mie by `droplet_diameter`); mie_table (a Lorenz-Mie table that "
                         "Nimbus computes for water droplets with `effective_radius` and "
                         "`effective_variance`, per RGB channel: fog bow and glory included).",
                         NIMBUS_AT(scene.medium.phase)));
        auto phaseIs = [](std::initializer_list<PhaseKind> kinds) {
            return [kinds = std::vector<PhaseKind>(kinds)](const SceneFile& f) {
                return std::find(kinds.begin(), kinds.end(), f.scene.medium.phase) != kinds.end();
            };
        };
        t.push_back(number(med, "g", open(-1, 1),
                           "Asymmetry: > 0 scatters forward, < 0 backward. The g of hg and draine; "
                           "the first lobe of dual_hg.",
                           NIMBUS_AT(scene.medium.g))
                        .usedWhen("medium.phase = \"hg\", \"dual_hg\" or \"draine\"",
                                  phaseIs({PhaseKind::HenyeyGreenstein, PhaseKind::DualHG,
                                           PhaseKind::Draine})));
        t.push_back(number(med, "g2", open(-1, 1),
                           "Asymmetry of the second dual_hg lobe (typically < 0: back "
                           "scattering).",
                           NIMBUS_AT(scene.medium.g2))
                        .usedWhen("medium.phase = \"dual_hg\"", phaseIs({PhaseKind::DualHG})));
        t.push_back(number(med, "blend", closed(0, 1),
                           "Weight of the second dual_hg lobe: (1 - blend) HG(g) + blend HG(g2).",
                           NIMBUS_AT(scene.medium.blend))
                        .usedWhen("medium.phase = \"dual_hg\"", phaseIs({PhaseKind::DualHG})));
        t.push_back(number(med, "alpha", closed(0, 1000),
                           "Draine's alpha: 0 is Henyey-Greenstein; with g = 0, alpha = 1 is "
                           "Rayleigh scattering.",
                           NIMBUS_AT(scene.medium.alpha))
                        .usedWhen("medium.phase = \"draine\"", phaseIs({PhaseKind::Draine})));
        t.push_back(
            number(med, "droplet_diameter", closed(5, 50),
                   "Droplet diameter in micrometres for mie_approx; the fit of Jendersie "
                   "& d'Eon holds from 5 to 50 (cumulus ~ 10-20, fog ~ 10-40).",
                   NIMBUS_AT(scene.medium.dropletDiameter))
                .usedWhen("medium.phase = \"mie_approx\"", phaseIs({PhaseKind::MieApprox})));
        t.push_back(number(med, "effective_radius", closed(1, 20),
                           "Effective droplet radius in micrometres for mie_table (Hansen 1971 "
                           "gamma size distribution; cumulus ~ 6-12). The table is computed once "
                           "per process: ~1.3 s on 2 cores at the defaults, ~5 s at radius 20 "
                           "and variance 0.25.",
                           NIMBUS_AT(scene.medium.effectiveRadius))
                        .usedWhen("medium.phase = \"mie_table\"", phaseIs({PhaseKind::MieTable})));
        t.push_back(number(med, "effective_variance", closed(0.01, 0.25),
                           "Effective variance of the droplet radii for mie_table (~0.1 in "
                           "cumulus; small values sharpen the bow and its supernumeraries).",
                           NIMBUS_AT(scene.medium.effectiveVariance))
                        .usedWhen("medium.phase = \"mie_table\"", phaseIs({PhaseKind::MieTable})));

        // --- [field]
        t.push_back(word(fld, "kind", kFieldKinds,
                         "Density field: a procedural cumulus layer (Olajos 2016), a box of "
                         "constant density, or a grid from a VDB file. The other keys of [field] "
                         "depend on it.",
                         NIMBUS_AT(scene.field.kind)));
        const FieldKind cu = FieldKind::Cumulus, ho = FieldKind::Homogeneous;
        t.push_back(vector(fld, "bounds_min", Type::Vec3, {},
                           "Lower corner of the cloud layer; its y is the cloud base altitude.",
                           NIMBUS_AT(scene.field.cumulus.bounds.lo))
                        .onlyFor(cu));
        t.push_back(vector(fld, "bounds_max", Type::Vec3, {},
                           "Upper corner of the cloud layer; its y is the highest cloud top.",
                           NIMBUS_AT(scene.field.cumulus.bounds.hi))
                        .onlyFor(cu));
        t.push_back(number(fld, "density", atLeast(0), "Density in the cloud cores.",
                           NIMBUS_AT(scene.field.cumulus.density))
                        .onlyFor(cu));
        t.push_back(number(fld, "coverage", closed(0, 1),
                           "Fraction of the sky covered: the noise threshold is 1 - coverage.",
                           NIMBUS_AT(scene.field.cumulus.coverage))
                        .onlyFor(cu));
        t.push_back(number(fld, "softness", openClosed(0, 1),
                           "Width of the soft density ramp above the threshold (cloud edges).",
                           NIMBUS_AT(scene.field.cumulus.softness))
                        .onlyFor(cu));
        t.push_back(number(fld, "erosion", closed(0, 0.99),
                           "How much the detail noise eats into the edges.",
                           NIMBUS_AT(scene.field.cumulus.erosion))
                        .onlyFor(cu));
        t.push_back(number(fld, "height_a", above(0),
                           "Rise rate a of the height distribution (1 - e^-ah) e^-bh; large = "
                           "flat cloud bases.",
                           NIMBUS_AT(scene.field.cumulus.heightA))
                        .onlyFor(cu));
        t.push_back(number(fld, "height_b", above(0),
                           "Decay rate b of the height distribution; large = thin tops.",
                           NIMBUS_AT(scene.field.cumulus.heightB))
                        .onlyFor(cu));
        t.push_back(number(fld, "base_period", above(0),
                           "World size of one tile of the base (shape) noise.",
                           NIMBUS_AT(scene.field.cumulus.basePeriod))
                        .onlyFor(cu));
        t.push_back(integer(fld, "base_lattice", closed(1, 64),
                            "Lattice cells per base tile in the lowest octave.",
                            NIMBUS_AT(scene.field.cumulus.baseLattice))
                        .onlyFor(cu));
        t.push_back(integer(fld, "base_octaves", closed(1, 8), "Octaves of the base noise.",
                            NIMBUS_AT(scene.field.cumulus.baseOctaves))
                        .onlyFor(cu));
        t.push_back(number(fld, "detail_period", above(0),
                           "World size of one tile of the detail (erosion) noise.",
                           NIMBUS_AT(scene.field.cumulus.detailPeriod))
                        .onlyFor(cu));
        t.push_back(integer(fld, "detail_lattice", closed(1, 64),
                            "Lattice cells per detail tile in the lowest octave.",
                            NIMBUS_AT(scene.field.cumulus.detailLattice))
                        .onlyFor(cu));
        t.push_back(integer(fld, "detail_octaves", closed(1, 8), "Octaves of the detail noise.",
                            NIMBUS_AT(scene.field.cumulus.detailOctaves))
                        .onlyFor(cu));
        t.push_back(number(fld, "tower_spacing", above(0),
                           "Size of the square cells that hold at most one tower each.",
                           NIMBUS_AT(scene.field.cumulus.towerSpacing))
                        .onlyFor(cu));
        t.push_back(pair(fld, "tower_radius", above(0),
                         "Range of tower footprint radii (3 sigma); max <= `tower_spacing`.",
                         NIMBUS_AT(scene.field.cumulus.towerRadiusMin),
                         NIMBUS_AT(scene.field.cumulus.towerRadiusMax))
                        .onlyFor(cu));
        t.push_back(pair(fld, "tower_height", openClosed(0, 1),
                         "Range of tower (column) heights as fractions of the layer height.",
                         NIMBUS_AT(scene.field.cumulus.towerHeightMin),
                         NIMBUS_AT(scene.field.cumulus.towerHeightMax))
                        .onlyFor(cu));
        t.push_back(number(fld, "tower_probability", closed(0, 1),
                           "Chance that a cell holds a tower.",
                           NIMBUS_AT(scene.field.cumulus.towerProbability))
                        .onlyFor(cu));
        t.push_back(number(fld, "tower_anisotropy", closed(0, 0.9),
                           "0: round footprints; up to 0.9: elongated ones.",
                           NIMBUS_AT(scene.field.cumulus.towerAnisotropy))
                        .onlyFor(cu));
        t.push_back(vector(fld, "wind", Type::Vec3, {},
                           "Drift of the whole field, world units per second (t = frame / fps).",
                           NIMBUS_AT(scene.field.cumulus.wind))
                        .onlyFor(cu));
        t.push_back(vector(fld, "detail_wind", Type::Vec3, {},
                           "Extra drift of the detail noise, world units per second: slowly "
                           "evolving edges.",
                           NIMBUS_AT(scene.field.cumulus.detailWind))
                        .onlyFor(cu));
        t.push_back(integer(fld, "seed", kUInt32, "Seed of the noise and tower placement.",
                            NIMBUS_AT(scene.field.cumulus.seed))
                        .onlyFor(cu));
        auto notDirect = [](const SceneFile& f) {
            return f.scene.field.cumulus.eval != NoiseEval::Direct;
        };
        t.push_back(word(fld, "evaluation",
                         WordTable<NoiseEval>{{"auto", NoiseEval::Auto},
                                              {"direct", NoiseEval::Direct},
                                              {"baked", NoiseEval::Baked}},
                         "Noise evaluation: direct (exact, slow), baked (tiled volumes, fast) or "
                         "auto (chosen by the plan).",
                         NIMBUS_AT(scene.field.cumulus.eval))
                        .onlyFor(cu));
        t.push_back(integer(fld, "base_bake_resolution", closed(8, 512),
                            "Voxels per base tile edge when baked.",
                            NIMBUS_AT(scene.field.cumulus.baseBakeResolution))
                        .onlyFor(cu)
                        .usedWhen("field.evaluation != \"direct\"", notDirect));
        t.push_back(integer(fld, "detail_bake_resolution", closed(8, 512),
                            "Voxels per detail tile edge when baked.",
                            NIMBUS_AT(scene.field.cumulus.detailBakeResolution))
                        .onlyFor(cu)
                        .usedWhen("field.evaluation != \"direct\"", notDirect));
        t.push_back(vector(fld, "bounds_min", Type::Vec3, {}, "Lower corner of the box.",
                           NIMBUS_AT(scene.field.homogeneous.box.lo))
                        .onlyFor(ho));
        t.push_back(vector(fld, "bounds_max", Type::Vec3, {}, "Upper corner of the box.",
                           NIMBUS_AT(scene.field.homogeneous.box.hi))
                        .onlyFor(ho));
        t.push_back(number(fld, "density", atLeast(0), "Density inside the box.",
                           NIMBUS_AT(scene.field.homogeneous.density))
                        .onlyFor(ho));
        const FieldKind vd = FieldKind::Vdb;
        t.push_back(text(fld, "path",
                         "VDB file, or a per-frame pattern (`smoke.####.vdb`, `$F4`); relative "
                         "to the scene file. Required.",
                         NIMBUS_AT(scene.field.vdb.path))
                        .onlyFor(vd));
        t.push_back(text(fld, "grid", "Name of the density grid; only this grid is read.",
                         NIMBUS_AT(scene.field.vdb.grid))
                        .onlyFor(vd));
        t.push_back(flag(fld, "levelset_to_fog",
                         "Convert a level set to a fog volume instead of refusing it.",
                         NIMBUS_AT(scene.field.vdb.levelsetToFog))
                        .onlyFor(vd));
        t.push_back(flag(fld, "hold",
                         "A missing frame of a sequence repeats the last existing one (with a "
                         "warning) instead of failing.",
                         NIMBUS_AT(scene.field.vdb.hold))
                        .onlyFor(vd));
        t.push_back(number(fld, "density", atLeast(0), "Multiplier of the grid values.",
                           NIMBUS_AT(scene.field.vdb.density))
                        .onlyFor(vd));

        // --- [ground]
        const std::string gnd = "ground";
        auto groundOn = [](const SceneFile& f) { return f.scene.ground.enabled; };
        t.push_back(flag(gnd, "enabled",
                         "An opaque diffuse ground plane (Embree): stops camera rays and "
                         "receives the clouds' shadows.",
                         NIMBUS_AT(scene.ground.enabled)));
        t.push_back(
            number(gnd, "height", {}, "Height (y) of the plane.", NIMBUS_AT(scene.ground.height))
                .usedWhen("ground.enabled = true", groundOn));
        t.push_back(number(gnd, "extent", above(0),
                           "Half the side of the square plane, centred under the camera.",
                           NIMBUS_AT(scene.ground.extent))
                        .usedWhen("ground.enabled = true", groundOn));
        t.push_back(vector(gnd, "albedo", Type::Rgb, closed(0, 1), "Diffuse reflectance.",
                           NIMBUS_AT(scene.ground.material.albedo))
                        .usedWhen("ground.enabled = true", groundOn));
        t.push_back(flag(gnd, "holdout",
                         "A matte: hides what is behind it with alpha 0 and no colour of its "
                         "own (for compositing over a plate).",
                         NIMBUS_AT(scene.ground.material.holdout))
                        .usedWhen("ground.enabled = true", groundOn));

        // --- [render]
        auto pathtrace = [](const SceneFile& f) {
            return f.scene.render.integrator == Integrator::PathTrace;
        };
        auto marching = [](const SceneFile& f) {
            return f.scene.render.integrator == Integrator::March;
        };
        t.push_back(word(ren, "integrator",
                         WordTable<Integrator>{{"march", Integrator::March},
                                               {"pathtrace", Integrator::PathTrace}},
                         "march: fast single-scattering ray marching with approximations "
                         "(production); pathtrace: unbiased multiple scattering (references).",
                         NIMBUS_AT(scene.render.integrator)));
        t.push_back(integer(ren, "spp", closed(1, 1 << 20), "Path-traced samples per pixel.",
                            NIMBUS_AT(scene.render.spp))
                        .usedWhen("render.integrator = \"pathtrace\"", pathtrace));
        t.push_back(integer(ren, "max_depth", closed(1, 1 << 20),
                            "Scattering events per path (and per photon) at most (1 = single "
                            "scattering).",
                            NIMBUS_AT(scene.render.maxDepth))
                        .usedWhen("render.integrator = \"pathtrace\" or "
                                  "render.multiple_scattering = \"photons\"",
                                  [](const SceneFile& f) {
                                      return f.scene.render.integrator == Integrator::PathTrace ||
                                             f.scene.render.multipleScattering ==
                                                 MultipleScattering::Photons;
                                  }));
        t.push_back(integer(ren, "rr_depth", closed(1, 1 << 20),
                            "Russian roulette (unbiased path termination) from this depth on.",
                            NIMBUS_AT(scene.render.rrDepth))
                        .usedWhen("render.integrator = \"pathtrace\"", pathtrace));
        t.push_back(word(ren, "shadow",
                         WordTable<ShadowMethod>{{"march", ShadowMethod::March},
                                                 {"volume", ShadowMethod::Volume}},
                         "Sun transmittance for march: a shadow march per sample, or a "
                         "light-attenuation volume propagated slice by slice along the sun "
                         "(Fizimayer 2008) and read trilinearly.",
                         NIMBUS_AT(scene.render.shadow))
                        .usedWhen("render.integrator = \"march\"", marching));
        t.push_back(number(ren, "light_volume_cell", atLeast(0),
                           "Voxel size of the light-attenuation volumes (sun shadows, multiple "
                           "scattering, column sky occlusion; world units); 0 = the majorant cell.",
                           NIMBUS_AT(scene.render.lightVolumeCell))
                        .usedWhen("render.shadow = \"volume\", render.multiple_scattering = "
                                  "\"grid\" or \"photons\" or render.sky_occlusion = "
                                  "\"column\"",
                                  [](const SceneFile& f) {
                                      const RenderDesc& r = f.scene.render;
                                      return r.shadow == ShadowMethod::Volume ||
                                             r.multipleScattering != MultipleScattering::None ||
                                             r.skyOcclusion == SkyOcclusion::Column;
                                  }));
        t.push_back(number(ren, "step", above(0), "Primary ray-march step (world units).",
                           NIMBUS_AT(scene.render.step)));
        t.push_back(number(ren, "step_growth", atLeast(0),
                           "Distance-adaptive steps: step = max(step, step_growth * distance).",
                           NIMBUS_AT(scene.render.stepGrowth)));
        t.push_back(flag(ren, "jitter",
                         "Offset the samples within each step by a random fraction per pixel "
                         "(trades banding for noise); off = step midpoints.",
                         NIMBUS_AT(scene.render.jitter)));
        t.push_back(number(ren, "epsilon", closedOpen(0, 1),
                           "Stop marching when the transmittance falls below this.",
                           NIMBUS_AT(scene.render.epsilon)));
        t.push_back(number(ren, "shadow_step", above(0), "First shadow-ray step (world units).",
                           NIMBUS_AT(scene.render.shadowStep)));
        t.push_back(number(ren, "shadow_growth", atLeast(0),
                           "Shadow steps grow geometrically by this factor.",
                           NIMBUS_AT(scene.render.shadowGrowth)));
        t.push_back(flag(ren, "skip_empty", "Skip empty space with the majorant grid.",
                         NIMBUS_AT(scene.render.skipEmpty)));
        t.push_back(flag(ren, "hierarchical_skip",
                         "Instanced volumes: find the instance boxes a ray crosses (Embree), then "
                         "walk each volume's own majorant grid; false = one coarse world grid "
                         "over all instances (for comparison).",
                         NIMBUS_AT(scene.render.hierarchicalSkip))
                        .usedWhen("render.skip_empty = true",
                                  [](const SceneFile& f) { return f.scene.render.skipEmpty; }));
        t.push_back(number(ren, "majorant_cell", atLeast(0),
                           "Majorant grid cell size (world units); 0 = chosen by the plan.",
                           NIMBUS_AT(scene.render.majorantCell))
                        .usedWhen("render.skip_empty = true",
                                  [](const SceneFile& f) { return f.scene.render.skipEmpty; }));
        auto multiple = [](const SceneFile& f) { return f.scene.render.octaves > 1; };
        t.push_back(integer(ren, "octaves", closed(1, 16),
                            "Multiple-scattering octaves (Wrenninge 2015): octave i adds the sun "
                            "term again with scaled weight, optical depth and g; 1 = single "
                            "scattering only.",
                            NIMBUS_AT(scene.render.octaves)));
        t.push_back(number(ren, "octave_extinction", closed(0, 1),
                           "Sun optical depth of octave i is scaled by octave_extinction^i.",
                           NIMBUS_AT(scene.render.octaveExtinction))
                        .usedWhen("render.octaves > 1", multiple));
        t.push_back(number(ren, "octave_contribution", closed(0, 1),
                           "Weight of octave i is octave_contribution^i; at most "
                           "`octave_extinction` (energy conservation).",
                           NIMBUS_AT(scene.render.octaveContribution))
                        .usedWhen("render.octaves > 1", multiple));
        t.push_back(number(ren, "octave_eccentricity", closed(0, 1),
                           "Phase asymmetry g of octave i is scaled by octave_eccentricity^i.",
                           NIMBUS_AT(scene.render.octaveEccentricity))
                        .usedWhen("render.octaves > 1", multiple));
        t.push_back(word(ren, "multiple_scattering",
                         WordTable<MultipleScattering>{{"none", MultipleScattering::None},
                                                       {"grid", MultipleScattering::Grid},
                                                       {"photons", MultipleScattering::Photons}},
                         "Sun light scattered more than once and sky light: none (octaves and "
                         "the sky ambient term only); grid: solved once per frame as a "
                         "diffusion process on the light-volume grid (Stam 1995; similarity "
                         "relation for g, Marshak boundaries lit by the sky), read trilinearly; "
                         "it replaces the sky ambient term, octaves add to it; photons: the "
                         "sun's part from `render.photons` photons traced through the field "
                         "once per frame and recorded on the light-volume grid toward the "
                         "camera (no octaves, nothing to calibrate), the sky's from the "
                         "diffusion grid.",
                         NIMBUS_AT(scene.render.multipleScattering)));
        auto gridOn = [](const SceneFile& f) {
            return f.scene.render.multipleScattering != MultipleScattering::None;
        };
        auto photonsOn = [](const SceneFile& f) {
            return f.scene.render.multipleScattering == MultipleScattering::Photons;
        };
        t.push_back(integer(ren, "photons", closed(1, 1 << 30),
                            "Photons traced from the sun per frame (multiple_scattering = "
                            "\"photons\"); their noise falls as 1 / sqrt(photons).",
                            NIMBUS_AT(scene.render.photons))
                        .usedWhen("render.multiple_scattering = \"photons\"", photonsOn));
        t.push_back(number(ren, "photon_skin", closed(0, 4),
                           "Photons: how the sun's multiply scattered light falls off inside a "
                           "voxel of the light-volume grid, brightest under the sunlit surface: as "
                           "max(exp(-photon_skin sigma_t tau), 0.1) with tau the density integral "
                           "toward the sun. Photons record the light divided by this profile and "
                           "march multiplies it back at each sample: the voxel's light keeps about "
                           "its mean and takes this shape. 0 = flat over the voxel. A model "
                           "parameter, like the octaves: on the default scene at 640x360 (4 M "
                           "photons) 0.2 measured 9.0% relative RMSE against 10.0% flat; on a "
                           "homogeneous box with voxels of two mean free paths it did not help.",
                           NIMBUS_AT(scene.render.photonSkin))
                        .usedWhen("render.multiple_scattering = \"photons\"", photonsOn));
        t.push_back(number(ren, "ms_strength", atLeast(0),
                           "Scale of the grid's multiply scattered sun light (1 = the diffusion "
                           "solution, which loses light in moderately thick, porous cloud; the "
                           "sky's part is not scaled).",
                           NIMBUS_AT(scene.render.msStrength))
                        .usedWhen("render.multiple_scattering = \"grid\" or \"photons\"", gridOn));
        t.push_back(number(ren, "ms_p1", closed(0, 1),
                           "Grid diffusion: weight of the flux term (phi + 3 g F.w) of the "
                           "diffuse radiance scattered toward the camera; 0 = isotropic.",
                           NIMBUS_AT(scene.render.msP1))
                        .usedWhen("render.multiple_scattering = \"grid\"", [](const SceneFile& f) {
                            return f.scene.render.multipleScattering == MultipleScattering::Grid;
                        }));
        t.push_back(word(ren, "sky_occlusion",
                         WordTable<SkyOcclusion>{{"height", SkyOcclusion::Height},
                                                 {"column", SkyOcclusion::Column}},
                         "Sky light inside the medium: height (darker toward the base of the "
                         "field, down to 0.3), or column: the upper and lower hemispheres' sky "
                         "weighted by the openness of the vertical column above and below the "
                         "sample, normalised so that an albedo-1 medium under a uniform sky "
                         "returns the sky (white furnace).",
                         NIMBUS_AT(scene.render.skyOcclusion))
                        .usedWhen("render.multiple_scattering = \"none\"", [](const SceneFile& f) {
                            return f.scene.render.multipleScattering == MultipleScattering::None;
                        }));
        t.push_back(number(ren, "sky_openness", atLeast(0),
                           "Column sky occlusion: weights e^(-k tau) of the hemispheres, tau the "
                           "transport optical depth above / below; 0 = the mean sky.",
                           NIMBUS_AT(scene.render.skyOpenness))
                        .usedWhen("render.multiple_scattering = \"none\" and render.sky_occlusion "
                                  "= \"column\"",
                                  [](const SceneFile& f) {
                                      return f.scene.render.multipleScattering ==
                                                 MultipleScattering::None &&
                                             f.scene.render.skyOcclusion == SkyOcclusion::Column;
                                  }));
        auto inscatterOn = [](const SceneFile& f) {
            return f.scene.render.inScatter != InScatter::None;
        };
        t.push_back(word(ren, "inscatter",
                         WordTable<InScatter>{{"none", InScatter::None},
                                              {"olajos", InScatter::Olajos},
                                              {"powder", InScatter::Powder}},
                         "Approximate in-scatter term: none, Olajos 1 - e^-cd, or Schneider's "
                         "Beer-powder 2 e^-d (1 - e^-2d).",
                         NIMBUS_AT(scene.render.inScatter)));
        t.push_back(number(ren, "inscatter_c", above(0), "The c of Olajos' 1 - e^-cd.",
                           NIMBUS_AT(scene.render.inScatterC))
                        .usedWhen("render.inscatter = \"olajos\"", [](const SceneFile& f) {
                            return f.scene.render.inScatter == InScatter::Olajos;
                        }));
        t.push_back(number(ren, "inscatter_strength", closed(0, 1),
                           "Blend weight of the in-scatter term.",
                           NIMBUS_AT(scene.render.inScatterStrength))
                        .usedWhen("render.inscatter != \"none\"", inscatterOn));
        t.push_back(word(ren, "background",
                         WordTable<Background>{{"sky", Background::Sky},
                                               {"transparent", Background::Transparent}},
                         "What camera rays that leave the scene show: the sky, or alpha 0.",
                         NIMBUS_AT(scene.render.background)));
        t.push_back(integer(ren, "seed", kUInt32,
                            "Base random seed; every frame derives its own from it and the frame "
                            "number.",
                            NIMBUS_AT(scene.render.seed)));
        t.push_back(integer(ren, "threads", closed(0, 1024), "Worker threads; 0 = all cores.",
                            NIMBUS_AT(scene.render.threads)));
        t.push_back(integer(ren, "tile_size", closed(4, 256),
                            "Edge of the square render tiles (pixels).",
                            NIMBUS_AT(scene.render.tileSize)));
        t.push_back(number(ren, "fps", above(0), "Frames per second: frame f is at time f / fps.",
                           NIMBUS_AT(scene.render.fps)));

        // --- [output]
        t.push_back(text(out, "path",
                         "EXR file name pattern; needs a frame token when several frames are "
                         "rendered.",
                         NIMBUS_AT(output.path))
                        .checkedBy([](const Value& v) -> std::string {
                            if (endsWithNoCase(v.s, ".exr") && v.s.size() > 4) return "";
                            return "expected a file name ending in .exr, found " + quote(v.s);
                        }));
        t.push_back(text(out, "color_space", "Colour space of the EXR pixels (an OCIO name).",
                         NIMBUS_AT(output.colorSpace))
                        .checkedBy(nonEmpty));
        {
            Param p = row(out, "aovs", Type::WordList, {},
                          "Extra EXR layers: transmittance (RGB, of the whole camera ray) and "
                          "depth (distance where transmittance first drops below 0.5).");
            p.words = {"transmittance", "depth"};
            p.set = [](Staging& s, const Value& v) {
                AovSet& a = s.file.output.aovs;
                a = AovSet{};
                for (const std::string& w : v.list) {
                    if (w == "transmittance") a.transmittance = true;
                    if (w == "depth") a.depth = true;
                }
            };
            p.get = [](Staging& s) -> std::optional<Value> {
                Value v;
                if (s.file.output.aovs.transmittance) v.list.push_back("transmittance");
                if (s.file.output.aovs.depth) v.list.push_back("depth");
                return v;
            };
            t.push_back(p);
        }
        t.push_back(text(out, "preview",
                         "PNG file name pattern of a display-referred preview; \"\" = none.",
                         NIMBUS_AT(output.preview))
                        .checkedBy([](const Value& v) -> std::string {
                            if (v.s.empty() || (endsWithNoCase(v.s, ".png") && v.s.size() > 4))
                                return "";
                            return "expected \"\" or a file name ending in .png, found " +
                                   quote(v.s);
                        }));
        auto previewOn = [](const SceneFile& f) { return !f.output.preview.empty(); };
        t.push_back(text(out, "display", "OCIO display of the preview.", NIMBUS_AT(output.display))
                        .checkedBy(nonEmpty)
                        .usedWhen("output.preview != \"\"", previewOn));
        t.push_back(text(out, "view", "OCIO view of the preview.", NIMBUS_AT(output.view))
                        .checkedBy(nonEmpty)
                        .usedWhen("output.preview != \"\"", previewOn));
        return t;
    }();
    return table;
}

#undef NIMBUS_AT

/// An array of tables (`[[instance]]`): each element is read with the rows of its section in
/// arrayRegistry(), the accessors reaching the element Staging::element.
struct ArraySection {
    std::string name;
    std::string doc;
    std::function<void(Staging&, Where)> grow; ///< appends a default element
};

const std::vector<ArraySection>& arraySections() {
    static const std::vector<ArraySection> table = {
        {"volume",
         "A further VDB volume beside `[field]`, referred to by its `name` from `[[instance]]` "
         "and `[[scatter]]` (the `[field]` volume is called \"field\"). Without any "
         "`[[instance]]` or `[[scatter]]`, `[field]` and every `[[volume]]` are placed once, "
         "untransformed. Only grids of volumes that are placed are read.",
         [](Staging& s, Where w) {
             NamedVolumeDesc v;
             v.field.kind = FieldKind::Vdb;
             s.file.scene.volumes.push_back(v);
             s.volumeWhere.push_back(w);
         }},
        {"instance",
         "One placement of a volume: world = translate + R (scale * p), R = Rz Ry Rx. Where "
         "instances overlap their densities add.",
         [](Staging& s, Where w) {
             s.file.scene.instances.push_back(InstanceDesc{});
             s.instanceVolumes.push_back({"field", w});
         }},
        {"scatter",
         "`count` instances of a volume at random positions in a box (a cloudscape), with "
         "random uniform scale, rotation about y and density in the given ranges; "
         "deterministic per `seed`.",
         [](Staging& s, Where w) {
             Staging::Scatter sc;
             sc.where = w;
             s.scatters.push_back(sc);
         }},
        {"mesh",
         "A triangle mesh from an OBJ file (Embree): opaque, diffuse, two-sided; stops camera "
         "rays, casts and receives shadows.",
         [](Staging& s, Where w) {
             s.file.scene.meshes.push_back(MeshDesc{});
             s.meshWhere.push_back(w);
         }},
    };
    return table;
}

// clang-format off
#define NIMBUS_EL(vec, member) [](Staging& s) -> auto& { return s.vec[s.element].member; }
// clang-format on

const std::vector<Param>& arrayRegistry() {
    static const std::vector<Param> table = [] {
        std::vector<Param> t;
        const std::string vol = "volume", ins = "instance", sct = "scatter", msh = "mesh";
        t.push_back(text(vol, "name", "Name the instances use. Required, unique, not \"field\".",
                         NIMBUS_EL(file.scene.volumes, name))
                        .checkedBy(nonEmpty));
        t.push_back(text(vol, "path",
                         "VDB file, or a per-frame pattern (`smoke.####.vdb`, `$F4`); relative "
                         "to the scene file. Required.",
                         NIMBUS_EL(file.scene.volumes, field.vdb.path))
                        .checkedBy(nonEmpty));
        t.push_back(text(vol, "grid", "Name of the density grid; only this grid is read.",
                         NIMBUS_EL(file.scene.volumes, field.vdb.grid))
                        .checkedBy(nonEmpty));
        t.push_back(flag(vol, "levelset_to_fog",
                         "Convert a level set to a fog volume instead of refusing it.",
                         NIMBUS_EL(file.scene.volumes, field.vdb.levelsetToFog)));
        t.push_back(flag(vol, "hold", "A missing frame repeats the last existing one.",
                         NIMBUS_EL(file.scene.volumes, field.vdb.hold)));
        t.push_back(number(vol, "density", atLeast(0), "Multiplier of the grid values.",
                           NIMBUS_EL(file.scene.volumes, field.vdb.density)));

        t.push_back(text(ins, "volume", "The volume placed: \"field\" or a `[[volume]]` name.",
                         NIMBUS_EL(instanceVolumes, volume))
                        .checkedBy(nonEmpty));
        t.push_back(vector(ins, "translate", Type::Vec3, {}, "Translation (world units).",
                           NIMBUS_EL(file.scene.instances, translate)));
        t.push_back(vector(ins, "rotate", Type::Vec3, {},
                           "Rotation in degrees about x, then y, then z.",
                           NIMBUS_EL(file.scene.instances, rotate)));
        t.push_back(vector(ins, "scale", Type::Vec3, above(0), "Scale along x, y and z.",
                           NIMBUS_EL(file.scene.instances, scale)));
        t.push_back(number(ins, "density", atLeast(0), "Multiplier of the volume's density.",
                           NIMBUS_EL(file.scene.instances, density)));

        t.push_back(text(sct, "volume", "The volume placed: \"field\" or a `[[volume]]` name.",
                         NIMBUS_EL(scatters, volume))
                        .checkedBy(nonEmpty));
        t.push_back(integer(sct, "count", closed(1, 1000000), "Number of instances.",
                            NIMBUS_EL(scatters, count)));
        t.push_back(integer(sct, "seed", kUInt32, "Random seed of the placement.",
                            NIMBUS_EL(scatters, seed)));
        t.push_back(vector(sct, "region_min", Type::Vec3, {},
                           "Lower corner of the box the instance origins are drawn from.",
                           NIMBUS_EL(scatters, regionMin)));
        t.push_back(vector(sct, "region_max", Type::Vec3, {}, "Upper corner of that box.",
                           NIMBUS_EL(scatters, regionMax)));
        t.push_back(pair(sct, "scale", above(0), "Uniform scale range.",
                         NIMBUS_EL(scatters, scaleMin), NIMBUS_EL(scatters, scaleMax)));
        t.push_back(pair(sct, "rotate_y", {}, "Rotation about y range, degrees.",
                         NIMBUS_EL(scatters, yawMin), NIMBUS_EL(scatters, yawMax)));
        t.push_back(pair(sct, "density", atLeast(0), "Density multiplier range.",
                         NIMBUS_EL(scatters, densityMin), NIMBUS_EL(scatters, densityMax)));

        t.push_back(text(msh, "path", "OBJ file, relative to the scene file. Required.",
                         NIMBUS_EL(file.scene.meshes, path))
                        .checkedBy(nonEmpty));
        t.push_back(vector(msh, "translate", Type::Vec3, {}, "Translation (world units).",
                           NIMBUS_EL(file.scene.meshes, translate)));
        t.push_back(vector(msh, "rotate", Type::Vec3, {},
                           "Rotation in degrees about x, then y, then z.",
                           NIMBUS_EL(file.scene.meshes, rotate)));
        t.push_back(vector(msh, "scale", Type::Vec3, above(0), "Scale along x, y and z.",
                           NIMBUS_EL(file.scene.meshes, scale)));
        t.push_back(vector(msh, "albedo", Type::Rgb, closed(0, 1), "Diffuse reflectance.",
                           NIMBUS_EL(file.scene.meshes, material.albedo)));
        t.push_back(flag(msh, "holdout",
                         "A matte: hides what is behind it with alpha 0 and no colour of its own.",
                         NIMBUS_EL(file.scene.meshes, material.holdout)));
        return t;
    }();
    return table;
}

#undef NIMBUS_EL

std::vector<std::string> sectionNames() {
    std::vector<std::string> out;
    for (const Param& p : registry())
        if (!p.section.empty() && std::find(out.begin(), out.end(), p.section) == out.end())
            out.push_back(p.section);
    return out;
}

/// Keys of @p section that apply to field kind @p kind (all keys outside [field]).
std::vector<std::string> keysOf(const std::string& section, std::optional<FieldKind> kind) {
    std::vector<std::string> out;
    for (const Param& p : registry())
        if (p.section == section && (!p.kind || !kind || p.kind == kind)) {
            if (std::find(out.begin(), out.end(), p.key) == out.end()) out.push_back(p.key);
        }
    return out;
}

// ------------------------------------------------------------------------------------------
// 3. Rules across keys
// ------------------------------------------------------------------------------------------

/// The location of the first of @p keys that the file or an override gave.
Where locate(const Staging& s, const Context& cx, std::initializer_list<std::string_view> keys) {
    for (std::string_view k : keys) {
        auto it = s.given.find(std::string(k));
        if (it != s.given.end()) return it->second;
    }
    return {cx.sourceName + ":1:1", 0, 1, 1};
}

std::string formatVec(const vec3& v) {
    return "[" + formatFloat(v.x) + ", " + formatFloat(v.y) + ", " + formatFloat(v.z) + "]";
}

struct Rule {
    std::string section;
    std::string doc;
    std::function<void(Staging&, const Context&, Problems&)> apply;
};

const std::vector<Rule>& rules() {
    static const std::vector<Rule> table = {
        {"camera", "`look_at` must differ from `position`.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const CameraDesc& c = s.file.scene.camera;
             float scale = std::max(1.0f, glm::length(c.position));
             if (glm::length(c.lookAt - c.position) > 1e-6f * scale) return;
             pr.add(locate(s, cx, {"camera.look_at", "camera.position"}),
                    "camera.look_at " + formatVec(c.lookAt) +
                        " equals camera.position: the view direction is undefined");
         }},
        {"camera", "`up` must not be parallel to the view direction `look_at - position`.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const CameraDesc& c = s.file.scene.camera;
             vec3 d = c.lookAt - c.position;
             if (glm::length(d) == 0.0f || glm::length(c.up) == 0.0f) return; // reported above
             float sine = glm::length(glm::cross(glm::normalize(d), glm::normalize(c.up)));
             if (sine > 1e-3f) return;
             pr.add(locate(s, cx, {"camera.up", "camera.look_at", "camera.position"}),
                    "camera.up " + formatVec(c.up) + " is parallel to the view direction " +
                        formatVec(glm::normalize(d)) +
                        " (look_at - position); choose an up vector across it");
         }},
        {"sun",
         "Give the sun's position as `direction` or as `elevation` + `azimuth` (both), not "
         "both ways.",
         [](Staging& s, const Context& cx, Problems& pr) {
             bool hasDirection = s.given.count("sun.direction") > 0;
             bool hasEl = s.sunElevation.has_value(), hasAz = s.sunAzimuth.has_value();
             if (hasDirection && (hasEl || hasAz)) {
                 pr.add(locate(s, cx, {"sun.elevation", "sun.azimuth"}),
                        std::string(hasEl ? "sun.elevation" : "sun.azimuth") +
                            ": the sun is already placed by sun.direction (" +
                            locate(s, cx, {"sun.direction"}).prefix +
                            "); give either direction or elevation + azimuth");
                 return;
             }
             if (hasEl != hasAz) {
                 pr.add(locate(s, cx, {"sun.elevation", "sun.azimuth"}),
                        hasEl ? "sun.elevation needs sun.azimuth as well (degrees from +z "
                                "toward +x)"
                              : "sun.azimuth needs sun.elevation as well (degrees above the "
                                "horizon)");
                 return;
             }
             if (!hasEl) {
                 const vec3& d = s.file.scene.sun.direction; // non-zero: checked on reading
                 double x = d.x, y = d.y, z = d.z, len = std::sqrt(x * x + y * y + z * z);
                 s.file.scene.sun.direction = vec3(float(x / len), float(y / len), float(z / len));
                 return;
             }
             const double toRad = std::numbers::pi / 180.0;
             double el = *s.sunElevation * toRad, az = *s.sunAzimuth * toRad;
             s.file.scene.sun.direction =
                 glm::normalize(vec3(float(std::cos(el) * std::sin(az)), float(std::sin(el)),
                                     float(std::cos(el) * std::cos(az))));
         }},
        {"field", "`bounds_min` must be below `bounds_max` on every axis.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const FieldDesc& f = s.file.scene.field;
             const Box& b = f.kind == FieldKind::Cumulus ? f.cumulus.bounds : f.homogeneous.box;
             const char* axes = "xyz";
             for (int a = 0; a < 3; ++a) {
                 if (b.lo[a] < b.hi[a]) continue;
                 pr.add(locate(s, cx, {"field.bounds_min", "field.bounds_max"}),
                        "field.bounds_min " + formatVec(b.lo) + " must be below field.bounds_max " +
                            formatVec(b.hi) + " on every axis; on " + axes[a] + " " +
                            formatFloat(b.lo[a]) + " >= " + formatFloat(b.hi[a]));
                 return;
             }
         }},
        {"field",
         "Cumulus: the largest `tower_radius` may not exceed `tower_spacing`: each tower lives in "
         "one cell of a `tower_spacing` grid and only the 3 x 3 neighbouring cells are searched, "
         "so a wider footprint would be cut off at the cell borders.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const CumulusDesc& c = s.file.scene.field.cumulus;
             if (s.file.scene.field.kind != FieldKind::Cumulus) return;
             if (c.towerRadiusMax <= c.towerSpacing) return;
             pr.add(locate(s, cx, {"field.tower_radius", "field.tower_spacing"}),
                    "field.tower_radius max " + formatFloat(c.towerRadiusMax) +
                        " exceeds field.tower_spacing " + formatFloat(c.towerSpacing) +
                        ": footprints may not be wider than the spacing (each tower lives in one "
                        "cell and only the neighbouring cells are searched); lower the radius or "
                        "raise the spacing");
         }},
        {"render",
         "With `octaves` > 1, `octave_contribution` may not exceed `octave_extinction`: each "
         "octave would then add more light than the medium can scatter (Wrenninge 2015).",
         [](Staging& s, const Context& cx, Problems& pr) {
             const RenderDesc& r = s.file.scene.render;
             if (r.octaves <= 1 || r.octaveContribution <= r.octaveExtinction) return;
             pr.add(locate(s, cx,
                           {"render.octave_contribution", "render.octave_extinction",
                            "render.octaves"}),
                    "render.octave_contribution " + formatFloat(r.octaveContribution) +
                        " exceeds render.octave_extinction " + formatFloat(r.octaveExtinction) +
                        ": the octaves would not conserve energy; expected contribution <= "
                        "extinction");
         }},
        {"output",
         "When `frames` names more than one frame, `output.path` (and `output.preview`, if set) "
         "must contain a frame token, or every frame would overwrite the same file.",
         [](Staging& s, const Context& cx, Problems& pr) {
             size_t count = parseFrameSpec(s.file.frames).size();
             if (count <= 1) return;
             const OutputDesc& o = s.file.output;
             std::string frames =
                 "frames " + quote(s.file.frames) + " names " + std::to_string(count) + " frames";
             if (!patternHasFrameToken(o.path))
                 pr.add(locate(s, cx, {"output.path", "frames"}),
                        "output.path " + quote(o.path) + " has no frame token (#### or $F4) but " +
                            frames);
             if (!o.preview.empty() && !patternHasFrameToken(o.preview))
                 pr.add(locate(s, cx, {"output.preview", "frames"}),
                        "output.preview " + quote(o.preview) +
                            " has no frame token (#### or $F4) but " + frames);
         }},
    };
    return table;
}

// ------------------------------------------------------------------------------------------
// 4. Reading nodes, overrides, validation
// ------------------------------------------------------------------------------------------

/// A number node checked against @p r after rounding to float (what gets stored).
std::optional<double> readNumber(const toml::node& n, const std::string& label, const Range& r,
                                 const Context& cx, Problems& pr) {
    std::optional<double> x;
    if (auto i = n.as_integer()) x = double(i->get());
    if (auto f = n.as_floating_point()) x = f->get();
    if (x && r.contains(double(float(*x)))) return double(float(*x));
    pr.add(cx.at(n), label + ": expected a number" + r.suffix(false) + ", found " + describe(n));
    return std::nullopt;
}

std::optional<Value> read(const Param& p, const toml::node& n, const Context& cx, Problems& pr) {
    const std::string name = p.full();
    auto wrong = [&]() -> std::optional<Value> {
        pr.add(cx.at(n), name + ": expected " + p.expected() + ", found " + describe(n));
        return std::nullopt;
    };
    Value v;
    switch (p.type) {
    case Type::Bool:
        if (!n.is_boolean()) return wrong();
        v.b = n.as_boolean()->get();
        break;
    case Type::Int:
        if (!n.is_integer() || !p.range.contains(double(n.as_integer()->get()))) return wrong();
        v.i = n.as_integer()->get();
        break;
    case Type::Number: {
        auto x = readNumber(n, name, p.range, cx, pr);
        if (!x) return std::nullopt;
        v.x = *x;
        break;
    }
    case Type::Vec3:
    case Type::Rgb:
    case Type::Pair: {
        if (p.type == Type::Rgb && (n.is_integer() || n.is_floating_point())) {
            auto x = readNumber(n, name, p.range, cx, pr);
            if (!x) return std::nullopt;
            v.v = {*x, *x, *x};
            break;
        }
        size_t count = p.type == Type::Pair ? 2 : 3;
        const toml::array* a = n.as_array();
        if (!a || a->size() != count) return wrong();
        bool ok = true;
        for (size_t k = 0; k < count; ++k) {
            auto x = readNumber(*a->get(k), name + "[" + std::to_string(k) + "]", p.range, cx, pr);
            if (x) v.v[k] = *x;
            ok = ok && x.has_value();
        }
        if (!ok) return std::nullopt;
        break;
    }
    case Type::String:
        if (!n.is_string()) return wrong();
        v.s = n.as_string()->get();
        break;
    case Type::Word: {
        if (!n.is_string()) return wrong();
        v.s = n.as_string()->get();
        if (std::find(p.words.begin(), p.words.end(), v.s) == p.words.end()) {
            pr.add(cx.at(n), name + ": unknown value " + quote(v.s) + suggestion(v.s, p.words) +
                                 "; expected " + p.expected());
            return std::nullopt;
        }
        break;
    }
    case Type::WordList: {
        const toml::array* a = n.as_array();
        if (!a) return wrong();
        bool ok = true;
        for (size_t k = 0; k < a->size(); ++k) {
            const toml::node& e = *a->get(k);
            std::string label = name + "[" + std::to_string(k) + "]";
            if (!e.is_string()) {
                pr.add(cx.at(e), label + ": expected one of " + quotedList(p.words) + ", found " +
                                     describe(e));
                ok = false;
                continue;
            }
            std::string w = e.as_string()->get();
            if (std::find(p.words.begin(), p.words.end(), w) == p.words.end()) {
                pr.add(cx.at(e), label + ": unknown value " + quote(w) + suggestion(w, p.words) +
                                     "; expected one of " + quotedList(p.words));
                ok = false;
            } else if (std::find(v.list.begin(), v.list.end(), w) != v.list.end()) {
                pr.add(cx.at(e), label + ": " + quote(w) + " is listed twice");
                ok = false;
            }
            v.list.push_back(w);
        }
        if (!ok) return std::nullopt;
        break;
    }
    case Type::Frames:
        if (n.is_integer())
            v.s = std::to_string(n.as_integer()->get());
        else if (n.is_string())
            v.s = n.as_string()->get();
        else
            return wrong();
        try {
            parseFrameSpec(v.s);
        } catch (const std::invalid_argument& e) {
            pr.add(cx.at(n), name + ": " + e.what());
            return std::nullopt;
        }
        break;
    }
    if (p.check) {
        std::string problem = p.check(v);
        if (!problem.empty()) {
            pr.add(cx.at(n), name + ": " + problem);
            return std::nullopt;
        }
    }
    return v;
}

bool isBareKey(std::string_view k) {
    if (k.empty()) return false;
    for (char c : k)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') return false;
    return true;
}

/// Moves @p from into @p into, replacing values; nodes keep their source (the override label).
void merge(toml::table& into, toml::table& from) {
    for (auto&& [k, v] : from) {
        toml::node* dst = into.get(k.str());
        if (dst && dst->is_table() && v.is_table())
            merge(*dst->as_table(), *v.as_table());
        else
            into.insert_or_assign(k, std::move(v));
    }
}

/// Parses one `section.key=value` override and merges it into @p root.
void applyOverride(toml::table& root, const std::string& label, const std::string& override) {
    auto fail = [&](const std::string& what) { throw SceneError(label + ": " + what); };
    size_t eq = override.find('=');
    if (eq == std::string::npos) fail("expected section.key=value, such as render.step=0.5");
    std::string key = trim(std::string_view(override).substr(0, eq));
    std::string value = trim(std::string_view(override).substr(eq + 1));
    if (override.find_first_of("\r\n") != std::string::npos)
        fail("an override must be a single line");
    std::vector<std::string> parts;
    for (size_t a = 0;;) {
        size_t b = key.find('.', a);
        parts.push_back(key.substr(a, b == std::string::npos ? std::string::npos : b - a));
        if (b == std::string::npos) break;
        a = b + 1;
    }
    for (const std::string& part : parts)
        if (!isBareKey(part))
            fail("expected section.key=value with a key such as render.step or frames, found key " +
                 quote(key));
    if (value.empty()) fail("missing value after '='");

    toml::table parsed;
    try {
        parsed = toml::parse(key + " = " + value, label);
    } catch (const toml::parse_error& e) {
        // A bare word (gradient, out/x.####.exr, 1-10) is taken as a string; anything that looks
        // like TOML syntax must be valid TOML.
        if (std::string_view("[{\"'").find(value[0]) != std::string_view::npos)
            fail(
                "invalid TOML value " + value + ": " + std::string(e.description()) +
                (value[0] == '[' || value[0] == '{' ? " (strings inside arrays need quotes)" : ""));
        parsed = toml::parse(key + " = " + quote(value), label);
    }
    merge(root, parsed);
}

/// Checks every key of @p root against the registry and fills @p s.
void validate(const toml::table& root, Staging& s, const Context& cx, Problems& pr) {
    const std::vector<std::string> sections = sectionNames();

    // Unknown top-level keys and sections that are not tables.
    for (auto&& [k, node] : root) {
        std::string name(k.str());
        const auto& arrays = arraySections();
        if (std::any_of(arrays.begin(), arrays.end(),
                        [&](const ArraySection& a) { return a.name == name; }))
            continue; // read below
        if (std::find(sections.begin(), sections.end(), name) != sections.end()) {
            if (!node.is_table())
                pr.add(cx.at(node),
                       name + ": expected a table ([" + name + "]), found " + describe(node));
            continue;
        }
        std::vector<std::string> topKeys = keysOf("", std::nullopt);
        if (std::find(topKeys.begin(), topKeys.end(), name) != topKeys.end()) continue;
        std::vector<std::string> candidates = topKeys;
        candidates.insert(candidates.end(), sections.begin(), sections.end());
        std::vector<std::string> bracketed;
        for (const std::string& sec : sections) bracketed.push_back("[" + sec + "]");
        for (const ArraySection& a : arraySections()) {
            candidates.push_back(a.name);
            bracketed.push_back("[[" + a.name + "]]");
        }
        pr.add(cx.atKey(k, node), "unknown key " + quote(name) + suggestion(name, candidates) +
                                      "; the top level accepts " + join(topKeys, ", ") +
                                      " and the sections " + join(bracketed, ", "));
    }

    // Values, in registry order: field.kind comes before the keys that depend on it.
    bool fieldKindKnown = true;
    for (const Param& p : registry()) {
        const toml::table* tbl = p.section.empty() ? &root : root[p.section].as_table();
        if (!tbl) continue;
        const toml::node* n = tbl->get(p.key);
        if (!n) continue;
        if (p.kind && (!fieldKindKnown || *p.kind != s.file.scene.field.kind)) continue;
        std::optional<Value> v = read(p, *n, cx, pr);
        if (v) {
            p.set(s, *v);
            s.given[p.full()] = cx.at(*n);
        } else if (p.full() == "field.kind") {
            fieldKindKnown = false;
        }
    }

    // Unknown keys inside sections, and keys of the other field kind.
    for (const std::string& sec : sections) {
        const toml::table* tbl = root[sec].as_table();
        if (!tbl) continue;
        std::optional<FieldKind> kind;
        if (sec == "field") kind = s.file.scene.field.kind;
        for (auto&& [k, node] : *tbl) {
            std::string key(k.str());
            bool known = false;
            std::optional<FieldKind> otherKind;
            for (const Param& p : registry()) {
                if (p.section != sec || p.key != key) continue;
                if (!p.kind || !kind || *p.kind == *kind)
                    known = true;
                else
                    otherKind = p.kind;
            }
            if (known) continue;
            if (otherKind && !fieldKindKnown) continue; // the bad kind is reported already
            std::string name = sec + "." + key;
            if (otherKind) {
                pr.add(cx.atKey(k, node),
                       name + ": belongs to field.kind = " + quote(fieldKindName(*otherKind)) +
                           ", but field.kind is " + quote(fieldKindName(*kind)) +
                           "; with that kind [field] accepts " + join(keysOf(sec, kind), ", "));
                continue;
            }
            std::vector<std::string> keys = keysOf(sec, kind);
            std::string hint = suggestion(key, keys);
            pr.add(cx.atKey(k, node), "unknown key " + quote(name) + hint + "; [" + sec +
                                          "] accepts " + join(keys, ", "));
        }
    }
}

/// Reads the [[array]] tables of @p root.
void validateArrays(const toml::table& root, Staging& s, const Context& cx, Problems& pr) {
    for (const ArraySection& a : arraySections()) {
        const toml::node* n = root.get(a.name);
        if (!n) continue;
        const toml::array* arr = n->as_array();
        if (!arr || !arr->is_array_of_tables()) {
            pr.add(cx.at(*n),
                   a.name + ": expected [[" + a.name + "]] tables, found " + describe(*n));
            continue;
        }
        std::vector<std::string> keys;
        for (const Param& p : arrayRegistry())
            if (p.section == a.name) keys.push_back(p.key);
        for (size_t i = 0; i < arr->size(); ++i) {
            const toml::table& tbl = *arr->get(i)->as_table();
            a.grow(s, cx.at(tbl));
            s.element = i;
            for (auto&& [k, node] : tbl) {
                const std::string key(k.str());
                const Param* p = nullptr;
                for (const Param& q : arrayRegistry())
                    if (q.section == a.name && q.key == key) p = &q;
                if (!p) {
                    pr.add(cx.atKey(k, node), "unknown key " + quote(a.name + "." + key) +
                                                  suggestion(key, keys) + "; [[" + a.name +
                                                  "]] accepts " + join(keys, ", "));
                    continue;
                }
                Param named = *p;
                named.section = a.name + "[" + std::to_string(i) + "]";
                if (std::optional<Value> v = read(named, node, cx, pr)) p->set(s, *v);
            }
        }
    }
}

/// Required keys, names, scatter expansion and the default placements.
void resolveArrays(Staging& s, Problems& pr) {
    SceneDesc& sc = s.file.scene;
    std::vector<std::string> names{"field"};
    for (size_t i = 0; i < sc.volumes.size(); ++i) {
        const std::string& n = sc.volumes[i].name;
        const std::string label = "volume[" + std::to_string(i) + "]";
        if (n.empty())
            pr.add(s.volumeWhere[i], label + ": `name` is required");
        else if (std::find(names.begin(), names.end(), n) != names.end())
            pr.add(s.volumeWhere[i], label + ".name: " + quote(n) +
                                         (n == "field" ? " is the name of [field]"
                                                       : " is used by an earlier [[volume]]"));
        if (sc.volumes[i].field.vdb.path.empty())
            pr.add(s.volumeWhere[i], label + ": `path` is required");
        names.push_back(n);
    }
    for (size_t i = 0; i < sc.meshes.size(); ++i)
        if (sc.meshes[i].path.empty())
            pr.add(s.meshWhere[i], "mesh[" + std::to_string(i) + "]: `path` is required");
    auto indexOf = [&](const std::string& name, const Where& w, const std::string& label) {
        const auto it = std::find(names.begin(), names.end(), name);
        if (it != names.end()) return int(it - names.begin());
        pr.add(w, label + ".volume: no volume " + quote(name) + suggestion(name, names) +
                      "; known: " + quotedList(names));
        return 0;
    };
    const bool placed = !sc.instances.empty() || !s.scatters.empty();
    for (size_t i = 0; i < sc.instances.size(); ++i)
        sc.instances[i].volume = indexOf(s.instanceVolumes[i].volume, s.instanceVolumes[i].where,
                                         "instance[" + std::to_string(i) + "]");
    for (size_t i = 0; i < s.scatters.size(); ++i) {
        const Staging::Scatter& c = s.scatters[i];
        const int v = indexOf(c.volume, c.where, "scatter[" + std::to_string(i) + "]");
        if (glm::any(glm::greaterThan(c.regionMin, c.regionMax)))
            pr.add(c.where, "scatter[" + std::to_string(i) + "]: region_min " +
                                "must not exceed region_max on any axis");
        std::uint32_t state = c.seed * 747796405u + 2891336453u;
        auto uniform = [&state]() { // PCG-style hash chain: deterministic, seed-local
            state = state * 747796405u + 2891336453u;
            std::uint32_t w = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
            return float((w >> 22u) ^ w) * (1.0f / 4294967296.0f);
        };
        for (std::int64_t k = 0; k < c.count; ++k) {
            InstanceDesc d;
            d.volume = v;
            const vec3 u(uniform(), uniform(), uniform());
            d.translate = glm::mix(c.regionMin, c.regionMax, u);
            d.scale = vec3(glm::mix(c.scaleMin, c.scaleMax, uniform()));
            d.rotate = vec3(0.0f, glm::mix(c.yawMin, c.yawMax, uniform()), 0.0f);
            d.density = glm::mix(c.densityMin, c.densityMax, uniform());
            sc.instances.push_back(d);
        }
    }
    if (!placed && !sc.volumes.empty())
        for (int v = 0; v <= int(sc.volumes.size()); ++v) {
            InstanceDesc d;
            d.volume = v;
            sc.instances.push_back(d);
        }
    if (placed) // volumes nobody places are never read
        for (size_t i = 0; i < sc.volumes.size(); ++i) {
            if (!isPlaced(sc, int(i) + 1) && i < s.volumeWhere.size())
                s.file.warnings.push_back(s.volumeWhere[i].prefix + ": warning: volume " +
                                          quote(sc.volumes[i].name) +
                                          " is not placed by any [[instance]] or [[scatter]]; "
                                          "it is not read");
        }
}

/// Keys given although their value is ignored (e.g. medium.g with an isotropic phase).
std::vector<std::string> ignoredKeyWarnings(const Staging& s) {
    Problems w;
    for (const Param& p : registry()) {
        auto it = s.given.find(p.full());
        if (it == s.given.end() || !p.used || p.used(s.file)) continue;
        if (p.kind && *p.kind != s.file.scene.field.kind) continue;
        w.add(it->second, p.full() + " is ignored: it is used only when " + p.usedWhenText);
    }
    return w.lines("warning: ");
}

// ------------------------------------------------------------------------------------------
// 5. Reference
// ------------------------------------------------------------------------------------------

std::string toToml(const Param& p, const Value& v) {
    auto triple = [&](size_t n) {
        std::vector<std::string> parts;
        for (size_t k = 0; k < n; ++k) parts.push_back(formatFloat(v.v[k]));
        return "[" + join(parts, ", ") + "]";
    };
    switch (p.type) {
    case Type::Bool:
        return v.b ? "true" : "false";
    case Type::Int:
        return std::to_string(v.i);
    case Type::Number:
        return formatFloat(v.x);
    case Type::Vec3:
        return triple(3);
    case Type::Rgb:
        if (float(v.v[0]) == float(v.v[1]) && float(v.v[1]) == float(v.v[2]))
            return formatFloat(v.v[0]);
        return triple(3);
    case Type::Pair:
        return triple(2);
    case Type::String:
    case Type::Word:
    case Type::Frames:
        return quote(v.s);
    case Type::WordList:
        return "[" + quotedList(v.list) + "]";
    }
    return "";
}

/// The default of @p p in TOML syntax, or "" when it has none.
std::string defaultOf(const Param& p) {
    Staging s;
    if (p.kind) s.file.scene.field.kind = *p.kind;
    std::optional<Value> v = p.get(s);
    return v ? toToml(p, *v) : "";
}

std::string allowedOf(const Param& p) {
    switch (p.type) {
    case Type::Word:
    case Type::WordList:
        return quotedList(p.words);
    case Type::Int:
    case Type::Number:
    case Type::Vec3:
    case Type::Rgb:
    case Type::Pair:
        return p.range.text(p.type == Type::Int);
    default:
        return "";
    }
}

std::string onlyOf(const Param& p) {
    std::vector<std::string> conditions;
    if (p.kind) conditions.push_back("field.kind = " + quote(fieldKindName(*p.kind)));
    if (!p.usedWhenText.empty()) conditions.push_back(p.usedWhenText);
    return join(conditions, " and ");
}

std::string cell(std::string s) {
    std::string out;
    for (char c : s) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out;
}

std::string code(const std::string& s) {
    return s.empty() ? "" : "`" + s + "`";
}

void tableOf(std::ostringstream& md, const std::string& section, std::optional<FieldKind> kind,
             bool kindSpecific) {
    md << "| Key | Type | Default | Allowed | Description |\n"
       << "|---|---|---|---|---|\n";
    for (const Param& p : registry()) {
        if (p.section != section || p.kind.has_value() != kindSpecific) continue;
        if (kindSpecific && p.kind != kind) continue;
        std::string def = defaultOf(p);
        std::string doc = p.doc;
        if (!p.usedWhenText.empty()) doc += " Used only when " + code(p.usedWhenText) + ".";
        md << "| `" << p.key << "` | " << cell(typeName(p.type)) << " | "
           << (def.empty() ? "unset" : cell(code(def))) << " | " << cell(code(allowedOf(p)))
           << " | " << cell(doc) << " |\n";
    }
    md << "\n";
}

} // namespace

// ------------------------------------------------------------------------------------------
// Public API
// ------------------------------------------------------------------------------------------

SceneFile parseSceneText(const std::string& text, const std::string& sourceName,
                         const std::vector<std::string>& overrides) {
    Context cx{sourceName, {}};
    for (const std::string& o : overrides) cx.labels.push_back("--set " + o);

    toml::table root;
    try {
        root = toml::parse(text, sourceName);
    } catch (const toml::parse_error& e) {
        throw SceneError(cx.at(e.source()).prefix +
                         ": TOML syntax error: " + std::string(e.description()));
    }
    for (size_t i = 0; i < overrides.size(); ++i) applyOverride(root, cx.labels[i], overrides[i]);

    Staging s;
    s.file.path = sourceName;
    Problems pr;
    validate(root, s, cx, pr);
    validateArrays(root, s, cx, pr);
    if (!pr.empty()) pr.raise();
    resolveArrays(s, pr);
    if (!pr.empty()) pr.raise();
    for (const Rule& r : rules()) r.apply(s, cx, pr);
    if (!pr.empty()) pr.raise();

    s.file.scene.sun.irradiance *= s.sunIntensity;
    for (std::string& w : ignoredKeyWarnings(s)) s.file.warnings.push_back(std::move(w));
    return s.file;
}

SceneFile loadSceneFile(const std::string& path, const std::vector<std::string>& overrides) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec))
        throw SceneError(path + ": cannot read scene file: no such file");
    if (std::filesystem::is_directory(path, ec))
        throw SceneError(path + ": cannot read scene file: it is a directory");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(path + ": cannot read scene file: " + std::strerror(errno));
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw SceneError(path + ": cannot read scene file: read error");
    return parseSceneText(text.str(), path, overrides);
}

std::vector<SceneParamInfo> sceneFileParameters() {
    std::vector<SceneParamInfo> out;
    for (const Param& p : registry())
        out.push_back({p.full(), typeName(p.type), defaultOf(p), allowedOf(p), p.doc, onlyOf(p)});
    return out;
}

std::string sceneFileReference() {
    std::ostringstream md;
    md << "# Nimbus scene-file reference\n\n"
       << "<!-- Generated by nimbus::io::sceneFileReference() from the parameter table in "
          "plugin/io/scene_file.cpp; do not edit. tests/test_scene_file.cpp fails when this file "
          "and the code differ; to regenerate run `NIMBUS_UPDATE_REFERENCE=1 nimbus_tests "
          "--gtest_filter='SceneFileReference.*'`. -->\n\n"
       << "A scene file is [TOML](https://toml.io). It is read strictly: an unknown key (at any "
          "level), a value of the wrong type, a number out of range or an unknown word is an "
          "error reported as `file:line:column: key: expected ..., found ...`. Keys that are "
          "left out take the defaults below, so an empty file is a valid scene. Lengths are in "
          "world units, angles in degrees, colours are scene-linear RGB in the space named by "
          "`color_space`.\n\n"
       << "A key whose value is ignored because of another setting (for example `medium.g` "
          "with `medium.phase = \"isotropic\"`) gives a warning, not an error.\n\n"
       << "## Value types\n\n"
       << "| Type | Written as |\n|---|---|\n"
       << "| bool | `true` or `false` |\n"
       << "| integer | a whole number: `640` |\n"
       << "| number | `0.5`, `1e-3`, or an integer: `2` |\n"
       << "| [x, y, z] | three numbers: `[0, 1.5, -5]` |\n"
       << "| RGB | `[r, g, b]`, or one number for grey: `0.8` |\n"
       << "| [min, max] | two numbers with min <= max: `[1.2, 3.5]` |\n"
       << "| string | `\"text\"` |\n"
       << "| word | one of the listed strings: `\"gradient\"` |\n"
       << "| words | an array of listed strings, each at most once: `[\"depth\"]` |\n"
       << "| frame spec | a string such as `\"1-100x2\"` (see below), or one integer |\n\n"
       << "## Top level\n\n";
    tableOf(md, "", std::nullopt, false);
    for (const std::string& sec : sectionNames()) {
        md << "## [" << sec << "]\n\n";
        tableOf(md, sec, std::nullopt, false);
        if (sec != "field") continue;
        for (const auto& [name, kind] : kFieldKinds) {
            md << "### [field] with kind = \"" << name << "\"\n\n";
            tableOf(md, sec, kind, true);
        }
        md << "Keys of the other kind are errors.\n\n";
    }
    for (const ArraySection& a : arraySections()) {
        md << "## [[" << a.name << "]]\n\n"
           << a.doc << " Any number of tables.\n\n"
           << "| Key | Type | Default | Allowed | Description |\n"
           << "|---|---|---|---|---|\n";
        for (const Param& p : arrayRegistry()) {
            if (p.section != a.name) continue;
            Staging st;
            a.grow(st, Where{});
            st.element = 0;
            const std::optional<Value> v = p.get(st);
            const std::string def = v ? toToml(p, *v) : "";
            md << "| `" << p.key << "` | " << cell(typeName(p.type)) << " | "
               << (def.empty() || def == "\"\"" ? "unset" : cell(code(def))) << " | "
               << cell(code(allowedOf(p))) << " | " << cell(p.doc) << " |\n";
        }
        md << "\n";
    }
    md << "## Rules across keys\n\n";
    for (const Rule& r : rules()) md << "- **[" << r.section << "]** " << r.doc << "\n";
    md << "\n## Frames and file names\n\n"
       << frameSpecSyntax() << "\n\n"
       << framePatternSyntax() << "\n\n"
       << "## Overrides\n\n"
       << "`nimbus render scene.toml --set section.key=value` replaces (or adds) one key before "
          "validation, with the same checks; top-level keys have no section (`--set "
          "frames=1-10`). The value is TOML (`--set camera.position=[0,1,2]`, "
          "`--set output.path=\"x.####.exr\"`); a bare word that is not valid TOML is taken as "
          "a string (`--set sky.kind=gradient`). Errors in overrides are reported as "
          "`--set section.key=value: ...`.\n\n"
       << "## Every key at its default\n\n"
       << "With `field.kind = \"cumulus\"`; `sun.elevation` and `sun.azimuth` are unset because "
          "`sun.direction` is given, and keys that the defaults ignore are commented out.\n\n"
       << "```toml\n";
    std::string current;
    for (const Param& p : registry()) {
        if (p.kind && *p.kind != FieldKind::Cumulus) continue;
        std::string def = defaultOf(p);
        if (def.empty()) continue;
        if (p.section != current) {
            md << "\n[" << p.section << "]\n";
            current = p.section;
        }
        Staging defaults;
        bool used = !p.used || p.used(defaults.file);
        md << (used ? "" : "# ") << p.key << " = " << def
           << (used ? "" : "  # used only when " + p.usedWhenText) << "\n";
    }
    md << "```\n";
    return md.str();
}

} // namespace nimbus::io
