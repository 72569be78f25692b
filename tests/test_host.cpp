// The render session (plugin/host): errors come back as values with file and line, missing VDB
// frames name the file and frame, a tiny scene renders into buffers, and nothing is printed.
#include <atomic>
#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "plugin/host/session.h"
#include "tests/scenes.h"

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

std::string tinyScene(const std::string& extra = "") {
    return tinySceneText(extra);
}

} // namespace

TEST(Host, ExitCodesAreTheCommandsDocumentedOnes) {
    EXPECT_EQ(host::exitCode(host::StatusCode::ok), 0);
    EXPECT_EQ(host::exitCode(host::StatusCode::bad_input), 2);
    EXPECT_EQ(host::exitCode(host::StatusCode::io), 3);
    EXPECT_EQ(host::exitCode(host::StatusCode::no_memory), 4);
    EXPECT_EQ(host::exitCode(host::StatusCode::interrupted), 130);
    EXPECT_EQ(host::exitCode(host::StatusCode::internal), 1);
}

TEST(Host, BadSceneStringIsBadInputWithFileAndLine) {
    ::testing::internal::CaptureStderr();
    host::Session s;
    const host::Status st = s.loadString("[camera]\nfov = 45.0\nwidht = 64\n", "bad.toml");
    const std::string printed = ::testing::internal::GetCapturedStderr();
    EXPECT_EQ(st.code, host::StatusCode::bad_input);
    EXPECT_EQ(st.file, "bad.toml");
    EXPECT_EQ(st.line, 3);
    EXPECT_NE(st.message.find("widht"), std::string::npos) << st.message;
    EXPECT_FALSE(s.loaded());
    EXPECT_TRUE(printed.empty()) << printed;
    // an override has no line
    const host::Status ov = s.loadString(tinyScene(), "ok.toml", {"render.stepp=0.5"});
    EXPECT_EQ(ov.code, host::StatusCode::bad_input);
    EXPECT_EQ(ov.line, 0);
    EXPECT_NE(ov.message.find("stepp"), std::string::npos) << ov.message;
}

TEST(Host, MissingVdbNamesTheFileAndFrame) {
    const fs::path dir = fs::temp_directory_path() / "nimbus_test_host";
    fs::create_directories(dir);
    const std::string scene = (dir / "smoke.toml").string();
    ::testing::internal::CaptureStderr();
    host::Session s;
    host::Status st = s.loadString("frames = \"7\"\n[field]\nkind = \"vdb\"\npath = "
                                   "\"nowhere.####.vdb\"\n",
                                   scene);
    ASSERT_TRUE(st.ok()) << st.message;
    st = s.bind(7);
    Framebuffer fb;
    RenderStats stats;
    const host::Status viaRender = s.render(7, fb, stats);
    const std::string printed = ::testing::internal::GetCapturedStderr();
    EXPECT_EQ(st.code, host::StatusCode::bad_input);
    EXPECT_EQ(st.file, scene);
    EXPECT_NE(st.message.find("frame 7"), std::string::npos) << st.message;
    EXPECT_NE(st.message.find("nowhere.0007.vdb"), std::string::npos) << st.message;
    EXPECT_EQ(viaRender.code, host::StatusCode::bad_input);
    EXPECT_FALSE(s.boundFrame().has_value());
    EXPECT_TRUE(printed.empty()) << printed;
}

TEST(Host, RendersATinySceneIntoBuffersWithoutPrinting) {
    ::testing::internal::CaptureStderr();
    host::Session s;
    host::Status st = s.loadString(tinyScene(), "tiny.toml");
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(s.firstFrame(), 3);
    EXPECT_FALSE(s.readsGrids());
    EXPECT_EQ(s.geometry(), nullptr); // no surfaces, no instances: Embree is not built
    st = s.bind(3);
    ASSERT_TRUE(st.ok()) << st.message;
    Framebuffer fb;
    RenderStats stats;
    int calls = 0, total = 0;
    FramePlan plan;
    st = s.render(
        3, fb, stats,
        [&](int, int t) {
            ++calls;
            total = t;
        },
        nullptr, &plan);
    const std::string printed = ::testing::internal::GetCapturedStderr();
    ASSERT_TRUE(st.ok()) << st.message;
    EXPECT_EQ(plan.frame, 3);
    EXPECT_EQ(fb.width, 24);
    EXPECT_EQ(fb.height, 14);
    EXPECT_GT(calls, 0);
    EXPECT_EQ(calls, total);
    double sum = 0.0;
    for (float v : fb.rgba) {
        ASSERT_TRUE(std::isfinite(v));
        sum += v;
    }
    EXPECT_GT(sum, 0.0);
    EXPECT_TRUE(printed.empty()) << printed;

    // the same frame through the Renderer directly is bit-identical
    Renderer r(s.scene());
    Framebuffer direct;
    RenderStats ds;
    ASSERT_TRUE(r.render(r.plan(3), direct, ds));
    EXPECT_EQ(direct.rgba, fb.rgba);
}

TEST(Host, CancelledRenderIsInterrupted) {
    host::Session s;
    ASSERT_TRUE(s.loadString(tinyScene(), "tiny.toml").ok());
    std::atomic<bool> cancel{true};
    Framebuffer fb;
    RenderStats stats;
    const host::Status st = s.render(3, fb, stats, {}, &cancel);
    EXPECT_EQ(st.code, host::StatusCode::interrupted);
    EXPECT_NE(st.message.find("frame 3"), std::string::npos) << st.message;
}

TEST(Host, WriteFrameWritesTheExrAndReportsIoErrors) {
    const fs::path dir = fs::temp_directory_path() / "nimbus_test_host_write";
    fs::remove_all(dir);
    fs::create_directories(dir);
    ::testing::internal::CaptureStderr();
    host::Session s;
    ASSERT_TRUE(
        s.loadString(tinyScene("[output]\npath = \"" + (dir / "f.####.exr").string() + "\"\n"),
                     "tiny.toml")
            .ok());
    Framebuffer fb;
    RenderStats stats;
    ASSERT_TRUE(s.render(3, fb, stats).ok());
    host::Status st = s.writeFrame(3, fb, io::ExrMetadata{});
    EXPECT_TRUE(st.ok()) << st.message;
    EXPECT_TRUE(fs::is_regular_file(dir / "f.0003.exr"));
    // a directory where the file should go: an I/O error naming the frame
    s.file().output.path = dir.string();
    st = s.writeFrame(3, fb, io::ExrMetadata{});
    const std::string printed = ::testing::internal::GetCapturedStderr();
    EXPECT_EQ(st.code, host::StatusCode::io);
    EXPECT_NE(st.message.find("frame 3"), std::string::npos) << st.message;
    EXPECT_TRUE(s.takeWarnings().empty());
    EXPECT_TRUE(printed.empty()) << printed;
    fs::remove_all(dir);
}
