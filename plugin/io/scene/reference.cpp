/// @file reference.cpp
/// @brief Values as TOML text, the generated scene-file reference and the public queries over
///        the table: sceneFileParameters(), sceneSettings(), scaleSteps(), calibrationKnobs().
#include <sstream>

#include "plugin/io/frames.h"
#include "plugin/io/scene/params_sdf.h"
#include "plugin/io/scene/reader.h"

namespace nimbus::io::scene {

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

namespace {

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

/// The [[field.node]] tables of kind = "sdf" (params_sdf.h): syntax and one row per key.
void sdfNodeTable(std::ostringstream& md) {
    md << "### [[field.node]] (kind = \"sdf\")\n\n"
       << "The tree of signed distance functions of an SDF cloud, one table per node. A node is "
          "a primitive (`type` = sphere, ellipsoid, box, round_box, capsule, torus, cone, plane) "
          "or an operator (union, intersection, subtraction; smooth when `smooth` > 0) that "
          "combines the nodes naming it as their `parent`, in file order (subtraction: the first "
          "child minus the others). Nodes without `parent` are the top level: one is the root, "
          "several are joined by a hard union. Each node has its own transform (parent from node "
          "= translate R scale, R = Rz Ry Rx) and may add noise displacement (`displace` > 0). "
          "Every distance is 1-Lipschitz, so empty space is skipped by sphere tracing with the "
          "displacement amplitudes added to the bound. A key the node's type does not take is "
          "an error.\n\n"
       << "```toml\n[[field.node]]\nname = \"blob\"\ntype = \"union\"\nsmooth = 0.5\n\n"
          "[[field.node]]\nparent = \"blob\"\ntype = \"sphere\"\nradius = 1.0\n\n"
          "[[field.node]]\nparent = \"blob\"\ntype = \"box\"\nsize = [0.6, 0.4, 0.6]\n"
          "translate = [1, 0, 0]\n```\n\n"
       << "| Key | Type | Default | Allowed | Description |\n|---|---|---|---|---|\n";
    for (const Param& p : sdfNodeRegistry()) {
        Staging st;
        st.sdfNodes.emplace_back();
        st.element = 0;
        const std::optional<Value> v = p.get(st);
        const std::string def = v && p.key != "type" ? toToml(p, *v) : "";
        md << "| `" << p.key << "` | " << cell(typeName(p.type)) << " | "
           << (def.empty() || def == "\"\"" ? "unset" : cell(code(def))) << " | "
           << cell(code(allowedOf(p))) << " | " << cell(p.doc) << " |\n";
    }
    md << "\n";
}

} // namespace

} // namespace nimbus::io::scene

namespace nimbus::io {

using namespace scene;

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
          "plugin/io/scene/params_*.cpp; do not edit. tests/test_scene_file.cpp fails when this "
          "file "
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
        sdfNodeTable(md);
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
