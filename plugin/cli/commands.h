/// @file commands.h
/// @brief The subcommands of `nimbus` (render, converge) behind the command-line parser.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/geometry.h"

namespace nimbus::cli {

// the exit codes of host::exitCode (plugin/host/session.h)
inline constexpr int kExitOk = 0;
inline constexpr int kExitInternal = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitIo = 3;
inline constexpr int kExitNoMemory = 4;
inline constexpr int kExitInterrupted = 130;

/// After the first signal the command stops by itself (the renderer polls its cancel flag inside
/// its loops); a watchdog ends the process with exit 130 if it is still running this long after.
inline constexpr double kCancelGraceSeconds = 0.9;

struct RenderOptions {
    std::string scene;
    std::string frames;
    std::vector<std::string> overrides;
    std::string output;
    int threads = -1; ///< -1: keep the scene's render.threads
    bool explain = false;
    bool resume = false;
    std::string progress = "auto"; ///< auto, bar, plain, json, none

    bool quiet = false;
};

struct ConvergeOptions {
    std::string scene;
    std::vector<std::string> overrides;
    std::optional<int> frame;                       ///< none: first frame of the scene
    std::vector<double> ladder{4.0, 2.0, 1.0, 0.5}; ///< march step multipliers
    double referenceStep = 0.125;     ///< march reference: step multiplier (referenceSpp == 0)
    int referenceSpp = 0;             ///< > 0: the reference is pathtrace with this many spp
    std::vector<int> pathtraceLadder; ///< pathtrace rungs (samples per pixel)
    std::vector<int> photonLadder;    ///< march rungs with multiple_scattering = photons
    double scale = 1.0;               ///< resolution multiplier for every render
    std::string csv;
    std::string plot; ///< PNG of error against time (gnuplot), empty = none
    int threads = -1;
    bool boxFilter = false;    ///< pathtrace averages over pixels (march samples their centres)
    std::string saveReference; ///< write the reference here (EXR, scene-linear working space)
    std::string loadReference; ///< read the reference from here instead of rendering it

    // --suite: the validation matrix of march against pathtrace (plugin/cli/suite.cpp)
    bool suite = false;
    std::string suiteData; ///< VDB folder; empty = ../shared/data/vdb beside the repository
    std::string suiteDir = "suite-cache"; ///< cached references, suite.md, suite.csv
    std::vector<std::string> suiteFilter; ///< run the cases whose name contains any of these
    std::string suiteSize = "64x36";      ///< width x height of every render
    int suiteSpp = 16;                    ///< first round of samples per pixel of each reference
    int suiteMaxSpp = 16384;              ///< samples per pixel of a reference at most
    double suiteNoise = 0.05; ///< refine a reference until its relative noise is below this
    double suiteSeconds = 30; ///< ... or its rendering took this long (seconds, all rounds)
    /// render.max_depth of the references (0 = the scene's, 2^20 by default): 65,536 since
    /// before that default was raised from 256 (which lost 4-14% of the matrix's thick albedo-1
    /// light), kept so that the cached references stay valid; a white furnace 500 mean free
    /// paths across loses 0.11% to it (docs/accuracy.md, "The depth cap")
    int suiteMaxDepth = 65536;
    bool suiteRerender = false; ///< render every reference again, ignoring the cache
    /// the suite's lights: "both" (the sun and the sky), "sun" or "sky" alone, to tell which
    /// light a case's error comes from; cached apart (<case>.sun.a.exr, <case>.sky.a.exr)
    std::string suiteLight = "both";
};

struct CalibrateOptions {
    std::string scene;
    std::vector<std::string> overrides;
    std::optional<int> frame; ///< none: first frame of the scene
    int referenceSpp = 256;
    double scale = 0.25;
    int threads = -1;
    bool boxFilter = false;
    std::string saveReference;
    std::string loadReference;
};

/// `nimbus render` is not here: it is a host of libnimbus.so (render_host.cpp, built as
/// libnimbus_render.so; plugin/cli/dispatch.h).
struct BakeOptions {
    std::string scene;
    std::vector<std::string> overrides;
    std::string frames; ///< default: the scene's
    std::string output; ///< VDB path pattern
    std::string grid = "density";
    float voxel = 0.0f; ///< 0 = the plan's majorant cell
    int threads = -1;
    bool levelSet = false;                ///< also the [[solid]]s, as level sets
    std::string levelSetGrid = "surface"; ///< their grid name ("surface_<n>" for several)
    float halfWidth = 3.0f;               ///< narrow band, voxels each side
    std::optional<Box> box;               ///< clips the level sets (needed for unbounded solids)
    /// also a vec3s grid `velocityGrid` per frame: the field's motion (its wind) around the
    /// density (vdb::FogBake::velocity); refused for a field that does not move
    bool velocity = false;
    std::string velocityGrid = "velocity";
};

/// `nimbus bench-vdb-render`: OpenVDB's VolumeRender against Nimbus march (bench_vdb.cpp).
struct BenchVdbOptions {
    std::string scene;
    std::vector<std::string> overrides;
    std::optional<int> frame; ///< none: first frame of the scene
    double scale = 1.0;       ///< resolution multiplier
    int threads = -1;         ///< both renderers; -1: render.threads
    std::vector<double> ladder{8.0, 6.0, 4.0, 3.0, 2.0, 1.5, 1.0, 0.5}; ///< nimbus step multipliers
    std::vector<double> vdbLadder{2.0, 1.0, 0.5, 0.25}; ///< VolumeRender step multipliers
    double vdbStep = 1.0;       ///< VolumeRender primary step at multiplier 1, voxels
    double vdbShadowStep = 3.0; ///< VolumeRender shadow step at multiplier 1, voxels
    /// more VolumeRender rungs, "primary:shadow" in voxels (a finer shadow step than vdb_render's
    /// 1:3 ratio is VolumeRender's better trade on smoke1)
    std::vector<std::string> vdbSteps{"4:2", "3:1.5", "2:1", "1.5:0.75", "1:0.5"};
    double vdbCutoff = -1.0;      ///< < 0: 3 render.epsilon^2, the early exit of march
    bool vdbDefaults = true;      ///< also run vdb_render's defaults (1, 3 voxels, cutoff 0.005)
    double referenceStep = 0.125; ///< step multiplier of the nimbus reference
    bool checkReference = false;  ///< also render at twice that step and compare
    int repeat = 3;               ///< rounds over the rungs; each rung's fastest time is kept
    std::string outputDir;        ///< write every image (EXR + PNG) here
    std::string csv;
};

/// `nimbus stress`: the numerical-stability report (stress.cpp, docs/stress.md).
struct StressOptions {
    bool quick = false;     ///< the short list of cases at 16x9 pixels
    std::string csv;        ///< also write the table here
    std::string filter;     ///< run only the cases whose name contains this
    double caseLimit = 0.0; ///< stop the run when one case runs longer (0: 40x the budget)
};

/// `nimbus rt`: the scene's frames on the GPU through the GLSL march pass (rt.cpp,
/// plugin/realtime/rt_march.h, docs/realtime.md).
struct RtOptions {
    std::string scene;
    std::string frames; ///< default: the scene's
    std::vector<std::string> overrides;
    std::string output;      ///< EXR path pattern; default: the scene's output.path
    int accumulate = 1;      ///< each frame the average of this many jittered renders (>= 1)
    bool gpuDisplay = false; ///< the preview's OCIO display transform on the GPU
    bool explain = false;
    bool quiet = false;
};

/// `nimbus export-glsl`: one frame's march shader for engines, with only the features it uses,
/// its parameter block and a JSON of the block (export_glsl.cpp, plugin/realtime/export_glsl.h,
/// docs/realtime.md "Export for engines").
struct ExportGlslOptions {
    std::string scene;
    std::string output;       ///< the folder to write (created)
    std::optional<int> frame; ///< default: the scene's first frame
    std::vector<std::string> overrides;
};

int runConverge(const ConvergeOptions& o);
int runExportGlsl(const ExportGlslOptions& o);
int runRt(const RtOptions& o);
int runStress(const StressOptions& o);
int runBenchVdb(const BenchVdbOptions& o);
int runBake(const BakeOptions& o);
int runCalibrate(const CalibrateOptions& o);

} // namespace nimbus::cli
