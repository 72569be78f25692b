// `nimbus render` as a farm task (docs/farm_cli.md): --resume re-renders frames of an edited
// scene or other overrides and says why, skips unchanged ones; the per-frame log line carries
// time and peak memory; the command is a host of libnimbus.so. --progress json is checked
// line by line by tests/farm_json_check.py (ctest farm_cli.json_progress).
#include <gtest/gtest.h>

#include "test_util.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "plugin/io/image_output.h"

namespace fs = std::filesystem;

namespace {

const std::string kScene = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/cumulus.toml";
/// Tiny frames of the default scene: at 32x18 its light-volume grid (voxel 0.117, 8.9 M voxels
/// and the diffusion solve on them) is nearly all of a frame's time, so these tests take a
/// coarse one (voxel 0.5): what they check is the command's handling of frames and files.
const std::string kSmall =
    " --set camera.width=32 --set camera.height=18 --set render.light_volume_cell=0.5";

void copyScene(const fs::path& to, const std::string& append = "") {
    std::ifstream in(kScene);
    std::ofstream out(to);
    out << in.rdbuf() << append;
}

std::string hashOf(const fs::path& exr) {
    return nimbus::io::readExr(exr.string()).attributes["nimbus/sceneHash"];
}

int count(const std::string& text, const std::string& part) {
    int n = 0;
    for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
    return n;
}

} // namespace

// Unchanged scene and overrides: skipped. An edit of the scene file, or another --set: rendered
// again, with the reason in the log, and the new frame carries the new hash.
TEST(FarmCli, ResumeRendersFramesOfAnEditedSceneAgain) {
    TempDir d("resume_hash");
    const fs::path scene = d / "s.toml";
    copyScene(scene);
    const std::string base = "render " + scene.string() + kSmall + " --frames 1-2 -o " +
                             (d / "f.####.exr").string() + " --progress none";
    CliRun r = runNimbus(base);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const std::string h1 = hashOf(d / "f.0001.exr");
    EXPECT_EQ(h1.size(), 16u);
    EXPECT_EQ(hashOf(d / "f.0002.exr"), h1); // the frame number is not in the hash

    r = runNimbus(base + " --resume");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_EQ(count(r.output, "exists, skipped (--resume)"), 2) << r.output;

    // settings that change no pixel keep the hash: threads, the output's pattern
    r = runNimbus(base + " --resume --threads 1 --set render.threads=1");
    EXPECT_EQ(count(r.output, "exists, skipped (--resume)"), 2) << r.output;

    // an edit of the scene text (the sun's intensity): both frames again
    {
        std::ifstream in(scene);
        std::string text((std::istreambuf_iterator<char>(in)), {});
        const size_t at = text.find("intensity = 12.0");
        ASSERT_NE(at, std::string::npos) << "examples/scenes/cumulus.toml changed";
        text.replace(at, 16, "intensity = 3.0");
        std::ofstream(scene) << text;
    }
    r = runNimbus(base + " --resume");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_EQ(count(r.output, "exists but it was rendered from another scene text or other "
                              "settings (scene hash " +
                                  h1),
              2)
        << r.output;
    EXPECT_EQ(count(r.output, "rendering it again (--resume)"), 2) << r.output;
    const std::string h2 = hashOf(d / "f.0001.exr");
    EXPECT_NE(h2, h1);
    EXPECT_EQ(hashOf(d / "f.0002.exr"), h2);

    // unchanged since: skipped
    r = runNimbus(base + " --resume");
    EXPECT_EQ(count(r.output, "exists, skipped (--resume)"), 2) << r.output;

    // another --set: rendered again; the same --set once more: skipped
    r = runNimbus(base + " --resume --set render.step=0.3");
    EXPECT_EQ(count(r.output, "rendering it again (--resume)"), 2) << r.output;
    r = runNimbus(base + " --resume --set render.step=0.3");
    EXPECT_EQ(count(r.output, "exists, skipped (--resume)"), 2) << r.output;
}

// A frame file of another frame number or with other channels is rendered again, saying why.
TEST(FarmCli, ResumeChecksFrameNumberAndChannels) {
    TempDir d("resume_check");
    const std::string out = " -o " + (d / "f.####.exr").string() + " --progress none";
    CliRun r = runNimbus("render " + kScene + kSmall + " --frames 1" + out);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    fs::copy_file(d / "f.0001.exr", d / "f.0002.exr");
    r = runNimbus("render " + kScene + kSmall + " --frames 1-2 --resume" + out);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "frame 1: " + (d / "f.0001.exr").string() +
                                       " exists, skipped (--resume)"));
    EXPECT_TRUE(contains(r.output, "exists but it is frame 1, not 2: rendering it again"));
    EXPECT_EQ(nimbus::io::readExr((d / "f.0002.exr").string()).attributes["nimbus/frame"], "2");
    // the scene's output (cumulus.toml: transmittance and depth) asks for other layers
    r = runNimbus("render " + kScene + kSmall + " --frames 1 --resume --set 'output.aovs=[]'" +
                  out);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "exists but its channels are A B G R depth transmittance.B "
                                   "transmittance.G transmittance.R, not A B G R: rendering"));
    EXPECT_EQ(nimbus::io::readExr((d / "f.0001.exr").string()).channels.size(), 4u);
}

// Plain progress: the per-frame log line has the frame's time and the peak memory.
TEST(FarmCli, PlainLogLineHasTimeAndPeakMemory) {
    TempDir d("plain");
    const CliRun r = runNimbus("render " + kScene + kSmall + " --frames 1-2 --progress plain -o " +
                               (d / "f.####.exr").string());
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const std::regex line(R"(frame ([12]): ([0-9]+\.[0-9]+) s \(.*, peak RSS ([0-9]+) MB -> )");
    int frames = 0;
    for (std::sregex_iterator it(r.output.begin(), r.output.end(), line), end; it != end; ++it) {
        ++frames;
        EXPECT_GT(std::stod((*it)[2]), 0.0);
        EXPECT_GT(std::stoi((*it)[3]), 1); // a process that rendered holds more than 1 MB
    }
    EXPECT_EQ(frames, 2) << r.output;
}

// The render command's code links libnimbus.so and none of the internals: its shared object
// needs libnimbus.so.0, takes nimbus_* functions from it and exports only its entry point.
TEST(FarmCli, RenderCommandIsAHostOfLibnimbus) {
    const fs::path lib = fs::path(NIMBUS_CLI_PATH).parent_path() / "libnimbus_render.so";
    ASSERT_TRUE(fs::exists(lib)) << lib;
    auto run = [](const std::string& cmd) {
        std::string out;
        FILE* p = popen(cmd.c_str(), "r");
        char buf[4096];
        size_t n;
        while (p && (n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
        if (p) pclose(p);
        return out;
    };
    const std::string needed = run("readelf -d " + lib.string() + " 2>&1");
    EXPECT_TRUE(contains(needed, "[libnimbus.so.0]"));
    for (const char* heavy : {"libOpenImageIO", "libopenvdb", "libembree", "libOpenColorIO"})
        EXPECT_EQ(needed.find(heavy), std::string::npos) << heavy << " linked directly";
    const std::string undefined = run("nm -D --undefined-only " + lib.string() + " 2>&1");
    for (const char* f :
         {"nimbus_load_file_with", "nimbus_render_write", "nimbus_output_check", "nimbus_cancel"})
        EXPECT_TRUE(contains(undefined, f));
    // defined and exported: the entry point, and no C++ symbol of nimbus's internals
    const std::string defined = run("nm -DC --defined-only " + lib.string() + " 2>&1");
    EXPECT_TRUE(contains(defined, "nimbus_cli_render"));
    for (const char* internal : {"nimbus::host::", "nimbus::io::ExrImage", "nimbus::Renderer"})
        EXPECT_EQ(defined.find(internal), std::string::npos) << internal;
}

// `nimbus --help` and `--version` stay fast: they load neither the render command's shared
// object nor libnimbus.so (nor what those need); `render` loads both (the control: the dynamic
// loader's log names them).
TEST(FarmCli, HelpAndVersionLoadNoRenderLibrary) {
    for (const char* args : {"--help", "--version", "render --help"}) {
        const CliRun r = runNimbus(args, "LD_DEBUG=files");
        EXPECT_EQ(r.exitCode, 0) << args;
        for (const char* lib : {"libnimbus_render.so", "libnimbus.so", "libOpenImageIO"})
            EXPECT_EQ(r.output.find(lib), std::string::npos) << args << " loaded " << lib;
    }
    const CliRun r = runNimbus("render /nonexistent/scene.toml", "LD_DEBUG=files");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_TRUE(contains(r.output, "libnimbus_render.so"));
    EXPECT_TRUE(contains(r.output, "libnimbus.so.0"));
    // OpenImageIO comes with the first image written (libnimbus_image.so), not with the library;
    // the same holds for the other commands' shared object
    EXPECT_FALSE(contains(r.output, "libOpenImageIO.so")) << "loaded before any image";
    EXPECT_FALSE(contains(r.output, "libnimbus_image.so"));
    const CliRun c = runNimbus("converge /nonexistent/scene.toml", "LD_DEBUG=files");
    EXPECT_EQ(c.exitCode, 2);
    EXPECT_TRUE(contains(c.output, "libnimbus_commands.so"));
    EXPECT_FALSE(contains(c.output, "libOpenImageIO.so")) << "loaded before any image";
    TempDir d("loads_oiio");
    const CliRun w =
        runNimbus("render " + kScene + kSmall + " --frames 1 -o " + (d / "f.####.exr").string(),
                  "LD_DEBUG=files");
    EXPECT_EQ(w.exitCode, 0);
    EXPECT_TRUE(contains(w.output, "libnimbus_image.so"));
    EXPECT_TRUE(contains(w.output, "libOpenImageIO.so"));
    EXPECT_TRUE(std::filesystem::exists(d / "f.0001.exr"));
}

// OpenImageIO's module (libnimbus_image.so) that cannot be loaded: the frame fails with the
// error naming each place looked in and why, the documented exit code 3, and no file of the
// frame left behind. The command and its libraries are copied into a folder of their own with a
// file that is not a shared object under the module's name; LD_LIBRARY_PATH, which the loader
// searches before the libraries' RUNPATH, points there too, so the build's module is not
// reachable. Without LD_LIBRARY_PATH the loader's path (RUNPATH, the build folder) comes second
// and the frame is written: a broken copy beside the libraries does not stop a render.
TEST(FarmCli, ImageModuleThatCannotLoadFailsTheFrameCleanly) {
    TempDir d("image_module");
    const fs::path bin = fs::path(NIMBUS_CLI_PATH).parent_path();
    for (const char* f : {"nimbus", "libnimbus_render.so", "libnimbus.so.0"})
        fs::copy_file(bin / f, d / f);
    writeText((d / "libnimbus_image.so").string(), "not a shared object\n");
    fs::create_directory(d / "out");
    const std::string render =
        (d / "nimbus").string() + " render " + kScene + kSmall + " --frames 1 --progress none -o ";
    const CliRun r = runShell("LD_LIBRARY_PATH=" + d.string() + " " + render +
                              (d / "out" / "f.####.exr").string());
    EXPECT_EQ(r.exitCode, 3) << r.output;
    EXPECT_TRUE(contains(r.output, "frame 1: cannot load OpenImageIO's module (" +
                                       (d / "libnimbus_image.so").string() + ": "));
    EXPECT_TRUE(contains(r.output, "the library path: "));
    EXPECT_TRUE(fs::is_empty(d / "out")) << "a file of the failed frame was left";
    const CliRun ok = runShell(render + (d / "out" / "g.####.exr").string());
    EXPECT_EQ(ok.exitCode, 0) << ok.output;
    EXPECT_EQ(nimbus::io::readExr((d / "out" / "g.0001.exr").string()).width, 32);
}
