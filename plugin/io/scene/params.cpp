/// @file params.cpp
/// @brief The parameter table in reference order (one line per section), the checks several
///        rows share, and the queries over the table's keys.
#include <algorithm>
#include <cctype>

#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

const WordTable<FieldKind> kFieldKinds = {
    {"cumulus", FieldKind::Cumulus}, {"homogeneous", FieldKind::Homogeneous},
    {"vdb", FieldKind::Vdb},         {"gardner", FieldKind::Gardner},
    {"sdf", FieldKind::Sdf},         {"automaton", FieldKind::Automaton}};

std::string fieldKindName(FieldKind k) {
    for (const auto& [name, e] : kFieldKinds)
        if (e == k) return name;
    return "?";
}

std::string nonEmpty(const Value& v) {
    return v.s.empty() ? "expected a non-empty string" : "";
}

std::string nonZero(const Value& v) {
    if (v.v[0] != 0.0 || v.v[1] != 0.0 || v.v[2] != 0.0) return "";
    return "expected a non-zero vector, found [0, 0, 0]";
}

const std::vector<Param>& registry() {
    static const std::vector<Param> table = [] {
        std::vector<Param> t;
        addTopLevelParams(t);
        addCameraParams(t);
        addSunParams(t);
        addSkyParams(t);
        addMediumParams(t);
        addFieldParams(t); // field.kind comes before the keys that depend on it
        addCumulusParams(t);
        addHomogeneousParams(t);
        addVdbParams(t);
        addGardnerParams(t);
        addSdfFieldParams(t);
        addAutomatonParams(t);
        addGroundParams(t);
        addRenderParams(t);
        addOutputParams(t);
        return t;
    }();
    return table;
}

std::vector<std::string> sectionNames() {
    std::vector<std::string> out;
    for (const Param& p : registry())
        if (!p.section.empty() && std::find(out.begin(), out.end(), p.section) == out.end())
            out.push_back(p.section);
    return out;
}

std::vector<std::string> keysOf(const std::string& section, std::optional<FieldKind> kind) {
    std::vector<std::string> out;
    for (const Param& p : registry())
        if (p.section == section && (!p.kind || !kind || p.kind == kind)) {
            if (std::find(out.begin(), out.end(), p.key) == out.end()) out.push_back(p.key);
        }
    return out;
}

} // namespace nimbus::io::scene
