/// @file scene_file.h
/// @brief Strict TOML scene files: parse, apply `--set` overrides, validate, fill SceneDesc.
///
/// Every key a scene file may contain is declared once, in the parameter table of
/// scene_file.cpp (section, key, type, default, allowed range or words, one-line doc). The same
/// table validates files and generates the reference (sceneFileReference(), checked in as
/// examples/scenes/reference.md), so documentation and parser cannot drift (pbrt-v4's
/// `ReportUnused()` idea: a misspelt key is an error, never a silent default).
///
/// @code
///   try {
///       io::SceneFile f = io::loadSceneFile("cloud.toml", {"render.step=0.02"});
///       for (const std::string& w : f.warnings) std::cerr << w << "\n";
///       for (int frame : io::parseFrameSpec(f.frames)) render(f.scene, frame);
///   } catch (const io::SceneError& e) {
///       std::cerr << e.what() << "\n"; // "cloud.toml:12:8: render.step: expected ..."
///   }
/// @endcode
///
/// @note Colours are stored as written, in the space named by `color_space`
///       (SceneFile::inputColorSpace); converting them to the working space is the caller's job
///       (it owns the OCIO config).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/scene.h"

namespace nimbus::io {

/// Where and how frames are written.
struct OutputDesc {
    std::string path = "out/frame.####.exr"; ///< EXR path pattern (frame tokens: frames.h)
    std::string colorSpace = "ACEScg";       ///< colour space of the EXR pixels
    nimbus::AovSet aovs;                     ///< extra layers beside RGBA
    std::string preview;                     ///< PNG path pattern; empty = no preview
    std::string display = "sRGB";            ///< OCIO display of the preview
    std::string view = "ACES 1.0 SDR-video"; ///< OCIO view of the preview
};

/// A parsed and validated scene file.
struct SceneFile {
    std::string path; ///< the file it came from (the source name for parseSceneText)
    nimbus::SceneDesc scene;
    OutputDesc output;
    std::string frames = "1";                   ///< frame spec, already checked by parseFrameSpec
    std::string inputColorSpace = "lin_rec709"; ///< space of the colours in the file
    std::vector<std::string> warnings; ///< "file:line:col: warning: ..." (e.g. ignored keys)
};

/// Any problem with a scene file or an override. what() starts with `file:line:column:` or, for
/// an override, `--set section.key=value:`; one line per problem, in file order.
class SceneError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// Reads and parses @p path (see parseSceneText). Throws SceneError when the file cannot be read.
SceneFile loadSceneFile(const std::string& path, const std::vector<std::string>& overrides = {});

/// Parses TOML @p text; @p sourceName prefixes error messages. @p overrides are
/// `section.key=value` strings (value in TOML syntax; a bare word such as `gradient` or
/// `out/x.####.exr` is taken as a string) applied before validation.
/// @throws SceneError on syntax errors, unknown keys (at any level), wrong types, out-of-range
///         values, unknown enum words, keys of the other field kind and failed cross-key checks.
SceneFile parseSceneText(const std::string& text, const std::string& sourceName,
                         const std::vector<std::string>& overrides = {});

/// The scene-file reference in Markdown, generated from the parameter table.
std::string sceneFileReference();

/// One row of the parameter table, as text (for --help listings).
struct SceneParamInfo {
    std::string key;     ///< "render.step", or "frames" at top level
    std::string type;    ///< "number", "[x, y, z]", "word", ...
    std::string value;   ///< default, in TOML syntax
    std::string allowed; ///< range or words, empty when anything of the type goes
    std::string doc;     ///< one line
    std::string only;    ///< condition such as `field.kind = "cumulus"`, empty = always
};

/// All parameters, in reference order.
std::vector<SceneParamInfo> sceneFileParameters();

} // namespace nimbus::io
