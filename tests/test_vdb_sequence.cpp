/// @file test_vdb_sequence.cpp
/// @brief resolveVdbFrame(): per-frame VDB patterns, missing frames, holding the previous frame.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "plugin/vdb/vdb_reader.h"
#include "tests/test_util.h"

using namespace nimbus::vdb;
namespace fs = std::filesystem;

namespace {

class VdbSequence : public ::testing::Test {
  protected:
    void SetUp() override {
        // Frames 1, 2 and 4 exist (resolveVdbFrame only checks that the files exist).
        for (const char* f : {"smoke.0001.vdb", "smoke.0002.vdb", "smoke.0004.vdb"})
            std::ofstream(dir_ / f) << "x";
        fs::create_directories(dir_ / "smoke.0005.vdb"); // a directory is not a frame file
    }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    std::string error(const std::string& pattern, int frame, bool hold, int maxHold = 100000) {
        try {
            VdbFrameFile f = resolveVdbFrame(pattern, frame, hold, maxHold);
            ADD_FAILURE() << "frame " << frame << " resolved to " << f.path;
        } catch (const VdbError& e) {
            return e.what();
        }
        return "";
    }
    TempDir dir_{"vdbseq"};
};

} // namespace

TEST_F(VdbSequence, ExistingFramesResolveForHashAndHoudiniTokens) {
    for (const std::string pattern : {path("smoke.####.vdb"), path("smoke.$F4.vdb")}) {
        VdbFrameFile f = resolveVdbFrame(pattern, 2);
        EXPECT_EQ(f.path, path("smoke.0002.vdb")) << pattern;
        EXPECT_EQ(f.frame, 2);
        EXPECT_EQ(f.sourceFrame, 2);
        EXPECT_FALSE(f.held);
        EXPECT_TRUE(f.warning.empty());
    }
}

TEST_F(VdbSequence, MissingFrameIsAnErrorNamingTheFrameAndThePath) {
    const std::string msg = error(path("smoke.####.vdb"), 3, false);
    EXPECT_TRUE(contains(msg, "frame 3"));
    EXPECT_TRUE(contains(msg, path("smoke.0003.vdb")));
    EXPECT_TRUE(contains(msg, "does not exist"));
    // A directory named like a frame file is not a frame file.
    EXPECT_TRUE(contains(error(path("smoke.$F4.vdb"), 5, false), "frame 5"));
}

TEST_F(VdbSequence, HoldUsesTheNearestEarlierFrameAndWarns) {
    VdbFrameFile f = resolveVdbFrame(path("smoke.####.vdb"), 3, /*hold=*/true);
    EXPECT_TRUE(f.held);
    EXPECT_EQ(f.frame, 3);
    EXPECT_EQ(f.sourceFrame, 2);
    EXPECT_EQ(f.path, path("smoke.0002.vdb"));
    EXPECT_TRUE(contains(f.warning, "frame 3"));
    EXPECT_TRUE(contains(f.warning, path("smoke.0003.vdb")));
    EXPECT_TRUE(contains(f.warning, "holding frame 2"));

    VdbFrameFile g = resolveVdbFrame(path("smoke.####.vdb"), 9, true);
    EXPECT_EQ(g.sourceFrame, 4) << "frames 5..8 are missing (5 is a directory)";
    EXPECT_TRUE(contains(error(path("smoke.####.vdb"), 9, true, 3), "searched back to frame 6"));

    const std::string msg = error(path("smoke.####.vdb"), 0, true);
    EXPECT_TRUE(contains(msg, "frame 0"));
    EXPECT_TRUE(contains(msg, "no earlier frame"));
}

TEST_F(VdbSequence, PatternWithoutFrameTokenIsOneFileForEveryFrame) {
    EXPECT_EQ(resolveVdbFrame(path("smoke.0004.vdb"), 17).path, path("smoke.0004.vdb"));
    EXPECT_TRUE(contains(error(path("static.vdb"), 17, true), path("static.vdb")));
}

TEST_F(VdbSequence, FrameInADirectoryNameAndNegativeFrames) {
    fs::create_directories(dir_ / "cache" / "f0010");
    std::ofstream(dir_ / "cache" / "f0010" / "density.vdb") << "x";
    VdbFrameFile f = resolveVdbFrame(path("cache/f$F4/density.vdb"), 12, true);
    EXPECT_EQ(f.sourceFrame, 10);
    EXPECT_EQ(f.path, path("cache/f0010/density.vdb"));

    std::ofstream(dir_ / "neg.-007.vdb") << "x";
    std::ofstream(dir_ / "neg.0003.vdb") << "x";
    VdbFrameFile n = resolveVdbFrame(path("neg.####.vdb"), -2, true);
    EXPECT_EQ(n.sourceFrame, -7);
    EXPECT_EQ(n.path, path("neg.-007.vdb"));
    EXPECT_EQ(resolveVdbFrame(path("neg.####.vdb"), 5, true).sourceFrame, 3);
}
