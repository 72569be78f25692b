/// @file common.h
/// @brief What the subcommands share: scene loading with colour resolution, signal handling,
/// timing.
#pragma once

#include <atomic>
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "plugin/io/color.h"
#include "plugin/io/scene_file.h"

namespace nimbus::cli {

/// Set by SIGINT/SIGTERM/SIGHUP once installSignalHandlers() ran.
extern std::atomic<bool> gCancel;
void installSignalHandlers();

double secondsSince(std::chrono::steady_clock::time_point t0);

/// A scene file loaded with overrides and its colours resolved against the OCIO config.
struct LoadedScene {
    std::optional<io::ColorSystem> cs;
    io::SceneFile file;
};

/// Loads a scene; prints errors and returns an exit code (0 on success). `threads` >= 0
/// overrides render.threads.
int loadScene(const std::string& path, const std::vector<std::string>& overrides, int threads,
              LoadedScene& out);

/// Loads what the scene's field needs for `frame` into s (a VDB field: that frame's grid);
/// prints warnings, and errors naming the scene file and frame. False on error.
bool attachFrameField(const io::SceneFile& f, int frame, SceneDesc& s);

} // namespace nimbus::cli
