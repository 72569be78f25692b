// CLI integration tests: the real `nimbus` binary on real scene files.
#include <gtest/gtest.h>

#include "test_util.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "plugin/io/image_output.h"

namespace fs = std::filesystem;

namespace {

fs::path tempDir(const std::string& name) {
    fs::path d =
        fs::temp_directory_path() / ("nimbus_cli_" + name + "_" + std::to_string(getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

/// A small cumulus scene: 48x27, a few seconds at most.
std::string tinyScene(const fs::path& dir, const std::string& extraRender = "") {
    return "color_space = \"lin_rec709\"\n"
           "frames = \"1\"\n"
           "[camera]\nposition = [0.0, 0.3, -24.0]\nlook_at = [0.0, 5.5, 0.0]\nfov = 45.0\n"
           "width = 48\nheight = 27\n"
           "[sun]\nelevation = 9.0\nazimuth = -30.0\nintensity = 12.0\n"
           "[medium]\nsigma_s = 12.0\ng = 0.5\n"
           "[field]\nkind = \"cumulus\"\nbounds_min = [-30.0, 1.2, -20.0]\n"
           "bounds_max = [30.0, 5.2, 40.0]\nwind = [0.6, 0.0, 0.15]\nbase_octaves = 3\n"
           "detail_octaves = 2\n"
           "[render]\nstep = 0.08\nstep_growth = 0.004\nshadow_step = 0.1\n"
           "multiple_scattering = \"grid\"\n" + // the default scene's model, not 2-8 M photons

           extraRender +
           "[output]\npath = \"" + (dir / "tiny.####.exr").string() +
           "\"\naovs = [\"transmittance\", \"depth\"]\npreview = \"" +
           (dir / "tiny.####.png").string() + "\"\n";
}

void writeFile(const fs::path& p, const std::string& text) {
    std::ofstream f(p);
    f << text;
}

void expectAllFinite(const nimbus::io::ExrImage& img) {
    for (float v : img.pixels) ASSERT_TRUE(std::isfinite(v));
}

} // namespace

TEST(Cli, HelpAndVersion) {
    CliRun h = runNimbus("--help");
    EXPECT_EQ(h.exitCode, 0);
    for (const char* word : {"render", "converge", "reference", "Exit codes"})
        EXPECT_NE(h.output.find(word), std::string::npos) << word;
    CliRun rh = runNimbus("render --help");
    EXPECT_EQ(rh.exitCode, 0);
    for (const char* word : {"--frames", "--set", "--explain", "--resume", "--progress"})
        EXPECT_NE(rh.output.find(word), std::string::npos) << word;
    CliRun v = runNimbus("--version");
    EXPECT_EQ(v.exitCode, 0);
    EXPECT_NE(v.output.find(NIMBUS_VERSION), std::string::npos);
    EXPECT_NE(runNimbus("render").exitCode, 0); // missing scene
    EXPECT_NE(runNimbus("no-such-command").exitCode, 0);
}

TEST(Cli, RendersTinySceneEndToEnd) {
    fs::path d = tempDir("tiny");
    writeFile(d / "tiny.toml", tinyScene(d));
    CliRun r = runNimbus("render " + (d / "tiny.toml").string() + " --progress plain");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("frame 1/1 100%"), std::string::npos) << r.output;
    nimbus::io::ExrImage img = nimbus::io::readExr((d / "tiny.0001.exr").string());
    EXPECT_EQ(img.width, 48);
    EXPECT_EQ(img.height, 27);
    for (const char* c : {"R", "G", "B", "A", "transmittance.R", "depth"})
        EXPECT_GE(img.channelIndex(c), 0) << c;
    EXPECT_EQ(img.attributes["nimbus/colorSpace"], "ACEScg");
    EXPECT_EQ(img.attributes["nimbus/frame"], "1");
    expectAllFinite(img);
    // clouds are there: some pixels have transmittance well below 1
    int cloudy = 0;
    const int t = img.channelIndex("transmittance.G");
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) cloudy += img.at(x, y, t) < 0.5f;
    EXPECT_GT(cloudy, 10);
    EXPECT_TRUE(fs::exists(d / "tiny.0001.png"));
    // nothing else (no temp files) in the output folder
    int files = 0;
    for (auto& e : fs::directory_iterator(d)) files += e.is_regular_file();
    EXPECT_EQ(files, 3); // toml, exr, png
    fs::remove_all(d);
}

TEST(Cli, FrameSequenceOverridesAndResume) {
    fs::path d = tempDir("seq");
    writeFile(d / "s.toml", tinyScene(d));
    CliRun r = runNimbus("render " + (d / "s.toml").string() +
                         " --frames 2-6x2 --set render.step=0.1 --set camera.width=32 -q");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    for (int f : {2, 4, 6}) {
        char name[32];
        std::snprintf(name, sizeof name, "tiny.%04d.exr", f);
        ASSERT_TRUE(fs::exists(d / name)) << name;
        nimbus::io::ExrImage img = nimbus::io::readExr((d / name).string());
        EXPECT_EQ(img.width, 32);
        EXPECT_EQ(img.attributes["nimbus/settings/render.step"], "0.1");
        expectAllFinite(img);
    }
    EXPECT_FALSE(fs::exists(d / "tiny.0003.exr"));
    // the wind moves the clouds: frames 2 and 6 differ
    auto a = nimbus::io::readExr((d / "tiny.0002.exr").string());
    auto b = nimbus::io::readExr((d / "tiny.0006.exr").string());
    EXPECT_NE(a.pixels, b.pixels);
    // --resume skips complete frames and renders the missing one
    CliRun again = runNimbus(
        "render " + (d / "s.toml").string() +
        " --frames 2-8x2 --set render.step=0.1 --set camera.width=32 --resume --progress none");
    ASSERT_EQ(again.exitCode, 0) << again.output;
    EXPECT_NE(again.output.find("frame 2: "), std::string::npos);
    EXPECT_NE(again.output.find("skipped (--resume)"), std::string::npos) << again.output;
    EXPECT_TRUE(fs::exists(d / "tiny.0008.exr"));
    fs::remove_all(d);
}

TEST(Cli, TypoInSceneNamesFileAndLine) {
    fs::path d = tempDir("typo");
    writeFile(d / "bad1.toml", "[camera]\nfov = 45.0\nwidht = 64\n");
    CliRun r = runNimbus("render " + (d / "bad1.toml").string());
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_NE(r.output.find("bad1.toml:3:"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("widht"), std::string::npos) << r.output;
    // out of range, with the allowed range in the message
    writeFile(d / "bad2.toml", "[medium]\n\ng = 1.5\n");
    CliRun r2 = runNimbus("render " + (d / "bad2.toml").string());
    EXPECT_EQ(r2.exitCode, 2);
    EXPECT_NE(r2.output.find("bad2.toml:3:"), std::string::npos) << r2.output;
    // a bad override names the override
    writeFile(d / "ok.toml", tinyScene(d));
    CliRun r3 = runNimbus("render " + (d / "ok.toml").string() + " --set render.stepp=0.5");
    EXPECT_EQ(r3.exitCode, 2);
    EXPECT_NE(r3.output.find("render.stepp"), std::string::npos) << r3.output;
    // a missing file
    CliRun r4 = runNimbus("render " + (d / "missing.toml").string());
    EXPECT_NE(r4.exitCode, 0);
    EXPECT_NE(r4.output.find("missing.toml"), std::string::npos) << r4.output;
    // several frames into one file name
    CliRun r5 = runNimbus("render " + (d / "ok.toml").string() + " --frames 1-2 -o " +
                          (d / "x.exr").string());
    EXPECT_EQ(r5.exitCode, 2);
    EXPECT_NE(r5.output.find("frame token"), std::string::npos) << r5.output;
    EXPECT_FALSE(fs::exists(d / "tiny.0001.exr")); // nothing rendered on bad input
    fs::remove_all(d);
}

TEST(Cli, InterruptedRenderLeavesNoFile) {
    fs::path d = tempDir("interrupt");
    // slow on purpose: a very fine step at a larger size
    writeFile(d / "slow.toml", tinyScene(d));
    const int code = interruptNimbus("render " + (d / "slow.toml").string() +
                                     " --set render.step=0.002 --set render.shadow_step=0.005 "
                                     "--set camera.width=320 --set camera.height=180 --progress "
                                     "none");
    EXPECT_EQ(code, 130);
    EXPECT_FALSE(fs::exists(d / "tiny.0001.exr"));
    EXPECT_FALSE(fs::exists(d / "tiny.0001.png"));
    for (auto& e : fs::directory_iterator(d))
        EXPECT_EQ(e.path().extension(), ".toml") << "left behind: " << e.path();
    fs::remove_all(d);
}

TEST(Cli, ExplainPrintsThePlanWithoutRendering) {
    fs::path d = tempDir("explain");
    writeFile(d / "e.toml", tinyScene(d));
    CliRun r = runNimbus("render " + (d / "e.toml").string() + " --explain");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("field noise"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("empty-space skipping"), std::string::npos);
    EXPECT_FALSE(fs::exists(d / "tiny.0001.exr"));
    fs::remove_all(d);
}

TEST(Cli, ConvergeWritesTableAndCsv) {
    fs::path d = tempDir("converge");
    writeFile(d / "c.toml", tinyScene(d));
    CliRun r = runNimbus("converge " + (d / "c.toml").string() +
                         " --ladder 4,2,1 --reference-step 0.25 --csv " + (d / "c.csv").string() +
                         " --set camera.width=24 --set camera.height=14");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("rel. RMSE"), std::string::npos) << r.output;
    std::ifstream f(d / "c.csv");
    std::string line;
    std::vector<std::string> lines;
    while (std::getline(f, line)) lines.push_back(line);
    // header, three step rungs, and march with the other shadow method (volume)
    ASSERT_EQ(lines.size(), 5u);
    EXPECT_EQ(lines[4].rfind("march,shadow volume,", 0), 0u) << lines[4];
    auto column = [&](const std::string& l, int k) {
        size_t i = 0;
        for (int comma = 0; i < l.size() && comma < k; ++i) comma += l[i] == ',';
        return std::stod(l.substr(i));
    };
    // error falls as the step shrinks: rung x4 has a larger RMSE than rung x1
    EXPECT_GT(column(lines[1], 9), column(lines[3], 9));
    EXPECT_GT(column(lines[3], 9), 0.0);
    fs::remove_all(d);
}

TEST(Cli, ConvergeSavesAndReusesItsReference) {
    // the reference written by --save-reference, read back with --reference, gives the same
    // errors without rendering it again; a reference of another size or a foreign file is
    // refused with a message that names the file
    fs::path d = tempDir("converge-ref");
    writeFile(d / "c.toml", tinyScene(d));
    const std::string scene = (d / "c.toml").string();
    const std::string size = " --set camera.width=24 --set camera.height=14";
    const std::string ref = (d / "ref.exr").string();
    CliRun a = runNimbus("converge " + scene + " --ladder 2 --reference-spp 8 --save-reference " +
                         ref + " --csv " + (d / "a.csv").string() + size);
    ASSERT_EQ(a.exitCode, 0) << a.output;
    ASSERT_TRUE(fs::exists(ref));
    CliRun b = runNimbus("converge " + scene + " --ladder 2 --reference " + ref +
                         " --photon-ladder 2000 --csv " + (d / "b.csv").string() + size);
    ASSERT_EQ(b.exitCode, 0) << b.output;
    EXPECT_NE(b.output.find("read from"), std::string::npos) << b.output;
    auto lines = [](const fs::path& p) {
        std::ifstream f(p);
        std::vector<std::string> out;
        for (std::string l; std::getline(f, l);) out.push_back(l);
        return out;
    };
    auto errors = [](const std::string& l) { // rmse and relative columns, not the time
        size_t i = 0;
        for (int comma = 0; i < l.size() && comma < 9; ++i) comma += l[i] == ',';
        return l.substr(i);
    };
    const auto la = lines(d / "a.csv"), lb = lines(d / "b.csv");
    ASSERT_GE(la.size(), 2u);
    ASSERT_EQ(lb.size(), la.size() + 1) << "one photon rung more";
    EXPECT_EQ(errors(la[1]), errors(lb[1])) << la[1] << "\n" << lb[1];
    EXPECT_EQ(lb.back().rfind("march,photons 2000,", 0), 0u) << lb.back();

    CliRun c = runNimbus("converge " + scene + " --ladder 2 --reference " + ref +
                         " --set camera.width=20 --set camera.height=14");
    EXPECT_EQ(c.exitCode, 2) << c.output;
    EXPECT_NE(c.output.find("ref.exr"), std::string::npos) << c.output;
    EXPECT_NE(c.output.find("24x14"), std::string::npos) << c.output;
    writeFile(d / "junk.exr", "not an image");
    CliRun e = runNimbus("converge " + scene + " --ladder 2 --reference " +
                         (d / "junk.exr").string() + size);
    EXPECT_EQ(e.exitCode, 2) << e.output;
    EXPECT_NE(e.output.find("junk.exr"), std::string::npos) << e.output;
    fs::remove_all(d);
}
