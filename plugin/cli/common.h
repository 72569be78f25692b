/// @file common.h
/// @brief What the subcommands share: printing the session's statuses and warnings (the
/// session, plugin/host, does the loading and binding), signal handling, timing.
#pragma once

#include <atomic>
#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "core/image_error.h"
#include "core/render.h"
#include "plugin/host/session.h"
#include "plugin/io/color.h"
#include "plugin/io/scene_file.h"

namespace nimbus::cli {

/// Set by SIGINT/SIGTERM/SIGHUP once installSignalHandlers() ran.
extern std::atomic<bool> gCancel;
void installSignalHandlers();

double secondsSince(std::chrono::steady_clock::time_point t0);

/// A scene loaded by the session: file with overrides, colours resolved, geometry built.
using LoadedScene = host::Session;

/// A message cut to its first and last bytes when longer than 8 KB: a value echoed from a scene
/// (a 50 MB string) must not flood a farm's log.
std::string clipped(const std::string& message);

/// Prints the warnings the session collected ("nimbus: <warning>").
void printWarnings(host::Session& s);

/// Prints a failed status ("nimbus: error: <message>"; when interrupted "nimbus: <message>")
/// and returns its exit code (0 for ok, printing nothing).
int report(const host::Status& st);

/// Loads a scene into the session; prints warnings and errors and returns an exit code (0 on
/// success). `threads` >= 0 overrides render.threads.
int loadScene(const std::string& path, const std::vector<std::string>& overrides, int threads,
              LoadedScene& out);

/// Binds frame `frame` in the session (the VDB grids of the placed volumes, the geometry) and
/// copies its bindings to b; prints warnings and errors. False on error.
bool bindFrame(LoadedScene& ls, int frame, FrameBindings& b);

// --- measuring error against run time (converge, calibrate, bench-vdb-render) ---

/// A render and its wall time.
struct Measured {
    double seconds = 0.0;
    RenderStats stats;
    Framebuffer fb;
    float step = 0.0f, shadowStep = 0.0f; ///< march's steps as the plan chose them
    /// march's multiple scattering as the plan chose it ("grid", "photons", "none") and, when
    /// render.multiple_scattering = "auto" measured it, the cloud's optical depth along the sun
    std::string msModel;
    double cloudTau = -1.0;
    double photonCellScale = 0.0;   ///< photons: their voxel in light-volume cells
    double photonVoxelDepth = -1.0; ///< photons: their voxel's mean optical depth (-1: unmeasured)
    int marchOrders = 1; ///< the sun's orders march takes itself (FramePlan::secondDepth)
};

/// The scene with its whole step schedule scaled by f: render.step, render.step_growth and
/// render.shadow_step (render.shadow_growth is a ratio and is kept).
SceneDesc withSteps(const SceneDesc& base, double f);

/// Renders frame `frame` of s and times Renderer::render (noise is baked before the clock
/// starts, so the time is the integrator's); returns false when interrupted.
bool measure(const SceneDesc& s, const FrameBindings& b, int frame, Measured& m);

/// The scene prepared for measuring: clouds alone (background transparent: a noise-free sky
/// would dilute the error), frame `requested` bound into b (the scene's first frame when none;
/// `frame` is set to the frame used), resolution scaled, the noise evaluation the scene's own
/// plan picks (so the error is that of the setting alone). Prints errors; false on bad input.
bool prepare(LoadedScene& ls, std::optional<int> requested, double scale, SceneDesc& base,
             int& frame, FrameBindings& b);

/// Writes text to path atomically; prints the error and returns false on failure.
bool writeText(const std::string& path, const std::string& text);

struct ConvergeOptions;

/// `nimbus converge --suite`: the validation matrix of march against pathtrace over every
/// cloud, thickness, sun position and albedo (suite.cpp). Returns an exit code.
int runSuite(const ConvergeOptions& o);

} // namespace nimbus::cli
