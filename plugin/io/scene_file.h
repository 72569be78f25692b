/// @file scene_file.h
/// @brief Strict TOML scene files: parse, apply `--set` overrides, validate, fill SceneDesc.
///
/// Every key a scene file may contain is declared once, in the parameter table of
/// plugin/io/scene/params_<section>.cpp (section, key, type, default, allowed range or words,
/// one-line doc, tags). The same
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

#include <functional>
#include <map>
#include <set>
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

/// Every parameter's effective value as TOML text, keyed "section.key" ("frames" at top level),
/// read from @p f through the table's getters: keys of the other field kinds and unset keys
/// (`sun.elevation` and `sun.azimuth`, folded into `sun.direction`) are left out;
/// `sun.irradiance` already includes `sun.intensity` (which then reads 1). Arrays of tables
/// give "volume[i].key" and "mesh[i].key"; instances (also those of [[scatter]]) are left out.
std::map<std::string, std::string> sceneSettings(const SceneFile& f);

/// The keys of sceneSettings(@p f) that cannot change @p f's pixels: those whose table row says
/// when it is used (`used only when` in the reference) where @p f does not meet that condition
/// (march's settings in a path-traced scene, for instance), and those that never change pixels
/// (render.threads, render.tile_size, frames). Array sections' keys are not included.
std::set<std::string> pixelNeutralSettings(const SceneFile& f);

/// The keys that never change a frame's pixels, whatever the scene: frames, render.threads,
/// render.tile_size and where the output and its preview go (the table's rows marked so).
std::vector<std::string> pixelNeutralKeys();

/// The keys of the march step schedule ("render.step", "render.step_voxels",
/// "render.step_growth", "render.shadow_step", "render.shadow_step_voxels"): the rows tagged as
/// scaling with the step.
std::vector<std::string> stepScheduleKeys();

/// Multiplies every key of the step schedule (stepScheduleKeys()) of @p s by @p f, rounding to
/// float as a scene file would (render.shadow_growth is a ratio and is kept). A step of 0 (the
/// plan's choice) stays 0 where the scene places a VDB volume (render.step_voxels and
/// render.shadow_step_voxels scale instead) and becomes kDefaultStep x f elsewhere.
void scaleSteps(SceneDesc& s, double f);

/// A parameter that `nimbus calibrate` fits, from the parameter table.
struct CalibrationKnob {
    std::string key;            ///< "render.octave_extinction"
    double lo = 0.0, hi = 0.0;  ///< allowed range (closed or open: see `allowed`)
    std::string allowed;        ///< the range as the reference writes it
    double defaultValue = 0.0;  ///< the table's default
    std::vector<double> values; ///< the grid calibrate tries, each inside the range
    std::function<bool(const SceneDesc&)> applies; ///< the key's "used only when" condition
    std::function<double(const SceneDesc&)> get;
    std::function<void(SceneDesc&, double)> set; ///< rounds to float, as a scene file would
};

/// The rows tagged for calibration, in table order.
std::vector<CalibrationKnob> calibrationKnobs();

} // namespace nimbus::io
