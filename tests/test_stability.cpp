/// @file test_stability.cpp
/// @brief Stiff and hostile cases through the real `nimbus` command (docs/stability.md): a
/// render stops on SIGTERM/SIGINT whatever the scene (cancellation polled inside tiles, exit
/// 130, nothing left behind), an exception never escapes main, grids past their limit are
/// refused with the key, the cells and the limit, and --explain warns of absurd steps.
///
/// The kill timeout below is a hang detector, not a speed assertion: the measured latencies
/// from signal to exit are recorded as test properties (--gtest_output=xml) and in the docs.

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "plugin/io/atomic_file.h"
#include "plugin/io/color.h"
#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"
#include "test_util.h"

namespace fs = std::filesystem;

namespace {

const std::string kScene = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/cumulus.toml";
/// A small frame of the default scene with the noise evaluated directly (no bake to wait for).
const std::string kSmall = " --frames 1 --set camera.width=64 --set camera.height=36 "
                           "--set field.evaluation='\"direct\"'";

/// No light grids (the default scene's diffusion grid takes seconds with direct noise): the
/// frame goes straight to its tiles, where the signal is meant to arrive; 8x4 pixels, so the
/// rays in flight at the signal are in the cloud (at 64x36 the first rows see only sky, and a
/// check between rows would stop them).
const std::string kNoGrids = " --set render.multiple_scattering='\"none\"' --progress plain "
                             "--set camera.width=8 --set camera.height=4 ";

struct SignalledRun {
    int exitCode = -1;
    bool hung = false;    ///< still running kHangSeconds after the signal (then SIGKILLed)
    double latency = 0.0; ///< seconds from the signal to the exit
    std::string stderrText;
};

constexpr double kHangSeconds = 20.0;

/// Runs `nimbus args` with stderr to a file, waits until stderr shows `marker` (the render has
/// started; at most kHangSeconds), then `ms` milliseconds more, sends `sig` and waits for the
/// exit (SIGKILL after kHangSeconds: a hang detector).
SignalledRun signalNimbus(const std::string& args, const std::string& marker, int sig, int ms,
                          const fs::path& errFile) {
    SignalledRun r;
    const std::string cmd =
        "exec " + std::string(NIMBUS_CLI_PATH) + " " + args + " >/dev/null 2>" + errFile.string();
    const pid_t pid = fork();
    if (pid < 0) return r;
    if (pid == 0) {
        execl("/bin/sh", "sh", "-c", cmd.c_str(), (char*)nullptr);
        _exit(127);
    }
    auto readErr = [&] {
        std::ifstream in(errFile);
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    };
    for (int i = 0; i < int(kHangSeconds * 100) && readErr().find(marker) == std::string::npos; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    const auto t0 = std::chrono::steady_clock::now();
    kill(pid, sig);
    int st = 0;
    for (;;) {
        const pid_t w = waitpid(pid, &st, WNOHANG);
        r.latency = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (w == pid) break;
        if (r.latency > kHangSeconds) {
            r.hung = true;
            kill(pid, SIGKILL);
            waitpid(pid, &st, 0);
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    r.exitCode = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    r.stderrText = readErr();
    return r;
}

/// Every entry of `dir` (hidden ones included) but the file `except`.
std::vector<std::string> leftovers(const fs::path& dir, const fs::path& except) {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(dir))
        if (e.path() != except) out.push_back(e.path().filename().string());
    return out;
}

struct StiffCase {
    const char* name;
    const char* settings;
    int signal;
};

class StiffScene : public testing::TestWithParam<StiffCase> {};

} // namespace

// A frame whose tiles would run for hours stops within a second of the signal, by the
// renderer's own polling (not the watchdog), exits 130 and leaves no file behind. The signal
// comes 1.5 s after the frame's start ("0%" of the plain progress): inside the stiff tiles.
TEST_P(StiffScene, StopsOnSignalAndLeavesNothing) {
    const StiffCase& c = GetParam();
    TempDir d("stiff");
    const fs::path err = d / "stderr.txt";
    const SignalledRun r = signalNimbus("render " + kScene + kSmall + " --progress plain " +
                                            c.settings + " -o " + (d / "out.####.exr").string(),
                                        "0% (frame 1)", c.signal, 1500, err);
    RecordProperty("latency_ms", int(r.latency * 1000.0));
    RecordProperty("stderr", r.stderrText);
    EXPECT_FALSE(r.hung) << "still running " << kHangSeconds << " s after the signal";
    EXPECT_EQ(r.exitCode, 130) << r.stderrText;
    EXPECT_TRUE(contains(r.stderrText, "interrupted during frame 1"));
    // the cooperative stop, not the watchdog's last resort
    EXPECT_EQ(r.stderrText.find("did not stop"), std::string::npos) << r.stderrText;
    EXPECT_TRUE(leftovers(d, err).empty()) << leftovers(d, err).front();
}

INSTANTIATE_TEST_SUITE_P(
    Stability, StiffScene,
    testing::Values(
        // 8.5e10 steps per camera ray
        StiffCase{"step1e9", "--set render.step=1e-9 --set render.step_growth=0", SIGTERM},
        StiffCase{"step1e9_sigint", "--set render.step=1e-9 --set render.step_growth=0", SIGINT},
        // ~1e12 tentative collisions per path (delta tracking in a medium scaled by 1e12)
        StiffCase{"pathtrace_dense",
                  "--set render.integrator='\"pathtrace\"' --set medium.density_scale=1e12",
                  SIGTERM},
        // the documented maximum samples per pixel
        StiffCase{"pathtrace_max_spp",
                  "--set render.integrator='\"pathtrace\"' --set render.spp=1048576", SIGTERM},
        // march with the documented maximum pixel samples and a fine step
        StiffCase{"march_max_pixel_samples",
                  "--set render.pixel_samples=4096 --set render.step=0.001", SIGTERM},
        // a tiny shadow step with growth off: every sample's shadow march is long
        StiffCase{"shadow_step1e9", "--set render.shadow_step=1e-9 --set render.shadow_growth=0",
                  SIGTERM}),
    [](const testing::TestParamInfo<StiffCase>& i) { return std::string(i.param.name); });

// An exception from a render worker that is not a std::exception (TBB carries it to the main
// thread): a message and exit 1, not abort's 134.
TEST(Stability, ForeignExceptionFromAWorkerIsAnInternalError) {
    TempDir d("fault");
    const CliRun r = runNimbus("render " + kScene + kSmall + " -o " + (d / "f.####.exr").string(),
                               "NIMBUS_TEST_FAULT=worker");
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, "internal error"));
    EXPECT_TRUE(fs::is_empty(d.path()));
}

// A std::bad_alloc from a worker: out of memory, exit 4.
TEST(Stability, BadAllocFromAWorkerIsOutOfMemory) {
    TempDir d("fault");
    const CliRun r = runNimbus("render " + kScene + kSmall + " -o " + (d / "f.####.exr").string(),
                               "NIMBUS_TEST_FAULT=bad-alloc");
    EXPECT_EQ(r.exitCode, 4) << r.output;
    // what the frame allocates and how far the process had got, not just "out of memory"
    EXPECT_TRUE(contains(r.output, "frame 1: out of memory while rendering it; its plan "
                                   "allocates"))
        << r.output;
    EXPECT_TRUE(contains(r.output, "MB of frame buffer")) << r.output;
    EXPECT_TRUE(contains(r.output, "MB at its peak: lower the resolution")) << r.output;
}

// An exception on a thread that cannot pass it on reaches std::terminate: the last-resort
// handler prints what it was and exits 1 instead of aborting (134).
TEST(Stability, ExceptionReachingTerminateIsAnInternalError) {
    TempDir d("fault");
    const CliRun r = runNimbus("render " + kScene + kSmall + " -o " + (d / "f.####.exr").string(),
                               "NIMBUS_TEST_FAULT=thread");
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_TRUE(contains(r.output, "internal error: unhandled (test fault on a thread"));
}

// Grids past kMaxGridCells are refused before anything is allocated, naming the key, the cells
// the setting would need and the limit (they ran out of memory or threw length_error before).
TEST(Stability, GridsPastTheLimitAreRefused) {
    TempDir d("limit");
    const std::string out = " -o " + (d / "f.####.exr").string();
    CliRun r =
        runNimbus("render " + kScene + kSmall +
                  " --set render.shadow='\"volume\"' --set render.light_volume_cell=0.01" + out);
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "render.light_volume_cell = 0.01 needs 1.44e+10 cells "
                                   "(6001 x 400 x 6001)"));
    EXPECT_TRUE(contains(r.output, "the limit is 134217728"));
    r = runNimbus("render " + kScene + kSmall + " --set render.majorant_cell=1e-9" + out);
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "render.majorant_cell = 1e-09 needs"));
    EXPECT_TRUE(contains(r.output, "the limit is 134217728"));
    EXPECT_TRUE(fs::is_empty(d.path()));
}

// --explain warns of a step that implies an absurd number of steps per ray, and shows a refusal.
TEST(Stability, ExplainWarnsOfAbsurdStepsAndShowsRefusals) {
    CliRun r = runNimbus("render " + kScene + kSmall +
                         " --set render.step=1e-9 --set render.step_growth=0 --explain");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "warning: a march step of 1e-09"));
    EXPECT_TRUE(contains(r.output, "steps per camera ray"));
    r = runNimbus("render " + kScene + kSmall + " --explain");
    EXPECT_EQ(r.output.find("warning: a march step"), std::string::npos) << r.output;
    r = runNimbus("render " + kScene + kSmall + " --set render.majorant_cell=0.001 --explain");
    EXPECT_TRUE(contains(r.output, "refused: render.majorant_cell = 0.001 needs"));
}

// A scene far from the origin, where floats quantise positions to more than half a step, is
// warned of (it renders shifted and blocky: `nimbus stress --filter camera/far`); the same
// scene near the origin is not.
// Far from the origin (core/rebase.h): a homogeneous field 1e7 units out is rendered translated
// and --explain says where to; with a ground plane it cannot be translated exactly and the plan
// warns, saying why; near the origin neither.
TEST(Stability, ExplainSaysHowAFieldFarFromTheOriginIsRendered) {
    TempDir dir;
    auto scene = [&](double x, bool ground) {
        const std::string path =
            (dir / ("far" + std::to_string(int(x > 0)) + std::to_string(int(ground)) + ".toml"))
                .string();
        const std::string v = std::to_string(x);
        writeText(path, "[camera]\nposition = [" + v + ", 0.0, -100.0]\nlook_at = [" + v +
                            ", 0.0, 0.0]\n[field]\nkind = \"homogeneous\"\nbounds_min = [" +
                            std::to_string(x - 1.0) + ", -1.0, -1.0]\nbounds_max = [" +
                            std::to_string(x + 1.0) + ", 1.0, 1.0]\n" +
                            (ground ? "[ground]\nenabled = true\nheight = -2.0\n" : ""));
        return path;
    };
    CliRun r = runNimbus("render " + scene(1e7, false) + " --explain");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "coordinates: rendered relative to (10000000, 0, 0), 1e+07 "
                                   "units from the world origin"));
    EXPECT_EQ(r.output.find("warning: the field or the camera"), std::string::npos) << r.output;
    r = runNimbus("render " + scene(1e7, true) + " --explain");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "warning: the field or the camera lies 1e+07 units from the "
                                   "origin, where a float resolves only 1.19 units"));
    EXPECT_TRUE(contains(r.output, "(not translated automatically: the scene has surfaces"));
    r = runNimbus("render " + scene(0.0, false) + " --explain");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_EQ(r.output.find("from the origin"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("rendered relative to"), std::string::npos) << r.output;
}

// An empty --frames or -o is an error, not a silent fall-back to the scene's values.
TEST(Stability, EmptyFramesOrOutputIsAnError) {
    CliRun r = runNimbus("render " + kScene + " --frames '' --explain");
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "--frames is empty"));
    r = runNimbus("render " + kScene + " -o '' --explain");
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "--output is empty"));
}

namespace {

/// The built-in OCIO config with `edit` applied (from -> to), written to dir/name.
std::string writeConfig(const fs::path& dir, const std::string& name, const std::string& from,
                        const std::string& to) {
    std::string text = nimbus::io::ColorSystem::builtinConfigText();
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    const fs::path p = dir / name;
    std::ofstream(p) << text;
    return p.string();
}

const char* kLutSpace = R"(  - !<ColorSpace>
    name: lutspace
    family: Scene-linear
    isdata: false
    encoding: scene-linear
    to_scene_reference: !<FileTransform> {src: missing_lut.spi1d, interpolation: linear}

  - !<ColorSpace>
    name: raw)";

} // namespace

// $OCIO without a scene_linear role: bad input naming the role (it said "unknown colour space ''").
TEST(Stability, OcioConfigWithoutSceneLinearRoleIsBadInput) {
    TempDir d("ocio");
    const std::string cfg = writeConfig(d, "norole.ocio", "  scene_linear: ACEScg\n", "");
    const CliRun r = runNimbus("render " + kScene + kSmall + " --explain", "OCIO=" + cfg);
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "has no scene_linear role"));
}

// A colour space whose transform needs a missing LUT file: bad input at load (exit 2), for the
// scene's colours and for the output (that one was an I/O error, 3, after the first render).
TEST(Stability, ColourSpaceWithAMissingLutIsBadInput) {
    TempDir d("ocio");
    const std::string cfg =
        writeConfig(d, "lut.ocio", "  - !<ColorSpace>\n    name: raw", kLutSpace);
    const std::string out = " -o " + (d / "f.####.exr").string();
    CliRun r =
        runNimbus("render " + kScene + kSmall + " --set output.color_space='\"lutspace\"'" + out,
                  "OCIO=" + cfg);
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "missing_lut.spi1d"));
    r = runNimbus("render " + kScene + kSmall + " --set color_space='\"lutspace\"'" + out,
                  "OCIO=" + cfg);
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "missing_lut.spi1d"));
    EXPECT_FALSE(fs::exists(d / "f.0001.exr"));
}

namespace {

/// A pid that no process has: a child that has exited and been reaped.
pid_t deadPid() {
    const pid_t pid = fork();
    if (pid == 0) _exit(0);
    int st = 0;
    waitpid(pid, &st, 0);
    return pid;
}

} // namespace

// A SIGKILLed frame leaves a hidden temp file (not ending in .exr); the next run of that frame,
// with or without --resume, removes it; temp files of running processes stay.
TEST(Stability, StaleTempFilesOfDeadProcessesAreRemoved) {
    TempDir d("stale");
    const std::string final = (d / "f.0001.exr").string();
    std::string temp = nimbus::io::makeTempPath(final);
    const std::string me = "-" + std::to_string(getpid()) + "-";
    const std::string alive = temp;
    temp.replace(temp.find(me), me.size(), "-" + std::to_string(deadPid()) + "-");
    std::ofstream(temp) << "half a frame";
    std::string live = alive;
    live.replace(live.find(me), me.size(), "-1-"); // init: always running
    std::ofstream(live) << "another process's frame";
    EXPECT_NE(fs::path(temp).extension(), ".exr");
    for (const char* resume : {"", " --resume"}) {
        std::ofstream(temp) << "half a frame";
        const CliRun r =
            runNimbus("render " + kScene + kSmall + resume + " -o " + (d / "f.####.exr").string());
        EXPECT_EQ(r.exitCode, 0) << r.output;
        EXPECT_TRUE(contains(r.output, "removed 1 temp file(s) of interrupted runs"));
        EXPECT_FALSE(fs::exists(temp)) << resume;
        EXPECT_TRUE(fs::exists(live)) << resume;
    }
}

// A legal 250-byte output name works: the temp name stays within NAME_MAX.
TEST(Stability, LongOutputNameWorks) {
    TempDir d("long");
    const std::string name = std::string(246, 'x') + ".exr";
    const CliRun r = runNimbus("render " + kScene + kSmall + " -q -o " + (d / name).string());
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(fs::exists(d / name));
}

// --resume renders a valid frame of another resolution again, and says why.
TEST(Stability, ResumeRendersAFrameOfAnotherResolutionAgain) {
    TempDir d("resume");
    const std::string out = " -o " + (d / "f.####.exr").string();
    CliRun r = runNimbus("render " + kScene + kSmall + " -q" + out);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    r = runNimbus("render " + kScene + kSmall + " --resume" + out);
    EXPECT_TRUE(contains(r.output, "exists, skipped (--resume)"));
    r = runNimbus("render " + kScene + kSmall +
                  " --set camera.width=32 --set camera.height=18 --resume" + out);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "exists but it is 64x36, not 32x18: rendering it again"));
    EXPECT_EQ(nimbus::io::readExr((d / "f.0001.exr").string()).width, 32);
}

// SIGTERM while a frame is being written: exit 130 (it was 3, an I/O error, when the handler
// removed the temp file under the writer), and no file left.
TEST(Stability, SignalDuringTheWriteIsAnInterruption) {
    TempDir d("write");
    const CliRun r =
        runNimbus("render " + kScene + kSmall + " -q -o " + (d / "f.####.exr").string(),
                  "NIMBUS_TEST_FAULT=signal-in-write");
    EXPECT_EQ(r.exitCode, 130) << r.output;
    EXPECT_TRUE(contains(r.output, "interrupted while writing frame 1"));
    EXPECT_TRUE(fs::is_empty(d.path())) << leftovers(d, "").front();
}

// Every documented inclusive end of a number's range is accepted (field.erosion's [0, 0.99]
// refused 0.99: the value was rounded to float before the comparison, the end was not).
TEST(Stability, InclusiveRangeEndsAreAccepted) {
    std::ifstream in(kScene);
    std::stringstream text;
    text << in.rdbuf();
    int checked = 0;
    for (const nimbus::io::SceneParamInfo& p : nimbus::io::sceneFileParameters()) {
        if (p.type != "number" || p.allowed.empty()) continue;
        std::vector<std::string> ends;
        const std::string& a = p.allowed;
        if (a.rfind(">= ", 0) == 0 || a.rfind("<= ", 0) == 0) ends.push_back(a.substr(3));
        if (a.front() == '[') ends.push_back(a.substr(1, a.find(',') - 1));
        if (a.back() == ']') ends.push_back(a.substr(a.find(',') + 2, a.size() - a.find(',') - 3));
        for (const std::string& e : ends) {
            try {
                nimbus::io::parseSceneText(text.str(), "cumulus.toml", {p.key + "=" + e});
            } catch (const std::exception& ex) {
                EXPECT_EQ(std::string(ex.what()).find(p.key + ": expected a number"),
                          std::string::npos)
                    << p.key << " = " << e << " (allowed " << a << "): " << ex.what();
            }
            ++checked;
        }
    }
    RecordProperty("ends_checked", checked);
    EXPECT_GT(checked, 20);
}

// A huge value is not echoed whole into stderr (a 10 MB unknown key was, in full).
TEST(Stability, HugeValuesAreNotEchoedWhole) {
    TempDir d("huge");
    std::ifstream in(kScene);
    std::stringstream text;
    text << in.rdbuf();
    std::ofstream(d / "b.toml") << text.str() << "\n" << std::string(10 << 20, 'x') << " = 1\n";
    const CliRun r = runNimbus("render " + (d / "b.toml").string() + " --frames 1");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_LT(r.output.size(), 20000u);
    EXPECT_TRUE(contains(r.output.substr(0, 200), "unknown key"));
    EXPECT_TRUE(contains(r.output, "bytes left out"));
}

// A directory, FIFO or device as a VDB path says what it is (it said "does not exist").
TEST(Stability, VdbPathThatIsNotAFileSaysWhatItIs) {
    TempDir d("vdbpath");
    const std::string scene = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/smoke1.toml";
    const std::string fifo = (d / "fifo").string();
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    const std::pair<std::string, std::string> cases[] = {{d.string(), "is a directory"},
                                                         {fifo, "is a FIFO"},
                                                         {"/dev/null", "is a character device"}};
    for (const auto& [path, what] : cases) {
        const CliRun r = runNimbus("render " + scene + " --frames 1 -q --set field.path='\"" +
                                   path + "\"' -o " + (d / "x.exr").string());
        EXPECT_EQ(r.exitCode, 2) << r.output;
        EXPECT_TRUE(contains(r.output, what));
        EXPECT_EQ(r.output.find("does not exist"), std::string::npos) << r.output;
    }
}

// A full disk says so (OpenEXR's "Failed to write pixel data" alone did not): a 300 KB tmpfs,
// mounted when the test may (root); skipped otherwise.
TEST(Stability, FullDiskSaysNoSpaceLeft) {
    TempDir d("full");
    const fs::path mnt = d / "mnt";
    fs::create_directories(mnt);
    if (std::system(("mount -t tmpfs -o size=300k tmpfs " + mnt.string() + " 2>/dev/null").c_str()))
        GTEST_SKIP() << "cannot mount a tmpfs here";
    const CliRun r = runNimbus("render " + kScene + kSmall +
                               " --set camera.width=320 --set camera.height=180 -q -o " +
                               (mnt / "f.####.exr").string());
    const std::vector<std::string> left = leftovers(mnt, "");
    std::system(("umount " + mnt.string()).c_str());
    EXPECT_EQ(r.exitCode, 3) << r.output;
    EXPECT_TRUE(contains(r.output, "No space left on device"));
    EXPECT_TRUE(left.empty()) << left.front();
}
