/// @file common.h
/// @brief What the subcommands share: scene loading with colour resolution, signal handling,
/// timing.
#pragma once

#include <atomic>
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "core/render.h"
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
    /// Embree, when the scene has surfaces or instances (else null)
    std::shared_ptr<const GeometryBackend> geometry;
};

/// Loads a scene; prints errors and returns an exit code (0 on success). `threads` >= 0
/// overrides render.threads.
int loadScene(const std::string& path, const std::vector<std::string>& overrides, int threads,
              LoadedScene& out);

/// Binds what frame `frame` needs: the VDB grids of the placed volumes and the scene's
/// geometry; prints warnings, and errors naming the scene file and frame. False on error.
bool bindFrame(const LoadedScene& ls, int frame, FrameBindings& b);

// --- measuring error against run time (converge, calibrate, bench-vdb-render) ---

/// A render and its wall time.
struct Measured {
    double seconds = 0.0;
    RenderStats stats;
    Framebuffer fb;
};

/// The scene with its whole step schedule scaled by f: render.step, render.step_growth and
/// render.shadow_step (render.shadow_growth is a ratio and is kept).
SceneDesc withSteps(const SceneDesc& base, double f);

/// Renders frame `frame` of s and times Renderer::render (noise is baked before the clock
/// starts, so the time is the integrator's); returns false when interrupted.
bool measure(const SceneDesc& s, const FrameBindings& b, int frame, Measured& m);

/// Root mean square difference over every RGBA value of two same-sized framebuffers.
double rmse(const Framebuffer& a, const Framebuffer& ref);
/// Root mean square of every RGBA value (relative RMSE = rmse / rms of the reference).
double rms(const Framebuffer& a);

/// The scene prepared for measuring: clouds alone (background transparent: a noise-free sky
/// would dilute the error), the field of `frame` attached (the scene's first frame when frame
/// is -1000000000; frame is set to it), resolution scaled, the noise evaluation the scene's own
/// plan picks (so the error is that of the setting alone). Prints errors; false on bad input.
bool prepare(const LoadedScene& ls, int& frame, double scale, SceneDesc& base, FrameBindings& b);

/// Writes text to path atomically; prints the error and returns false on failure.
bool writeText(const std::string& path, const std::string& text);

} // namespace nimbus::cli
