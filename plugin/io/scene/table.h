/// @file table.h
/// @brief The scene-file parameter table: value types, ranges, the staging a file is parsed
///        into, one row (Param) per key and the one factory (Section::param) that makes rows.
///
/// Internal to plugin/io (the public API is plugin/io/scene_file.h). Each section's rows are
/// registered in its own params_<section>.cpp; registry() (params.cpp) lists them in reference
/// order. A row's type is deduced from the member it reaches:
///
/// @code
///   const Section<CameraDesc> cam{"camera", [](Staging& s) -> CameraDesc& {
///       return s.file.scene.camera;
///   }};
///   t.push_back(cam.param("fov", open(0, 180), "Vertical field of view in degrees.",
///                         &CameraDesc::fovY)); // float member: a number row
/// @endcode
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "plugin/io/scene_file.h"

namespace nimbus::io::scene {

constexpr double kInf = std::numeric_limits<double>::infinity();

// --- text helpers (reader.cpp)

/// Shortest text that reads back as the same float (values are stored as float).
std::string formatFloat(double x);
/// Shortest text of a double: what the user wrote, for error messages.
std::string formatDouble(double x);
/// A TOML basic string.
std::string quote(std::string_view s);
std::string trim(std::string_view s);
std::string join(const std::vector<std::string>& items, std::string_view sep);
std::string quotedList(const std::vector<std::string>& words);
/// " (did you mean "x"?)" for the closest candidate, or "".
std::string suggestion(std::string_view word, const std::vector<std::string>& candidates);
bool endsWithNoCase(const std::string& s, std::string_view suffix);

/// Where a problem is: "file:line:column" or the override it came from.
struct Where {
    std::string prefix;
    int rank = 0; ///< 0: the file; 1 + i: override i (overrides sort after the file)
    int line = 0;
    int column = 0;
};

// --- value types and ranges

enum class Type { Bool, Int, Number, Vec3, Rgb, Pair, String, Word, WordList, Frames };

std::string typeName(Type t);

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
    std::string text(bool integer) const;
    /// " in [0, 1]", " > 0" or "" — appended to "a number".
    std::string suffix(bool integer) const;
};

inline Range atLeast(double lo) {
    return {lo, kInf, false, false};
}
inline Range above(double lo) {
    return {lo, kInf, true, false};
}
inline Range closed(double lo, double hi) {
    return {lo, hi, false, false};
}
inline Range open(double lo, double hi) {
    return {lo, hi, true, true};
}
inline Range closedOpen(double lo, double hi) {
    return {lo, hi, false, true};
}
inline Range openClosed(double lo, double hi) {
    return {lo, hi, true, false};
}
inline const Range kUInt32 = closed(0.0, 4294967295.0);

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
    std::vector<Where> solidWhere;          ///< per [[solid]]
    std::vector<char> solidTreeRead;        ///< per [[solid]]: its [[solid.node]] tables given
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

    // tables inside [field] (fieldSubTables())
    std::vector<Where> ellipsoidWhere;        ///< per [[field.ellipsoid]]
    std::optional<Where> gardnerScatterWhere; ///< [field.scatter]
    std::vector<Where> windWhere;             ///< per [[field.wind]] (automaton)
    std::optional<Where> advectWhere;         ///< [field.advect]
    std::vector<Where> windLayerWhere;        ///< per [[field.wind_layer]] (advection)
    /// SDF node tables being read (params_sdf.cpp), one per table of the array.
    struct SdfNodeRow {
        SdfNodeDesc desc;
        std::string name, parent;
        Where where;                        ///< the table
        std::map<std::string, Where> given; ///< key -> location of its value
    };
    std::vector<SdfNodeRow> sdfNodes;
};

// --- rows

/// One key: type, range, doc, the condition under which it matters, and its accessors.
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
    bool stepSchedule = false;                         ///< scaled with the march step (scaleSteps)
    bool pixelNeutral = false; ///< cannot change a frame's pixels (threads, tiles, frames)
    std::vector<double> calibrationGrid; ///< non-empty: values `nimbus calibrate` tries

    std::string full() const { return section.empty() ? key : section + "." + key; }
    std::string expected() const;

    Param& as(Type t) { ///< Vec3 -> Rgb, String -> Frames: same value, other syntax
        type = t;
        return *this;
    }
    Param& usedWhen(std::string text, std::function<bool(const SceneFile&)> pred) {
        usedWhenText = std::move(text);
        used = std::move(pred);
        return *this;
    }
    /// Read by `march` alone: the row's condition, if any, with `render.integrator = "march"`
    /// before it (a path-traced scene warns that the key is ignored, and the validation
    /// suite's reference keys leave it out).
    Param& marchOnly() {
        std::function<bool(const SceneFile&)> before = std::move(used);
        used = [before](const SceneFile& f) {
            return f.scene.render.integrator == Integrator::March && (!before || before(f));
        };
        // a condition with alternatives in it is bracketed, so that "and" binds all of it
        const bool alternatives = usedWhenText.find(" or ") != std::string::npos;
        usedWhenText = usedWhenText.empty() ? "render.integrator = \"march\""
                       : alternatives ? "render.integrator = \"march\" and (" + usedWhenText + ")"
                                      : "render.integrator = \"march\" and " + usedWhenText;
        return *this;
    }
    Param& checkedBy(std::function<std::string(const Value&)> fn) {
        check = std::move(fn);
        return *this;
    }
    Param& neutralToPixels() {
        pixelNeutral = true;
        return *this;
    }
    Param& scalesWithStep() {
        stepSchedule = true;
        return *this;
    }
    Param& calibratedOver(std::vector<double> grid) {
        calibrationGrid = std::move(grid);
        return *this;
    }
};

template <class E> using WordTable = std::vector<std::pair<std::string, E>>;

template <class T> struct IsOptional : std::false_type {};
template <class T> struct IsOptional<std::optional<T>> : std::true_type {};

/// The row type of a member of type T.
template <class T> constexpr Type typeOf() {
    if constexpr (std::is_same_v<T, bool>)
        return Type::Bool;
    else if constexpr (std::is_integral_v<T>)
        return Type::Int;
    else if constexpr (std::is_floating_point_v<T> || IsOptional<T>::value)
        return Type::Number;
    else if constexpr (std::is_same_v<T, vec3>)
        return Type::Vec3;
    else if constexpr (std::is_same_v<T, std::string>)
        return Type::String;
    else
        static_assert(std::is_enum_v<T>, "no scene-file type for this member");
    return Type::Word;
}

/// Stores a read value in a member.
template <class T> void load(T& m, const Value& v) {
    if constexpr (std::is_same_v<T, bool>)
        m = v.b;
    else if constexpr (std::is_integral_v<T>)
        m = T(v.i);
    else if constexpr (std::is_floating_point_v<T>)
        m = T(float(v.x));
    else if constexpr (IsOptional<T>::value)
        m = v.x;
    else if constexpr (std::is_same_v<T, vec3>)
        m = vec3(float(v.v[0]), float(v.v[1]), float(v.v[2]));
    else
        m = v.s;
}

/// A member as a value; nullopt for an unset optional.
template <class T> std::optional<Value> store(const T& m) {
    Value v;
    if constexpr (std::is_same_v<T, bool>)
        v.b = m;
    else if constexpr (std::is_integral_v<T>)
        v.i = std::int64_t(m);
    else if constexpr (std::is_floating_point_v<T>)
        v.x = m;
    else if constexpr (IsOptional<T>::value) {
        if (!m) return std::nullopt;
        v.x = *m;
    } else if constexpr (std::is_same_v<T, vec3>)
        v.v = {m.x, m.y, m.z};
    else
        v.s = m;
    return v;
}

/// The rows of one section (or one field kind) whose members live in a Root struct that
/// `root` finds in the staging. param() deduces the row type from the member, reached from
/// Root by one or more member pointers (`&CumulusDesc::bounds, &Box::lo`).
template <class Root> struct Section {
    std::string name;
    Root& (*root)(Staging&);
    std::optional<FieldKind> kind = std::nullopt; ///< rows of [field] of this kind only

    Param row(std::string key, Type type, Range range, std::string doc) const {
        Param p;
        p.section = name;
        p.key = std::move(key);
        p.type = type;
        p.range = range;
        p.doc = std::move(doc);
        p.kind = kind;
        return p;
    }

    /// bool, integers, float/double, std::optional<double>, vec3 and std::string members.
    template <class... M> Param param(std::string key, Range r, std::string doc, M... path) const {
        using T = std::remove_cvref_t<decltype((std::declval<Root&>().*....*path))>;
        Param p = row(std::move(key), typeOf<T>(), r, std::move(doc));
        auto at = [root = root, path...](Staging& s) -> T& { return (root(s).*....*path); };
        p.set = [at](Staging& s, const Value& v) { load(at(s), v); };
        p.get = [at](Staging& s) { return store(at(s)); };
        return p;
    }

    /// A vec3 colour: [r, g, b] or one grey number.
    template <class... M> Param rgb(std::string key, Range r, std::string doc, M... path) const {
        return param(std::move(key), r, std::move(doc), path...).as(Type::Rgb);
    }

    /// An enum member written as one of the words of @p table.
    template <class E, class... M>
    Param param(std::string key, const WordTable<E>& table, std::string doc, M... path) const {
        using T = std::remove_cvref_t<decltype((std::declval<Root&>().*....*path))>;
        static_assert(std::is_same_v<T, E>, "the word table is not of the member's enum");
        Param p = row(std::move(key), Type::Word, {}, std::move(doc));
        for (const auto& [name, e] : table) p.words.push_back(name);
        auto at = [root = root, path...](Staging& s) -> T& { return (root(s).*....*path); };
        p.set = [at, table](Staging& s, const Value& v) {
            for (const auto& [name, e] : table)
                if (name == v.s) at(s) = e;
        };
        p.get = [at, table](Staging& s) -> std::optional<Value> {
            Value v;
            for (const auto& [name, e] : table)
                if (e == at(s)) v.s = name;
            return v;
        };
        return p;
    }

    /// Two float members given as one [min, max] array.
    Param pair(std::string key, Range r, std::string doc, float Root::*lo, float Root::*hi) const {
        Param p = row(std::move(key), Type::Pair, r, std::move(doc));
        p.set = [root = root, lo, hi](Staging& s, const Value& v) {
            root(s).*lo = float(v.v[0]);
            root(s).*hi = float(v.v[1]);
        };
        p.get = [root = root, lo, hi](Staging& s) -> std::optional<Value> {
            Value v;
            v.v = {root(s).*lo, root(s).*hi, 0.0};
            return v;
        };
        p.check = [](const Value& v) -> std::string {
            if (v.v[0] <= v.v[1]) return "";
            return "min " + formatFloat(v.v[0]) + " exceeds max " + formatFloat(v.v[1]) +
                   "; expected [min, max] with min <= max";
        };
        return p;
    }
};

// --- checks shared by several rows

std::string nonEmpty(const Value& v);
std::string nonZero(const Value& v);

extern const WordTable<FieldKind> kFieldKinds;
std::string fieldKindName(FieldKind k);

// --- the tables

/// Rows of each section, in reference order (params_<section>.cpp).
void addTopLevelParams(std::vector<Param>& t);
void addCameraParams(std::vector<Param>& t);
void addSunParams(std::vector<Param>& t);
void addSkyParams(std::vector<Param>& t);
void addMediumParams(std::vector<Param>& t);
void addFieldParams(std::vector<Param>& t); ///< field.kind
void addCumulusParams(std::vector<Param>& t);
void addHomogeneousParams(std::vector<Param>& t);
void addVdbParams(std::vector<Param>& t);
void addGardnerParams(std::vector<Param>& t);
void addSdfFieldParams(std::vector<Param>& t); ///< [field] kind = "sdf" (params_sdf.cpp)
void addAutomatonParams(std::vector<Param>& t);
void addGroundParams(std::vector<Param>& t);
void addRenderParams(std::vector<Param>& t);
void addOutputParams(std::vector<Param>& t);

/// Every key a scene file may contain, in reference order. The only place that knows them.
const std::vector<Param>& registry();

/// An array of tables (`[[instance]]`): each element is read with the rows of its section in
/// arrayRegistry(), the accessors reaching the element Staging::element.
struct ArraySection {
    std::string name;
    std::string doc;
    std::function<void(Staging&, Where)> grow; ///< appends a default element
};

const std::vector<ArraySection>& arraySections();
const std::vector<Param>& arrayRegistry();

/// A table (`[field.scatter]`) or an array of tables (`[[field.ellipsoid]]`) inside [field]
/// that belongs to one field kind. Its rows (fieldSubRegistry(), section "field.<key>") reach
/// element Staging::element of an array.
struct FieldSubTable {
    FieldKind kind;
    std::string key; ///< "ellipsoid": [[field.ellipsoid]] (array) or [field.ellipsoid]
    bool array = false;
    std::string doc;
    std::function<void(Staging&, Where)> grow; ///< array: appends an element; table: enables it
};

const std::vector<FieldSubTable>& fieldSubTables();
const std::vector<Param>& fieldSubRegistry();
/// [[field.wind]] of kind = "automaton" and its rows (params_automaton.cpp).
FieldSubTable automatonWindTable();
void addAutomatonSubParams(std::vector<Param>& t);
/// [field.advect] and [[field.wind_layer]] for every kind that can be advected
/// (params_advect.cpp).
void addAdvectTables(std::vector<FieldSubTable>& t);
void addAdvectSubParams(std::vector<Param>& t);

std::vector<std::string> sectionNames();
/// Keys of @p section that apply to field kind @p kind (all keys outside [field]).
std::vector<std::string> keysOf(const std::string& section, std::optional<FieldKind> kind);

// --- values as TOML (reference.cpp)

std::string toToml(const Param& p, const Value& v);
/// The default of @p p in TOML syntax, or "" when it has none.
std::string defaultOf(const Param& p);
std::string allowedOf(const Param& p);
std::string onlyOf(const Param& p);

} // namespace nimbus::io::scene
