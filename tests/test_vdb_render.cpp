// Rendering VDB files written by other tools, through the real CLI.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include <nanovdb/NanoVDB.h>

#include "core/fields/field.h"
#include "plugin/io/image_output.h"
#include "test_util.h"
#include "plugin/vdb/vdb_reader.h"

namespace fs = std::filesystem;

namespace {

const fs::path kData = NIMBUS_SHARED_VDB_DIR;

/// A scene looking along +z at (0, cy, 0) from distance d, transparent background, 64x48.
fs::path writeScene(const fs::path& dir, const std::string& file, const std::string& extra,
                    float cy, float d) {
    fs::create_directories(dir);
    const fs::path scene = dir / "scene.toml";
    std::ofstream f(scene);
    f << "[camera]\nposition = [0.0, " << cy << ", " << -d << "]\nlook_at = [0.0, " << cy
      << ", 0.0]\nfov = 40.0\nwidth = 64\nheight = 48\n"
      << "[sun]\nelevation = 30.0\nazimuth = 60.0\nintensity = 3.0\n"
      << "[medium]\nsigma_s = 1.0\ng = 0.6\n"
      << "[field]\nkind = \"vdb\"\npath = \"" << (kData / file).string() << "\"\n"
      << extra << "[render]\nstep = 0.5\nshadow_step = 1.0\nbackground = \"transparent\"\n"
      << "[output]\npath = \"" << (dir / "out.####.exr").string() << "\"\n";
    return scene;
}

} // namespace

#define REQUIRE_DATA()                                                                             \
    if (!fs::is_directory(kData))                                                                  \
    GTEST_SKIP() << "shared VDB folder " << kData << " is absent: real-file render tests skipped"

TEST(VdbRender, Smoke1RendersAPlume) {
    REQUIRE_DATA();
    const fs::path dir =
        fs::temp_directory_path() / ("nimbus_vdbr_smoke_" + std::to_string(getpid()));
    CliRun r =
        runNimbus("render " + writeScene(dir, "openvdb_smoke1.vdb", "", 15.0f, 90.0f).string() +
                  " --progress none");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    auto img = nimbus::io::readExr((dir / "out.0001.exr").string());
    const int a = img.channelIndex("A");
    for (float v : img.pixels) ASSERT_TRUE(std::isfinite(v));
    // the plume fills the middle of the frame; the corners see nothing
    EXPECT_GT(img.at(32, 24, a), 0.5f);
    EXPECT_EQ(img.at(0, 0, a), 0.0f);
    EXPECT_EQ(img.at(63, 47, a), 0.0f);
    int covered = 0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x) covered += img.at(x, y, a) > 0.05f;
    EXPECT_GT(covered, 64 * 48 / 10);
    EXPECT_LT(covered, 64 * 48 * 9 / 10);
    fs::remove_all(dir);
}

TEST(VdbRender, EmptyFrameRendersTransparentWithAWarning) {
    REQUIRE_DATA();
    const fs::path dir =
        fs::temp_directory_path() / ("nimbus_vdbr_empty_" + std::to_string(getpid()));
    CliRun r =
        runNimbus("render " + writeScene(dir, "usd_smoke_000001.vdb", "", 0.0f, 10.0f).string() +
                  " --progress none");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("warning"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("empty"), std::string::npos) << r.output;
    auto img = nimbus::io::readExr((dir / "out.0001.exr").string());
    const int a = img.channelIndex("A");
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) ASSERT_EQ(img.at(x, y, a), 0.0f);
    fs::remove_all(dir);
}

TEST(VdbRender, LevelSetIsRefusedWithAClearMessage) {
    REQUIRE_DATA();
    const fs::path dir = fs::temp_directory_path() / ("nimbus_vdbr_ls_" + std::to_string(getpid()));
    CliRun r = runNimbus(
        "render " +
        writeScene(dir, "gaffer_sphere.vdb", "grid = \"ls_sphere\"\n", 0.0f, 10.0f).string() +
        " --progress none");
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_NE(r.output.find("gaffer_sphere.vdb"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("level set"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "out.0001.exr"));
    // and converts when asked
    CliRun c = runNimbus("render " +
                         writeScene(dir, "gaffer_sphere.vdb",
                                    "grid = \"ls_sphere\"\nlevelset_to_fog = true\n", 0.0f, 10.0f)
                             .string() +
                         " --progress none");
    EXPECT_EQ(c.exitCode, 0) << c.output;
    fs::remove_all(dir);
}

TEST(VdbRender, MissingGridListsTheGridsThatExist) {
    REQUIRE_DATA();
    const fs::path dir =
        fs::temp_directory_path() / ("nimbus_vdbr_miss_" + std::to_string(getpid()));
    CliRun r = runNimbus(
        "render " +
        writeScene(dir, "usd_densityAndHeat.vdb", "grid = \"smoke\"\n", 0.0f, 10.0f).string() +
        " --progress none");
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_NE(r.output.find("heat"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("density"), std::string::npos) << r.output;
    fs::remove_all(dir);
}

TEST(VdbBakeCli, BakedCumulusReadsBackAsTheFieldItSampled) {
    const fs::path dir = fs::temp_directory_path() / ("nimbus_bake_" + std::to_string(getpid()));
    fs::create_directories(dir);
    {
        std::ofstream f(dir / "c.toml");
        f << "[field]\nkind = \"cumulus\"\nbounds_min = [-6.0, 1.5, -6.0]\n"
             "bounds_max = [6.0, 4.0, 6.0]\nbase_octaves = 2\ndetail_octaves = 1\n"
             "evaluation = \"direct\"\n";
    }
    CliRun r = runNimbus("bake " + (dir / "c.toml").string() + " -o " +
                         (dir / "c.####.vdb").string() + " --frames 3 --voxel 0.25");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    nimbus::vdb::VdbLoadOptions opt;
    opt.path = (dir / "c.0003.vdb").string();
    nimbus::vdb::LoadedVdbGrid g = nimbus::vdb::loadVdbGrid(opt);
    EXPECT_EQ(g.gridClass, "fog volume");
    EXPECT_GT(g.activeVoxelCount, 100u);
    EXPECT_NEAR(g.voxelSize.x, 0.25f, 1e-6f);
    // every voxel centre holds the density of the field at that point and frame
    nimbus::SceneDesc s;
    s.field.cumulus.bounds =
        nimbus::Box{nimbus::vec3(-6.0f, 1.5f, -6.0f), nimbus::vec3(6.0f, 4.0f, 6.0f)};
    s.field.cumulus.baseOctaves = 2;
    s.field.cumulus.detailOctaves = 1;
    s.field.cumulus.eval = nimbus::NoiseEval::Direct;
    nimbus::Field field = nimbus::makeField(s.field, 3.0f / s.render.fps);
    auto acc = g.grid()->getAccessor();
    int checked = 0, nonzero = 0;
    for (int k = 0; k < 10; ++k)
        for (int j = 0; j < 10; ++j)
            for (int i = 0; i < 48; i += 3) {
                const nanovdb::Coord ijk(i, j, 4 * k + 2);
                const nanovdb::Vec3f w =
                    g.grid()->indexToWorldF(nanovdb::Vec3f(ijk[0], ijk[1], ijk[2]));
                const float expect = field.density(nimbus::vec3(w[0], w[1], w[2]));
                EXPECT_NEAR(acc.getValue(ijk), expect, 1e-6f) << i << "," << j << "," << k;
                ++checked;
                nonzero += expect > 0.0f;
            }
    EXPECT_GT(nonzero, 10);
    fs::remove_all(dir);
}

TEST(VdbRender, ConvergeMeasuresAVdbScene) {
    REQUIRE_DATA();
    const fs::path dir =
        fs::temp_directory_path() / ("nimbus_vdbr_conv_" + std::to_string(getpid()));
    const fs::path scene = writeScene(dir, "openvdb_smoke1.vdb", "", 15.0f, 90.0f);
    // single scattering: the step's error is the point (with "auto"'s photons, traced for each of
    // the four renders, the test took 33 s instead of 1)
    CliRun r = runNimbus("converge " + scene.string() +
                         " --ladder 4,1 --reference-step 0.25 --set "
                         "'render.multiple_scattering=\"none\"' --csv " +
                         (dir / "c.csv").string());
    ASSERT_EQ(r.exitCode, 0) << r.output;
    std::ifstream f(dir / "c.csv");
    std::string header, coarse, fine;
    std::getline(f, header);
    std::getline(f, coarse);
    std::getline(f, fine);
    auto rmse = [](const std::string& l) {
        size_t i = 0;
        for (int comma = 0; i < l.size() && comma < 9; ++i) comma += l[i] == ',';
        return std::stod(l.substr(i));
    };
    // the grid was loaded (a field without it would give zero error everywhere) and the error
    // falls with the step
    EXPECT_GT(rmse(coarse), rmse(fine));
    EXPECT_GT(rmse(fine), 0.0);
    fs::remove_all(dir);
}
