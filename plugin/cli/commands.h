/// @file commands.h
/// @brief The subcommands of `nimbus` (render, converge) behind the command-line parser.
#pragma once

#include <string>
#include <vector>

namespace nimbus::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitInternal = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitIo = 3;
inline constexpr int kExitNoMemory = 4;
inline constexpr int kExitInterrupted = 130;

struct RenderOptions {
    std::string scene;
    std::string frames;
    std::vector<std::string> overrides;
    std::string output;
    int threads = -1; ///< -1: keep the scene's render.threads
    bool explain = false;
    bool resume = false;
    std::string progress = "auto";
    bool quiet = false;
};

struct ConvergeOptions {
    std::string scene;
    std::vector<std::string> overrides;
    int frame = -1000000000;                        ///< sentinel: first frame of the scene
    std::vector<double> ladder{4.0, 2.0, 1.0, 0.5}; ///< march step multipliers
    double referenceStep = 0.125;     ///< march reference: step multiplier (referenceSpp == 0)
    int referenceSpp = 0;             ///< > 0: the reference is pathtrace with this many spp
    std::vector<int> pathtraceLadder; ///< pathtrace rungs (samples per pixel)
    double scale = 1.0;               ///< resolution multiplier for every render
    std::string csv;
    std::string plot; ///< PNG of error against time (gnuplot), empty = none
    int threads = -1;
    bool boxFilter = false; ///< pathtrace averages over pixels (march samples their centres)
};

struct CalibrateOptions {
    std::string scene;
    std::vector<std::string> overrides;
    int frame = -1000000000;
    int referenceSpp = 256;
    double scale = 0.25;
    int threads = -1;
    bool boxFilter = false;
};

int runRender(const RenderOptions& o);
struct BakeOptions {
    std::string scene;
    std::vector<std::string> overrides;
    std::string frames; ///< default: the scene's
    std::string output; ///< VDB path pattern
    std::string grid = "density";
    float voxel = 0.0f; ///< 0 = the plan's majorant cell
    int threads = -1;
};

int runConverge(const ConvergeOptions& o);
int runBake(const BakeOptions& o);
int runCalibrate(const CalibrateOptions& o);

} // namespace nimbus::cli
