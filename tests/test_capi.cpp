// The C ABI of libnimbus.so (plugin/capi/nimbus.h), called through the shared library only:
// its pixels equal the render session's (bit for bit), errors come back as codes with message,
// file and line and leave the context usable, overrides are checked as --set checks them, the
// written EXR equals the command's, progress and cancellation work, no exception ever leaves
// the library (every layer made to throw), two contexts render concurrently as they do one
// after the other, and only the baseline's nimbus_* symbols are exported under the soname
// libnimbus.so.<major>.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "plugin/capi/nimbus.h"
#include "plugin/host/session.h"
#include "tests/scenes.h"
#include "plugin/io/atomic_file.h"
#include "plugin/io/image_output.h"
#include "tests/test_util.h"

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

std::string tinyScene(const std::string& extra = "") {
    return tinySceneText(extra);
}

/// A context that is destroyed with the test.
struct Ctx {
    nimbus_context* c = nimbus_create();
    ~Ctx() { nimbus_destroy(c); }
    operator nimbus_context*() const { return c; }
    std::string error() const { return nimbus_last_error(c); }
};

/// Renders frame `frame` through the C ABI into a vector (RGBA).
std::vector<float> renderC(nimbus_context* c, int frame, nimbus_status* status = nullptr) {
    int w = 0, h = 0;
    EXPECT_EQ(nimbus_plan_int(c, frame, NIMBUS_PLAN_WIDTH, &w), NIMBUS_OK);
    EXPECT_EQ(nimbus_plan_int(c, frame, NIMBUS_PLAN_HEIGHT, &h), NIMBUS_OK);
    std::vector<float> rgba(size_t(w) * h * 4, -1.0f);
    const nimbus_status st = nimbus_render(c, frame, rgba.data(), rgba.size());
    if (status)
        *status = st;
    else
        EXPECT_EQ(st, NIMBUS_OK) << nimbus_last_error(c);
    return rgba;
}

/// The same frame through host::Session (the C++ layer the ABI wraps).
std::vector<float> renderSession(const std::string& text, int frame,
                                 const std::vector<std::string>& overrides = {},
                                 Framebuffer* out = nullptr) {
    host::Session s;
    host::Status st = s.loadString(text, "scene.toml", overrides);
    EXPECT_TRUE(st.ok()) << st.message;
    Framebuffer fb;
    RenderStats stats;
    st = s.render(frame, fb, stats);
    EXPECT_TRUE(st.ok()) << st.message;
    if (out) *out = fb;
    return fb.rgba;
}

bool bitIdentical(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

std::string run(const std::string& cmd) {
    std::string out;
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) return out;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
    pclose(p);
    return out;
}

} // namespace

// ---------------------------------------------------------------------------------------------
// versions and names

TEST(CApi, VersionIsTheProjectsAndTheHeaders) {
    EXPECT_STREQ(nimbus_version(), NIMBUS_VERSION);
    int major = -1, minor = -1, patch = -1;
    nimbus_version_numbers(&major, &minor, &patch);
    EXPECT_EQ(major, NIMBUS_VERSION_MAJOR);
    EXPECT_EQ(minor, NIMBUS_VERSION_MINOR);
    EXPECT_EQ(patch, NIMBUS_VERSION_PATCH);
    EXPECT_EQ(std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(patch),
              nimbus_version());
    nimbus_version_numbers(nullptr, nullptr, nullptr); // any pointer may be NULL
}

TEST(CApi, StatusesAreTheCommandsExitCodes) {
    EXPECT_EQ(int(NIMBUS_OK), host::exitCode(host::StatusCode::ok));
    EXPECT_EQ(int(NIMBUS_INTERNAL), host::exitCode(host::StatusCode::internal));
    EXPECT_EQ(int(NIMBUS_BAD_INPUT), host::exitCode(host::StatusCode::bad_input));
    EXPECT_EQ(int(NIMBUS_IO), host::exitCode(host::StatusCode::io));
    EXPECT_EQ(int(NIMBUS_NO_MEMORY), host::exitCode(host::StatusCode::no_memory));
    EXPECT_EQ(int(NIMBUS_INTERRUPTED), host::exitCode(host::StatusCode::interrupted));
    EXPECT_STREQ(nimbus_status_name(NIMBUS_BAD_INPUT), "bad input");
    EXPECT_STREQ(nimbus_status_name(NIMBUS_INTERRUPTED), "interrupted");
    EXPECT_STREQ(nimbus_status_name(nimbus_status(77)), "unknown status");
    EXPECT_EQ(nimbus_aov_channels(NIMBUS_AOV_RGBA), 4);
    EXPECT_EQ(nimbus_aov_channels(NIMBUS_AOV_TRANSMITTANCE), 3);
    EXPECT_EQ(nimbus_aov_channels(NIMBUS_AOV_DEPTH), 1);
    EXPECT_EQ(nimbus_aov_channels(9), 0);
}

// ---------------------------------------------------------------------------------------------
// rendering: the session's pixels

TEST(CApi, RenderEqualsTheSessionBitForBit) {
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "scene.toml"), NIMBUS_OK) << c.error();
    int count = 0, frames[4] = {0, 0, 0, 0};
    ASSERT_EQ(nimbus_frames(c, frames, 4, &count), NIMBUS_OK);
    ASSERT_EQ(count, 1);
    EXPECT_EQ(frames[0], 3);
    const std::vector<float> viaC = renderC(c, 3);
    const std::vector<float> viaSession = renderSession(tinyScene(), 3);
    ASSERT_EQ(viaC.size(), size_t(24 * 14 * 4));
    EXPECT_TRUE(bitIdentical(viaC, viaSession));
    double sum = 0.0;
    for (float v : viaC) {
        ASSERT_TRUE(std::isfinite(v));
        sum += v;
    }
    EXPECT_GT(sum, 0.0);
    // a second render of the same context (baked noise reused) gives the same pixels
    EXPECT_TRUE(bitIdentical(renderC(c, 3), viaC));
    EXPECT_STREQ(nimbus_warnings(c), "");
}

TEST(CApi, AovsEqualTheSessionsAndLeaveRgbaAlone) {
    const std::string scene = tinyScene("[output]\naovs = [\"transmittance\", \"depth\"]\n");
    Framebuffer fb;
    renderSession(scene, 3, {}, &fb);
    ASSERT_EQ(fb.depth.size(), size_t(24 * 14));
    Ctx c;
    // the scene without AOVs: asking for them computes them all the same
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "scene.toml"), NIMBUS_OK) << c.error();
    std::vector<float> rgba(24 * 14 * 4), tr(24 * 14 * 3), depth(24 * 14);
    const nimbus_buffer b[3] = {{NIMBUS_AOV_DEPTH, depth.data(), depth.size()},
                                {NIMBUS_AOV_RGBA, rgba.data(), rgba.size()},
                                {NIMBUS_AOV_TRANSMITTANCE, tr.data(), tr.size()}};
    ASSERT_EQ(nimbus_render_aovs(c, 3, b, 3), NIMBUS_OK) << c.error();
    EXPECT_TRUE(bitIdentical(rgba, fb.rgba));
    EXPECT_TRUE(bitIdentical(tr, fb.transmittance));
    EXPECT_TRUE(bitIdentical(depth, fb.depth));
    EXPECT_GT(*std::max_element(depth.begin(), depth.end()), 0.0f);
    // and RGBA alone from the scene with AOVs is the same RGBA
    Ctx d;
    ASSERT_EQ(nimbus_load_string(d, scene.c_str(), "scene.toml"), NIMBUS_OK) << d.error();
    int aovDepth = 0;
    ASSERT_EQ(nimbus_plan_int(d, 3, NIMBUS_PLAN_AOV_DEPTH, &aovDepth), NIMBUS_OK);
    EXPECT_EQ(aovDepth, 1);
    EXPECT_TRUE(bitIdentical(renderC(d, 3), fb.rgba));
    // a layer twice, or a layer unknown, is misuse
    const nimbus_buffer twice[2] = {{NIMBUS_AOV_DEPTH, depth.data(), depth.size()},
                                    {NIMBUS_AOV_DEPTH, depth.data(), depth.size()}};
    EXPECT_EQ(nimbus_render_aovs(c, 3, twice, 2), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "given twice"));
    const nimbus_buffer unknown = {7, depth.data(), depth.size()};
    EXPECT_EQ(nimbus_render_aovs(c, 3, &unknown, 1), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "unknown layer 7"));
}

TEST(CApi, PlanIsTheExplainedOne) {
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "scene.toml"), NIMBUS_OK) << c.error();
    host::Session s;
    ASSERT_TRUE(s.loadString(tinyScene(), "scene.toml").ok());
    const FramePlan p = s.plan(3);
    const char* explained = nimbus_plan_explain(c, 3);
    ASSERT_NE(explained, nullptr) << c.error();
    EXPECT_EQ(std::string(explained), p.explain());
    EXPECT_TRUE(contains(explained, "frame 3"));
    auto item = [&](nimbus_plan_item i) {
        int v = -1;
        EXPECT_EQ(nimbus_plan_int(c, 3, i, &v), NIMBUS_OK) << c.error();
        return v;
    };
    EXPECT_EQ(item(NIMBUS_PLAN_WIDTH), 24);
    EXPECT_EQ(item(NIMBUS_PLAN_HEIGHT), 14);
    EXPECT_EQ(item(NIMBUS_PLAN_INTEGRATOR), 0);
    EXPECT_EQ(item(NIMBUS_PLAN_SHADOWS), int(p.shadows));
    EXPECT_EQ(item(NIMBUS_PLAN_BAKE_NOISE), int(p.bakeNoise));
    EXPECT_EQ(item(NIMBUS_PLAN_VOLUMES), 1);
    EXPECT_EQ(item(NIMBUS_PLAN_READS_GRIDS), 0);
    EXPECT_EQ(item(NIMBUS_PLAN_REFUSED), 0);
    ASSERT_EQ(nimbus_set(c, "render.integrator=pathtrace"), NIMBUS_OK) << c.error();
    EXPECT_EQ(item(NIMBUS_PLAN_INTEGRATOR), 1);
    int v = 0;
    EXPECT_EQ(nimbus_plan_int(c, 3, nimbus_plan_item(99), &v), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "unknown plan item 99"));
    const char* out = nimbus_output_path(c, 12);
    ASSERT_NE(out, nullptr);
    EXPECT_EQ(std::string(out), "out/frame.0012.exr");
}

// ---------------------------------------------------------------------------------------------
// errors: codes, file, line, message; the context stays usable

TEST(CApi, BadSceneIsBadInputWithFileLineAndMessageAndTheContextStaysUsable) {
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "good.toml"), NIMBUS_OK) << c.error();
    const std::vector<float> before = renderC(c, 3);
    EXPECT_EQ(nimbus_load_string(c, "[camera]\nfov = 45.0\nwidht = 64\n", "bad.toml"),
              NIMBUS_BAD_INPUT);
    EXPECT_EQ(nimbus_last_error_code(c), NIMBUS_BAD_INPUT);
    EXPECT_STREQ(nimbus_last_error_file(c), "bad.toml");
    EXPECT_EQ(nimbus_last_error_line(c), 3);
    EXPECT_TRUE(contains(c.error(), "bad.toml:3:"));
    EXPECT_TRUE(contains(c.error(), "widht"));
    // the good scene is still loaded; a successful call clears the error
    EXPECT_TRUE(bitIdentical(renderC(c, 3), before));
    EXPECT_EQ(nimbus_last_error_code(c), NIMBUS_OK);
    EXPECT_STREQ(nimbus_last_error(c), "");
    // a file that is not there
    EXPECT_EQ(nimbus_load_file(c, "/nonexistent/cloud.toml"), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "/nonexistent/cloud.toml: cannot read scene file"));
    // misuse
    Ctx empty;
    std::vector<float> buf(16);
    EXPECT_EQ(nimbus_render(empty, 1, buf.data(), buf.size()), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(empty.error(), "no scene loaded"));
    EXPECT_EQ(nimbus_render(c, 3, buf.data(), buf.size()), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "16 floats, the frame needs 1344 (24 x 14 x 4)"));
    EXPECT_EQ(nimbus_render(c, 3, nullptr, 1344), NIMBUS_BAD_INPUT);
    EXPECT_EQ(nimbus_load_file(c, nullptr), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "path is NULL"));
    EXPECT_EQ(nimbus_load_file(nullptr, "x.toml"), NIMBUS_BAD_INPUT);
    EXPECT_EQ(nimbus_last_error_code(nullptr), NIMBUS_BAD_INPUT);
    EXPECT_STREQ(nimbus_last_error(nullptr), "");
    nimbus_destroy(nullptr);
}

TEST(CApi, OverridesAreCheckedLikeSet) {
    const std::string scene = tinyScene();
    TempDir dir("capi");
    const std::string path = (dir / "scene.toml").string();
    writeText(path, scene);
    Ctx c;
    ASSERT_EQ(nimbus_load_file(c, path.c_str()), NIMBUS_OK) << c.error();
    // an unknown key: the message the command prints for the same --set
    EXPECT_EQ(nimbus_set(c, "render.stepp=0.5"), NIMBUS_BAD_INPUT);
    const std::string message = c.error();
    EXPECT_EQ(nimbus_last_error_line(c), 0);
    EXPECT_TRUE(contains(message, "--set render.stepp=0.5"));
    const CliRun cli = runNimbus("render " + path + " --set render.stepp=0.5");
    EXPECT_EQ(cli.exitCode, 2);
    EXPECT_TRUE(contains(cli.output, "nimbus: error: " + message));
    // out of range, not TOML, no '='
    EXPECT_EQ(nimbus_set(c, "camera.width=0"), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "camera.width"));
    EXPECT_EQ(nimbus_set(c, "camera.fov=[1,"), NIMBUS_BAD_INPUT);
    EXPECT_EQ(nimbus_set(c, "camera.fov"), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "expected section.key=value"));
    // refused overrides were not kept: good ones apply and equal the session's --set
    ASSERT_EQ(nimbus_set(c, "camera.width=32"), NIMBUS_OK) << c.error();
    ASSERT_EQ(nimbus_set(c, "sun.elevation=30"), NIMBUS_OK) << c.error();
    int w = 0;
    ASSERT_EQ(nimbus_plan_int(c, 3, NIMBUS_PLAN_WIDTH, &w), NIMBUS_OK);
    EXPECT_EQ(w, 32);
    EXPECT_TRUE(bitIdentical(renderC(c, 3),
                             renderSession(scene, 3, {"camera.width=32", "sun.elevation=30"})));
    // they survive a new load, and clearing them restores the file's values
    ASSERT_EQ(nimbus_load_string(c, scene.c_str(), "again.toml"), NIMBUS_OK) << c.error();
    ASSERT_EQ(nimbus_plan_int(c, 3, NIMBUS_PLAN_WIDTH, &w), NIMBUS_OK);
    EXPECT_EQ(w, 32);
    ASSERT_EQ(nimbus_clear_overrides(c), NIMBUS_OK);
    ASSERT_EQ(nimbus_plan_int(c, 3, NIMBUS_PLAN_WIDTH, &w), NIMBUS_OK);
    EXPECT_EQ(w, 24);
    // without a scene, an override is checked against the default scene and kept for the load
    Ctx fresh;
    EXPECT_EQ(nimbus_set(fresh, "camera.widht=40"), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(fresh.error(), "did you mean \"width\""));
    ASSERT_EQ(nimbus_set(fresh, "camera.width=40"), NIMBUS_OK) << fresh.error();
    ASSERT_EQ(nimbus_load_string(fresh, scene.c_str(), "scene.toml"), NIMBUS_OK);
    ASSERT_EQ(nimbus_plan_int(fresh, 3, NIMBUS_PLAN_WIDTH, &w), NIMBUS_OK);
    EXPECT_EQ(w, 40);
}

TEST(CApi, RenderWriteGivesTheCommandsExr) {
    TempDir dir("capi");
    const std::string path = (dir / "scene.toml").string();
    // output paths are taken from the working directory (as the command takes them)
    const std::string cliOut = (dir / "cli.####.exr").string();
    writeText(path, tinyScene("[output]\npath = \"" + cliOut + "\"\naovs = [\"depth\"]\n"));
    const CliRun cli = runNimbus("render " + path + " --quiet");
    ASSERT_EQ(cli.exitCode, 0) << cli.output;
    Ctx c;
    ASSERT_EQ(nimbus_load_file(c, path.c_str()), NIMBUS_OK) << c.error();
    const std::string out = (dir / "capi.exr").string();
    ASSERT_EQ(nimbus_render_write(c, 3, out.c_str()), NIMBUS_OK) << c.error();
    const io::ExrImage a = io::readExr(out); // through OpenImageIO
    const io::ExrImage b = io::readExr((dir / "cli.0003.exr").string());
    EXPECT_EQ(a.width, 24);
    EXPECT_EQ(a.height, 14);
    EXPECT_EQ(a.channels, b.channels);
    EXPECT_GE(a.channelIndex("depth"), 0);
    EXPECT_TRUE(bitIdentical(a.pixels, b.pixels));
    EXPECT_EQ(a.attributes.at("nimbus/frame"), "3");
    EXPECT_EQ(a.attributes.at("nimbus/settings/plan"), b.attributes.at("nimbus/settings/plan"));
    EXPECT_EQ(a.attributes.at("nimbus/settings/scene_file"),
              b.attributes.at("nimbus/settings/scene_file"));
    // a NULL path writes where the scene says
    const char* where = nimbus_output_path(c, 3);
    ASSERT_NE(where, nullptr);
    EXPECT_EQ(std::string(where), (dir / "cli.0003.exr").string());
    fs::remove(where);
    ASSERT_EQ(nimbus_render_write(c, 3, nullptr), NIMBUS_OK) << c.error();
    EXPECT_TRUE(bitIdentical(io::readExr((dir / "cli.0003.exr").string()).pixels, b.pixels));
    // not .exr: refused before rendering
    EXPECT_EQ(nimbus_render_write(c, 3, (dir / "x.png").string().c_str()), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "must end in .exr"));
}

// ---------------------------------------------------------------------------------------------
// what a host of frame sequences needs (the `nimbus render` command is one)

// One load with overrides (replacing the context's), threads and an output pattern that are not
// overrides, and the scene's strings; the scene hash changes with the text and with an override
// that may change pixels, not with threads or the output pattern.
TEST(CApi, LoadWithOverridesThreadsOutputAndSceneStrings) {
    TempDir dir("capi");
    const std::string path = (dir / "scene.toml").string();
    writeText(path, tinyScene("[output]\npath = \"" + (dir / "a.####.exr").string() +
                              "\"\npreview = \"p.####.png\"\n"));
    Ctx c;
    const char* widen[] = {"camera.width=30", "render.step=0.3"};
    ASSERT_EQ(nimbus_load_file_with(c, path.c_str(), widen, 2), NIMBUS_OK) << c.error();
    int w = 0;
    ASSERT_EQ(nimbus_plan_int(c, 3, NIMBUS_PLAN_WIDTH, &w), NIMBUS_OK);
    EXPECT_EQ(w, 30);
    EXPECT_EQ(std::string(nimbus_scene_string(c, NIMBUS_SCENE_PATH)), path);
    EXPECT_EQ(std::string(nimbus_scene_string(c, NIMBUS_SCENE_FRAMES)), "3");
    EXPECT_EQ(std::string(nimbus_scene_string(c, NIMBUS_SCENE_PREVIEW_PATTERN)), "p.####.png");
    EXPECT_EQ(std::string(nimbus_scene_string(c, NIMBUS_SCENE_OUTPUT_SPACE)), "ACEScg");
    EXPECT_FALSE(std::string(nimbus_scene_string(c, NIMBUS_SCENE_WORKING_SPACE)).empty());
    EXPECT_FALSE(std::string(nimbus_scene_string(c, NIMBUS_SCENE_COLOR_CONFIG)).empty());
    const std::string hash = nimbus_scene_string(c, NIMBUS_SCENE_HASH);
    EXPECT_EQ(hash.size(), 16u);
    EXPECT_EQ(hash.find_first_not_of("0123456789abcdef"), std::string::npos) << hash;
    // threads and the output pattern are not overrides: same hash, same overrides
    ASSERT_EQ(nimbus_set_threads(c, 1), NIMBUS_OK) << c.error();
    ASSERT_EQ(nimbus_set_output(c, (dir / "b.####.exr").string().c_str()), NIMBUS_OK);
    EXPECT_EQ(std::string(nimbus_scene_string(c, NIMBUS_SCENE_HASH)), hash);
    EXPECT_EQ(std::string(nimbus_output_path(c, 3)), (dir / "b.0003.exr").string());
    EXPECT_EQ(nimbus_set_output(c, "b.png"), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "must end in .exr"));
    // pixel-neutral overrides leave the hash alone; the same overrides give the same hash
    const char* neutral[] = {"camera.width=30", "render.step=0.3", "render.threads=1",
                             "output.preview=\"q.####.png\""};
    ASSERT_EQ(nimbus_load_file_with(c, path.c_str(), neutral, 4), NIMBUS_OK) << c.error();
    EXPECT_EQ(std::string(nimbus_scene_string(c, NIMBUS_SCENE_HASH)), hash);
    // the output pattern survives a load
    EXPECT_EQ(std::string(nimbus_output_path(c, 3)), (dir / "b.0003.exr").string());
    ASSERT_EQ(nimbus_set_output(c, nullptr), NIMBUS_OK) << c.error();
    EXPECT_EQ(std::string(nimbus_output_path(c, 3)), (dir / "a.0003.exr").string());
    // an override that changes pixels changes it; so does the text
    ASSERT_EQ(nimbus_set(c, "sun.intensity=3.0"), NIMBUS_OK) << c.error();
    EXPECT_NE(std::string(nimbus_scene_string(c, NIMBUS_SCENE_HASH)), hash);
    ASSERT_EQ(nimbus_load_file_with(c, path.c_str(), widen, 2), NIMBUS_OK);
    EXPECT_EQ(std::string(nimbus_scene_string(c, NIMBUS_SCENE_HASH)), hash);
    writeText(path, tinyScene("# an edit\n"));
    ASSERT_EQ(nimbus_load_file_with(c, path.c_str(), widen, 2), NIMBUS_OK);
    EXPECT_NE(std::string(nimbus_scene_string(c, NIMBUS_SCENE_HASH)), hash);
    // a bad override: refused with its message, the scene and its overrides stay
    const char* bad[] = {"camera.widht=3"};
    EXPECT_EQ(nimbus_load_file_with(c, path.c_str(), bad, 1), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "camera.widht"));
    ASSERT_EQ(nimbus_plan_int(c, 3, NIMBUS_PLAN_WIDTH, &w), NIMBUS_OK);
    EXPECT_EQ(w, 30);
    EXPECT_EQ(nimbus_load_file_with(c, path.c_str(), nullptr, 1), NIMBUS_BAD_INPUT);
    EXPECT_EQ(nimbus_set_threads(c, -2), NIMBUS_BAD_INPUT);
}

// The photon counts of the last render: none with the grid; with photons from the sun and the
// sky (render.photon_sky) handing off to the grid (render.photon_bounces) each count is there.
TEST(CApi, PhotonStatistics) {
    TempDir dir("capi_photons");
    const std::string path = (dir / "scene.toml").string();
    writeText(path, tinyScene());
    Ctx c;
    ASSERT_EQ(nimbus_load_file(c, path.c_str()), NIMBUS_OK) << c.error();
    renderC(c, 3);
    double traced = -1.0, sky = -1.0, handed = -1.0, scatterings = -1.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTONS, &traced), NIMBUS_OK);
    EXPECT_EQ(traced, 0.0);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTON_SCATTERINGS, &scatterings), NIMBUS_OK);
    EXPECT_EQ(scatterings, 0.0);
    for (const char* a :
         {"render.multiple_scattering=\"photons\"", "render.photons=20000",
          "render.photon_sky=true", "render.photon_bounces=2", "render.max_depth=64"})
        ASSERT_EQ(nimbus_set(c, a), NIMBUS_OK) << a << ": " << c.error();
    renderC(c, 3);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTONS, &traced), NIMBUS_OK);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTONS_FROM_SKY, &sky), NIMBUS_OK);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTONS_HANDED_OFF, &handed), NIMBUS_OK);
    // the sun and the sky share render.photons
    EXPECT_GT(traced, 15000.0);
    EXPECT_LE(traced, 20000.0);
    EXPECT_GT(sky, 0.0);
    EXPECT_LT(sky, traced);
    EXPECT_GT(handed, 0.0);
    EXPECT_LE(handed, traced);
    // every photon handed to the grid scattered three times first (render.photon_bounces 2)
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTON_SCATTERINGS, &scatterings), NIMBUS_OK);
    EXPECT_GE(scatterings, 3.0 * handed);
}

/// The number in `--explain`'s "(12.3 MB)" / "(at most 12.3 MB)" after `after` on the line
/// that holds it; -1 when there is none.
double explainedMb(const std::string& text, const std::string& line, const std::string& after) {
    const size_t l = text.find(line);
    if (l == std::string::npos) return -1.0;
    const std::string row = text.substr(l, text.find('\n', l) - l);
    const size_t a = row.find(after);
    if (a == std::string::npos) return -1.0;
    const size_t mb = row.find(" MB)", a);
    if (mb == std::string::npos) return -1.0;
    const size_t open = row.rfind('(', mb);
    if (open == std::string::npos || open < a) return -1.0;
    std::string num = row.substr(open + 1, mb - open - 1);
    if (num.rfind("at most ", 0) == 0) num = num.substr(8);
    return std::stod(num);
}

// NIMBUS_STAT_DIFFUSION_MB and NIMBUS_STAT_PHOTON_MB: what the frame's solve and photon pass
// held, the figures the plan's explanation estimates (closely where the plan measured the
// cloud, for the grid's cell; an upper bound where the scene names the cell); 0 for a part the
// frame did not run.
TEST(CApi, MemoryStatistics) {
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "tiny.toml"), NIMBUS_OK) << c.error();
    renderC(c, 3);
    double diffusion = -1.0, photons = -1.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_DIFFUSION_MB, &diffusion), NIMBUS_OK);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTON_MB, &photons), NIMBUS_OK);
    EXPECT_EQ(photons, 0.0);
    ASSERT_GT(diffusion, 0.0);
    const std::string measured = nimbus_plan_explain(c, 3);
    const double estimate = explainedMb(measured, "multiple scattering:", "grid");
    ASSERT_GT(estimate, 0.0) << measured;
    EXPECT_NEAR(diffusion / estimate, 1.0, 0.1) << measured;

    // a grid of half the cell holds about eight times the voxels
    ASSERT_EQ(nimbus_set(c, "render.light_volume_cell=1.0"), NIMBUS_OK) << c.error();
    renderC(c, 3);
    double coarse = -1.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_DIFFUSION_MB, &coarse), NIMBUS_OK);
    // a named cell: the cloud not measured, every voxel counted
    const std::string named = nimbus_plan_explain(c, 3);
    const double atMost = explainedMb(named, "multiple scattering:", "grid");
    ASSERT_GT(atMost, 0.0) << named;
    EXPECT_NE(named.find("(at most "), std::string::npos) << named;
    EXPECT_LE(coarse, atMost + 0.05) << named;
    ASSERT_EQ(nimbus_set(c, "render.light_volume_cell=0.5"), NIMBUS_OK) << c.error();
    renderC(c, 3);
    double fine = -1.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_DIFFUSION_MB, &fine), NIMBUS_OK);
    ASSERT_GT(coarse, 0.0);
    EXPECT_GT(fine / coarse, 5.0) << coarse << " MB -> " << fine << " MB";
    EXPECT_LT(fine / coarse, 9.0) << coarse << " MB -> " << fine << " MB";

    // photons: their voxels counted, the grid's sky solve too
    for (const char* a : {"render.light_volume_cell=1.0", "render.multiple_scattering=\"photons\"",
                          "render.photons=20000"})
        ASSERT_EQ(nimbus_set(c, a), NIMBUS_OK) << a << ": " << c.error();
    renderC(c, 3);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTON_MB, &photons), NIMBUS_OK);
    ASSERT_GT(photons, 0.0);
    const double explained =
        explainedMb(nimbus_plan_explain(c, 3), "multiple scattering:", "photons");
    ASSERT_GT(explained, 0.0) << nimbus_plan_explain(c, 3);
    EXPECT_NEAR(photons, explained, 0.05 + 0.02 * explained);
}

// NIMBUS_STAT_CLOUD_DEPTH: the depth along the sun that render.multiple_scattering = "auto"
// chose by, -1 when the scene names its model (the tiny scene names the grid).
TEST(CApi, CloudDepthStatistic) {
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "tiny.toml"), NIMBUS_OK) << c.error();
    renderC(c, 3);
    double depth = 0.0, photons = -1.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_CLOUD_DEPTH, &depth), NIMBUS_OK);
    EXPECT_EQ(depth, -1.0);
    for (const char* a : {"render.multiple_scattering=\"auto\"", "render.photons=20000"})
        ASSERT_EQ(nimbus_set(c, a), NIMBUS_OK) << a << ": " << c.error();
    renderC(c, 3);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_CLOUD_DEPTH, &depth), NIMBUS_OK);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTONS, &photons), NIMBUS_OK);
    // the cumulus layer at sigma_s 12 under a low sun: medium, so photons
    EXPECT_GT(depth, 1.0);
    EXPECT_LT(depth, 64.0);
    EXPECT_EQ(photons, 20000.0);
    ASSERT_EQ(nimbus_set(c, "render.photon_depth=1"), NIMBUS_OK) << c.error();
    renderC(c, 3);
    double again = 0.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_CLOUD_DEPTH, &again), NIMBUS_OK);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTONS, &photons), NIMBUS_OK);
    EXPECT_EQ(again, depth); // the same cloud, now above the threshold: the grid
    EXPECT_EQ(photons, 0.0);
    // NIMBUS_STAT_ABSORPTION_DEPTH: -1 where the medium does not absorb; at albedo 12 / 13.2 and
    // g 0.5 the diffuse light reaches 1 / sqrt(3 (1 - a)(1 - a g)) = 2.59 mean free paths, less
    // than the cloud's depth: "auto" compares that with render.photon_depth instead
    double reach = 0.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_ABSORPTION_DEPTH, &reach), NIMBUS_OK);
    EXPECT_EQ(reach, -1.0);
    ASSERT_EQ(nimbus_set(c, "medium.sigma_a=1.2"), NIMBUS_OK) << c.error();
    ASSERT_EQ(nimbus_set(c, "render.photon_depth=3"), NIMBUS_OK) << c.error();
    renderC(c, 3);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_ABSORPTION_DEPTH, &reach), NIMBUS_OK);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_PHOTONS, &photons), NIMBUS_OK);
    const double a = 12.0 / 13.2;
    EXPECT_NEAR(reach, 1.0 / std::sqrt(3.0 * (1.0 - a) * (1.0 - 0.5 * a)), 1e-4);
    EXPECT_GT(photons, 0.0); // 2.59 <= 3, though the cloud is deeper than 3
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_CLOUD_DEPTH, &again), NIMBUS_OK);
    EXPECT_GT(again, 3.0);
}

// nimbus_output_check: absent, current after a write, stale (with the reason) after an edit of
// the scene, for another frame number, another resolution; the statistics of the last render.
TEST(CApi, OutputCheckAndRenderStatistics) {
    TempDir dir("capi");
    const std::string path = (dir / "scene.toml").string();
    writeText(path, tinyScene("[output]\npath = \"" + (dir / "f.####.exr").string() + "\"\n"));
    Ctx c;
    ASSERT_EQ(nimbus_load_file(c, path.c_str()), NIMBUS_OK) << c.error();
    int state = -1;
    const char* why = nullptr;
    ASSERT_EQ(nimbus_output_check(c, 3, nullptr, &state, &why), NIMBUS_OK) << c.error();
    EXPECT_EQ(state, NIMBUS_OUTPUT_ABSENT);
    double seconds = -1.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_SECONDS, &seconds), NIMBUS_OK);
    EXPECT_EQ(seconds, 0.0); // no render yet
    ASSERT_EQ(nimbus_prepare(c, 3), NIMBUS_OK) << c.error();
    ASSERT_EQ(nimbus_render_write(c, 3, nullptr), NIMBUS_OK) << c.error();
    double lookups = 0.0;
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_SECONDS, &seconds), NIMBUS_OK);
    ASSERT_EQ(nimbus_render_stat(c, NIMBUS_STAT_LOOKUPS, &lookups), NIMBUS_OK);
    EXPECT_GT(seconds, 0.0);
    EXPECT_GT(lookups, 0.0);
    EXPECT_EQ(nimbus_render_stat(c, nimbus_stat(99), &seconds), NIMBUS_BAD_INPUT);
    const std::string out = nimbus_output_path(c, 3);
    EXPECT_EQ(io::readExr(out).attributes.at("nimbus/sceneHash"),
              std::string(nimbus_scene_string(c, NIMBUS_SCENE_HASH)));
    ASSERT_EQ(nimbus_output_check(c, 3, nullptr, &state, &why), NIMBUS_OK);
    EXPECT_EQ(state, NIMBUS_OUTPUT_CURRENT);
    EXPECT_STREQ(why, "");
    // another frame's file
    ASSERT_EQ(nimbus_output_check(c, 4, out.c_str(), &state, &why), NIMBUS_OK);
    EXPECT_EQ(state, NIMBUS_OUTPUT_STALE);
    EXPECT_TRUE(contains(why, "it is frame 3, not 4"));
    // another resolution
    ASSERT_EQ(nimbus_set(c, "camera.width=12"), NIMBUS_OK);
    ASSERT_EQ(nimbus_output_check(c, 3, nullptr, &state, &why), NIMBUS_OK);
    EXPECT_EQ(state, NIMBUS_OUTPUT_STALE);
    EXPECT_TRUE(contains(why, "it is 24x14, not 12x14"));
    ASSERT_EQ(nimbus_clear_overrides(c), NIMBUS_OK);
    // the scene edited
    writeText(path,
              tinyScene("[output]\npath = \"" + (dir / "f.####.exr").string() + "\"\n# edited\n"));
    ASSERT_EQ(nimbus_load_file(c, path.c_str()), NIMBUS_OK) << c.error();
    ASSERT_EQ(nimbus_output_check(c, 3, nullptr, &state, &why), NIMBUS_OK);
    EXPECT_EQ(state, NIMBUS_OUTPUT_STALE);
    EXPECT_TRUE(contains(why, "rendered from another scene text or other settings"));
    // not an EXR at all
    writeText(out, "not an image");
    ASSERT_EQ(nimbus_output_check(c, 3, nullptr, &state, &why), NIMBUS_OK);
    EXPECT_EQ(state, NIMBUS_OUTPUT_STALE);
    EXPECT_TRUE(contains(why, "cannot be read"));
    EXPECT_EQ(nimbus_output_check(c, 3, nullptr, nullptr, &why), NIMBUS_BAD_INPUT);
}

// Plan warnings by index, and their misuse.
TEST(CApi, PlanWarningsByIndex) {
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "scene.toml"), NIMBUS_OK) << c.error();
    ASSERT_EQ(nimbus_set(c, "render.step=1e-9"), NIMBUS_OK) << c.error();
    ASSERT_EQ(nimbus_set(c, "render.step_growth=0"), NIMBUS_OK) << c.error();
    int n = 0;
    ASSERT_EQ(nimbus_plan_int(c, 3, NIMBUS_PLAN_WARNINGS, &n), NIMBUS_OK);
    ASSERT_GE(n, 1);
    for (int i = 0; i < n; ++i) {
        const char* w = nimbus_plan_warning(c, 3, i);
        ASSERT_NE(w, nullptr) << c.error();
        EXPECT_GT(std::strlen(w), 10u);
    }
    EXPECT_EQ(nimbus_plan_warning(c, 3, n), nullptr);
    EXPECT_EQ(nimbus_last_error_code(c), NIMBUS_BAD_INPUT);
    int stale = -1;
    const int frames[] = {3};
    EXPECT_EQ(nimbus_remove_stale_temp_files(c, frames, 1, &stale), NIMBUS_OK) << c.error();
    EXPECT_EQ(stale, 0);
    EXPECT_EQ(nimbus_remove_stale_temp_files(c, nullptr, 1, &stale), NIMBUS_BAD_INPUT);
}

// ---------------------------------------------------------------------------------------------
// progress and cancellation

namespace {

struct Progress {
    std::atomic<int> calls{0}, total{0}, cancelAt{-1}, callsAfterCancel{0};
    std::atomic<bool> cancelled{false};
};

int onProgress(void* user, int done, int total) {
    auto* p = static_cast<Progress*>(user);
    if (p->cancelled) ++p->callsAfterCancel;
    ++p->calls;
    p->total = total;
    if (done < 1 || done > total) return 0;
    if (p->cancelAt >= 0 && done >= p->cancelAt) {
        p->cancelled = true;
        return 1;
    }
    return 0;
}

} // namespace

TEST(CApi, ProgressIsReportedAndCancellingFromItInterrupts) {
    Ctx c;
    // many small tiles
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "scene.toml"), NIMBUS_OK);
    ASSERT_EQ(nimbus_set(c, "camera.width=96"), NIMBUS_OK);
    ASSERT_EQ(nimbus_set(c, "camera.height=64"), NIMBUS_OK);
    ASSERT_EQ(nimbus_set(c, "render.tile_size=4"), NIMBUS_OK) << c.error();
    Progress p;
    ASSERT_EQ(nimbus_set_progress(c, onProgress, &p), NIMBUS_OK);
    const std::vector<float> full = renderC(c, 3);
    EXPECT_EQ(p.total, 24 * 16);
    EXPECT_EQ(p.calls, p.total);

    Progress q;
    q.cancelAt = 5;
    ASSERT_EQ(nimbus_set_progress(c, onProgress, &q), NIMBUS_OK);
    nimbus_status st = NIMBUS_OK;
    renderC(c, 3, &st);
    EXPECT_EQ(st, NIMBUS_INTERRUPTED);
    EXPECT_EQ(nimbus_last_error_code(c), NIMBUS_INTERRUPTED);
    EXPECT_TRUE(contains(c.error(), "interrupted during frame 3"));
    EXPECT_TRUE(q.cancelled);
    // promptly: the render stopped far short of its 384 tiles (the tiles in flight finish)
    EXPECT_LT(q.calls, 5 + 16) << "tiles reported after the cancel: " << q.callsAfterCancel;

    // the next render starts uncancelled and gives the whole frame again
    ASSERT_EQ(nimbus_set_progress(c, nullptr, nullptr), NIMBUS_OK);
    EXPECT_TRUE(bitIdentical(renderC(c, 3), full));
}

TEST(CApi, CancelFromAnotherThreadInterrupts) {
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "scene.toml"), NIMBUS_OK);
    ASSERT_EQ(nimbus_set(c, "camera.width=96"), NIMBUS_OK);
    ASSERT_EQ(nimbus_set(c, "camera.height=64"), NIMBUS_OK);
    ASSERT_EQ(nimbus_set(c, "render.tile_size=4"), NIMBUS_OK);
    Progress p; // counts only
    ASSERT_EQ(nimbus_set_progress(c, onProgress, &p), NIMBUS_OK);
    std::thread canceller([&] {
        while (p.calls < 3) std::this_thread::yield();
        EXPECT_EQ(nimbus_cancel(c), NIMBUS_OK);
    });
    nimbus_status st = NIMBUS_OK;
    renderC(c, 3, &st);
    canceller.join();
    EXPECT_EQ(st, NIMBUS_INTERRUPTED) << c.error();
    EXPECT_LT(p.calls, p.total);
    EXPECT_EQ(nimbus_cancel(nullptr), NIMBUS_BAD_INPUT);
}

// ---------------------------------------------------------------------------------------------
// no exception crosses the ABI: every layer made to throw, through the C calls only (an
// exception escaping would terminate the test process, which ctest reports as a failure)

namespace {

/// Sets an environment variable for the scope.
struct Env {
    std::string name;
    Env(const char* n, const char* v) : name(n) { ::setenv(n, v, 1); }
    ~Env() { ::unsetenv(name.c_str()); }
};

} // namespace

TEST(CApi, EveryLayerThatThrowsGivesAStatusNotAnException) {
    TempDir dir("capi");
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "scene.toml"), NIMBUS_OK);
    const std::vector<float> good = renderC(c, 3);

    // the TOML parser
    EXPECT_EQ(nimbus_load_string(c, "[camera\nfov = ", "broken.toml"), NIMBUS_BAD_INPUT);
    EXPECT_TRUE(contains(c.error(), "TOML syntax error"));
    EXPECT_EQ(nimbus_last_error_line(c), 1);
    // the colour configuration (OCIO)
    {
        Env ocio("OCIO", "/nonexistent/config.ocio");
        Ctx o;
        EXPECT_EQ(nimbus_load_string(o, tinyScene().c_str(), "scene.toml"), NIMBUS_BAD_INPUT);
        EXPECT_TRUE(contains(o.error(), "colour configuration"));
    }
    // the VDB reader: a missing file, and a file that is not a VDB
    {
        const std::string vdbScene = (dir / "vdb.toml").string();
        writeText((dir / "garbage.vdb").string(), std::string(4096, 'x'));
        Ctx v;
        for (const char* file : {"nowhere.vdb", "garbage.vdb"}) {
            ASSERT_EQ(nimbus_load_string(v,
                                         (std::string("[field]\nkind = \"vdb\"\npath = \"") + file +
                                          "\"\n[camera]\nwidth = 8\nheight = 8\n")
                                             .c_str(),
                                         vdbScene.c_str()),
                      NIMBUS_OK)
                << v.error();
            std::vector<float> buf(8 * 8 * 4);
            EXPECT_EQ(nimbus_render(v, 1, buf.data(), buf.size()), NIMBUS_BAD_INPUT) << file;
            EXPECT_STREQ(nimbus_last_error_file(v), vdbScene.c_str());
            EXPECT_TRUE(contains(v.error(), file));
            EXPECT_TRUE(contains(v.error(), "frame 1"));
        }
    }
    // Embree geometry: a mesh that is not there
    {
        Ctx m;
        EXPECT_EQ(nimbus_load_string(m, tinyScene("[[mesh]]\npath = \"nowhere.obj\"\n").c_str(),
                                     (dir / "mesh.toml").string().c_str()),
                  NIMBUS_BAD_INPUT);
        EXPECT_TRUE(contains(m.error(), "nowhere.obj"));
    }
    // the EXR writer: a folder where a file is
    {
        writeText((dir / "file").string(), "x");
        const std::string out = (dir / "file" / "frame.exr").string();
        EXPECT_EQ(nimbus_render_write(c, 3, out.c_str()), NIMBUS_IO);
        EXPECT_TRUE(contains(c.error(), "frame 3"));
        EXPECT_FALSE(fs::exists(out));
    }
    // the render workers: an int, std::bad_alloc and a std::runtime_error thrown on them
    {
        Env fault("NIMBUS_TEST_FAULT", "worker");
        nimbus_status st = NIMBUS_OK;
        renderC(c, 3, &st);
        EXPECT_EQ(st, NIMBUS_INTERNAL);
        EXPECT_TRUE(contains(c.error(), "not a std::exception"));
    }
    {
        Env fault("NIMBUS_TEST_FAULT", "bad-alloc");
        nimbus_status st = NIMBUS_OK;
        renderC(c, 3, &st);
        EXPECT_EQ(st, NIMBUS_NO_MEMORY);
        EXPECT_TRUE(contains(c.error(), "out of memory"));
    }
    {
        Env fault("NIMBUS_TEST_FAULT", "std");
        nimbus_status st = NIMBUS_OK;
        renderC(c, 3, &st);
        EXPECT_EQ(st, NIMBUS_INTERNAL);
        EXPECT_TRUE(contains(c.error(), "test fault in a worker"));
        EXPECT_EQ(nimbus_render_write(c, 3, (dir / "f.exr").string().c_str()), NIMBUS_INTERNAL);
        EXPECT_FALSE(fs::exists(dir / "f.exr"));
    }
    // a refused frame (a grid past its cell limit)
    {
        Ctx r;
        ASSERT_EQ(nimbus_load_string(r, tinyScene().c_str(), "scene.toml"), NIMBUS_OK);
        ASSERT_EQ(nimbus_set(r, "render.majorant_cell=0.0001"), NIMBUS_OK) << r.error();
        int refused = 0;
        ASSERT_EQ(nimbus_plan_int(r, 3, NIMBUS_PLAN_REFUSED, &refused), NIMBUS_OK);
        EXPECT_EQ(refused, 1);
        nimbus_status st = NIMBUS_OK;
        renderC(r, 3, &st);
        EXPECT_EQ(st, NIMBUS_BAD_INPUT);
        EXPECT_TRUE(contains(r.error(), "frame 3"));
    }
    // after all that, the context renders the same pixels as before
    EXPECT_TRUE(bitIdentical(renderC(c, 3), good));
}

// ---------------------------------------------------------------------------------------------
// threads

TEST(CApi, TwoContextsRenderingAtOnceGiveTheImagesOfOneAfterTheOther) {
    // two different scenes (one pathtraced), big enough for the renders to overlap
    const std::string a = tinyScene();
    const std::string b = tinyScene("integrator = \"pathtrace\"\nspp = 2\n");
    auto setup = [](nimbus_context* c, const std::string& text) {
        EXPECT_EQ(nimbus_load_string(c, text.c_str(), "scene.toml"), NIMBUS_OK)
            << nimbus_last_error(c);
        EXPECT_EQ(nimbus_set(c, "camera.width=64"), NIMBUS_OK);
        EXPECT_EQ(nimbus_set(c, "camera.height=40"), NIMBUS_OK);
    };
    std::vector<float> seqA, seqB;
    {
        Ctx ca, cb;
        setup(ca, a);
        setup(cb, b);
        seqA = renderC(ca, 3);
        seqB = renderC(cb, 3);
    }
    ASSERT_FALSE(bitIdentical(seqA, seqB));
    for (int round = 0; round < 2; ++round) {
        std::vector<float> parA, parB;
        std::atomic<int> ready{0};
        auto work = [&](const std::string& text, std::vector<float>& out) {
            Ctx c; // created, loaded, rendered and destroyed on this thread
            setup(c, text);
            ++ready;
            while (ready < 2) std::this_thread::yield(); // start rendering together
            out = renderC(c, 3);
        };
        std::thread ta(work, std::cref(a), std::ref(parA));
        std::thread tb(work, std::cref(b), std::ref(parB));
        ta.join();
        tb.join();
        EXPECT_TRUE(bitIdentical(parA, seqA)) << "round " << round;
        EXPECT_TRUE(bitIdentical(parB, seqB)) << "round " << round;
    }
}

// A cancelled render removes no other writer's temp file: a frame being written by another
// session (another context of the library) must survive a render cancelled beside it. Checked
// on host::Session with io::writeAtomically held open, which makes the order certain.
TEST(CApiThreads, ACancelledRenderLeavesAnotherWritersFileAlone) {
    TempDir dir("capi");
    const std::string out = (dir / "frame.exr").string();
    std::atomic<int> stage{0}; // 1: the temp file is written, 2: the render was cancelled
    std::string error;
    std::thread writer([&] {
        try {
            io::writeAtomically(out, [&](const std::string& temp) {
                writeText(temp, "a frame");
                stage = 1;
                while (stage < 2) std::this_thread::yield();
            });
        } catch (const std::exception& e) {
            error = e.what();
        }
    });
    while (stage < 1) std::this_thread::yield();
    host::Session s;
    ASSERT_TRUE(s.loadString(tinyScene(), "scene.toml").ok());
    Framebuffer fb;
    RenderStats stats;
    std::atomic<bool> cancel{false};
    const host::Status st = s.render(
        3, fb, stats, [&](int, int) { cancel = true; }, &cancel);
    stage = 2;
    writer.join();
    EXPECT_EQ(st.code, host::StatusCode::interrupted);
    EXPECT_TRUE(error.empty()) << error;
    EXPECT_TRUE(fs::exists(out));
}

TEST(CApi, AnOverlappingCallOnOneContextIsRefused) {
    Ctx c;
    ASSERT_EQ(nimbus_load_string(c, tinyScene().c_str(), "scene.toml"), NIMBUS_OK);
    ASSERT_EQ(nimbus_set(c, "camera.width=96"), NIMBUS_OK);
    ASSERT_EQ(nimbus_set(c, "render.tile_size=4"), NIMBUS_OK);
    struct Probe {
        nimbus_context* c;
        std::atomic<int> refused{0}, calls{0};
    } probe{c.c};
    // from inside the progress callback (a worker thread, while the render runs) a call other
    // than nimbus_cancel is an overlapping call
    ASSERT_EQ(nimbus_set_progress(
                  c,
                  [](void* u, int, int) {
                      auto* p = static_cast<Probe*>(u);
                      if (p->calls++ == 0 && nimbus_set(p->c, "camera.width=8") == NIMBUS_BAD_INPUT)
                          ++p->refused;
                      return 0;
                  },
                  &probe),
              NIMBUS_OK);
    renderC(c, 3);
    EXPECT_EQ(probe.refused, 1);
    int w = 0;
    ASSERT_EQ(nimbus_plan_int(c, 3, NIMBUS_PLAN_WIDTH, &w), NIMBUS_OK);
    EXPECT_EQ(w, 96);
}

// ---------------------------------------------------------------------------------------------
// the ABI: exported symbols and soname

// dlclose() must not unload the library: TBB worker threads may still be spinning down after a
// render (the suspected cause of the C host's one SIGSEGV at exit in a clean CI run under load).
// Linked with -z nodelete: the dynamic section says NODELETE.
TEST(CApi, TheLibraryStaysLoadedAfterDlclose) {
    const std::string lib = NIMBUS_CAPI_LIBRARY;
    const std::string dyn = run("readelf -d '" + lib + "'");
    ASSERT_FALSE(dyn.empty()) << "readelf (binutils) gave nothing for " << lib;
    bool nodelete = false;
    std::istringstream lines(dyn);
    for (std::string line; std::getline(lines, line);)
        if (line.find("(FLAGS_1)") != std::string::npos &&
            line.find("NODELETE") != std::string::npos)
            nodelete = true;
    EXPECT_TRUE(nodelete) << dyn;
}

TEST(CApi, ExportsExactlyTheBaselineAndTheSonameCarriesTheMajorVersion) {
    const std::string lib = NIMBUS_CAPI_LIBRARY;
    ASSERT_TRUE(fs::exists(lib)) << lib;
    const std::string nm = run("nm -D --defined-only --with-symbol-versions '" + lib + "'");
    ASSERT_FALSE(nm.empty()) << "nm (binutils) gave nothing for " << lib;
    std::set<std::string> exported;
    std::istringstream lines(nm);
    for (std::string line; std::getline(lines, line);) {
        std::istringstream f(line);
        std::string address, type, name;
        f >> address >> type >> name;
        if (name.empty()) continue;
        exported.insert(type + " " + name);
        if (type != "A") // the version node NIMBUS_0 is an absolute symbol
            EXPECT_EQ(name.rfind("nimbus_", 0), 0u) << "exported: " << line;
    }
    std::set<std::string> baseline;
    std::ifstream in(NIMBUS_CAPI_ABI);
    ASSERT_TRUE(in) << NIMBUS_CAPI_ABI;
    for (std::string line; std::getline(in, line);)
        if (!line.empty() && line[0] != '#') baseline.insert(line);
    std::string added, missing;
    for (const auto& s : exported)
        if (!baseline.count(s)) added += "  " + s + "\n";
    for (const auto& s : baseline)
        if (!exported.count(s)) missing += "  " + s + "\n";
    EXPECT_TRUE(added.empty()) << "exported but not in plugin/capi/nimbus.abi:\n" << added;
    EXPECT_TRUE(missing.empty()) << "in plugin/capi/nimbus.abi but not exported:\n" << missing;
    EXPECT_GT(baseline.size(), 20u);

    const std::string dyn = run("readelf -d '" + lib + "'");
    const std::string soname =
        "Library soname: [libnimbus.so." + std::to_string(NIMBUS_VERSION_MAJOR) + "]";
    EXPECT_TRUE(contains(dyn, soname));
}
