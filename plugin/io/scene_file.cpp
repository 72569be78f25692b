/// @file scene_file.cpp
/// @brief Parsing and loading scene files (see scene_file.h).
///
/// The pieces live in plugin/io/scene/:
///  - table.h: value types, ranges, rows (Param) and the one row factory (Section::param);
///  - params_<section>.cpp: the rows of each section, params.cpp lists them in reference order;
///  - reader.{h,cpp}: reading TOML nodes against a row, problems, overrides, validation;
///  - rules.cpp: the rules across keys, each with its one-line doc;
///  - reference.cpp: the generated reference and the parameter listing;
///  - queries.cpp: sceneSettings(), scaleSteps(), calibrationKnobs().
/// Adding a key = adding one row to its params_<section>.cpp; parser, errors, warnings,
/// reference and settings follow.
#include "plugin/io/scene_file.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "plugin/io/scene/params_sdf.h"
#include "plugin/io/scene/reader.h"

namespace nimbus::io {

using namespace scene;

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
    if (s.file.scene.field.kind == FieldKind::Sdf) readSdfField(root, s, cx, pr);
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

} // namespace nimbus::io
