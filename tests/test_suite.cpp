// `nimbus converge --suite` (plugin/cli/suite.cpp): the real command on the real Gaffer fog
// sphere from ../shared/data/vdb, a few cases at a tiny size: the table and the CSV, the
// thickness, the cache (reused, refined, refused when stale or corrupt) and bad options.
#include <gtest/gtest.h>

#include "test_util.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "plugin/io/image_output.h"

namespace fs = std::filesystem;

namespace {

const fs::path kData = NIMBUS_SHARED_VDB_DIR;
const char* kSphere = "gaffer_fogsphere_small";

/// The CSV of a run as rows of column -> value.
std::vector<std::map<std::string, std::string>> readCsv(const fs::path& p) {
    std::ifstream in(p);
    std::string line;
    std::vector<std::string> head;
    std::vector<std::map<std::string, std::string>> rows;
    while (std::getline(in, line)) {
        std::vector<std::string> cells;
        std::stringstream ss(line);
        for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
        if (head.empty()) {
            head = cells;
            continue;
        }
        std::map<std::string, std::string> row;
        for (size_t i = 0; i < head.size() && i < cells.size(); ++i) row[head[i]] = cells[i];
        rows.push_back(row);
    }
    return rows;
}

std::string fileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

double num(const std::map<std::string, std::string>& row, const std::string& key) {
    auto it = row.find(key);
    return it == row.end() ? std::nan("") : std::strtod(it->second.c_str(), nullptr);
}

class Suite : public testing::Test {
  protected:
    void SetUp() override {
        if (!fs::is_regular_file(kData / (std::string(kSphere) + ".vdb")))
            GTEST_SKIP() << "shared VDB folder " << kData << " (or " << kSphere
                         << ".vdb in it) is absent: converge --suite tests skipped";
    }
    /// `nimbus converge --suite` on the fog sphere at 32x18 with small references.
    /// `extra` replaces the options of the references' budget, and the size, when it names
    /// them.
    CliRun suite(const std::string& filter, const std::string& extra = "") {
        const std::string budget =
            extra.find("--suite-seconds") == std::string::npos ? " --suite-seconds 0" : "";
        const std::string size =
            extra.find("--suite-size") == std::string::npos ? " --suite-size 32x18" : "";
        return runNimbus("converge --suite --suite-data " + kData.string() + " --suite-dir " +
                         dir.string() + " --suite-filter " + filter + size +
                         " --suite-spp 16 --suite-max-depth 256" + budget +
                         // the table's workings, not its accuracy: far fewer photons than
                         // the 8 M that render.photons = 0 gives the medium rows (2 M until
                         // 2026-12-05: the test 43-49 s, most of it the photons)
                         " --set render.photons=200000 " + extra);
    }
    TempDir dir{"suite"};
};

} // namespace

TEST_F(Suite, TableCsvThicknessAndCache) {
    const std::string filter =
        std::string(kSphere) + "/thin/front," + kSphere + "/medium/side/a0.9";
    CliRun r = suite(filter);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    // the markdown table: its columns, one row per case, worst first, the summary
    for (const char* col : {"| scene", "grid", "thickness", "tau", "sun", "albedo", "rel. RMSE",
                            "mean ratio", "ref. noise", "ref. spp", "march s", "ref. s"})
        EXPECT_TRUE(contains(r.output, col));
    EXPECT_TRUE(contains(r.output, "worst: "));
    EXPECT_TRUE(contains(r.output, "of 3 cases within 10.00%"));
    EXPECT_TRUE(contains(r.output, "| thin (1)"));
    EXPECT_TRUE(contains(r.output, "| medium (20)"));

    const auto rows = readCsv(dir / "suite.csv");
    ASSERT_EQ(rows.size(), 3u) << r.output;
    double previous = 1e300;
    for (const auto& row : rows) {
        SCOPED_TRACE(row.at("case"));
        EXPECT_EQ(row.at("scene"), kSphere);
        EXPECT_EQ(row.at("grid"), "density");
        // the density scale gives the target's mean optical depth (rounded to 4 digits)
        const double target = num(row, "tau_target"), tau = num(row, "tau_achieved");
        EXPECT_NEAR(tau / target, 1.0, 1e-3);
        EXPECT_GT(num(row, "density_scale"), 0.0);
        for (const char* k : {"relative_rmse", "relative_rmse_raw", "mean_ratio", "reference_noise",
                              "march_seconds", "reference_seconds"}) {
            EXPECT_TRUE(std::isfinite(num(row, k))) << k;
            EXPECT_GE(num(row, k), 0.0) << k;
        }
        EXPECT_GT(num(row, "mean_ratio"), 0.0);
        EXPECT_GT(num(row, "cloud_pixels"), 10.0);
        EXPECT_EQ(num(row, "reference_spp"), 16.0);
        EXPECT_GT(num(row, "reference_seconds_this_run"), 0.0);
        EXPECT_LE(num(row, "relative_rmse"), previous); // worst first
        previous = num(row, "relative_rmse");
    }
    // the summary's median is the middle one of the three cases' errors, and the thin pair's
    // the mean of its two (the CSV holds six digits, the summary the percentage to 0.01)
    auto printedAfter = [&](const std::string& label) {
        const size_t at = r.output.find(label);
        return at == std::string::npos ? std::nan("")
                                       : std::atof(r.output.c_str() + at + label.size()) / 100.0;
    };
    EXPECT_NEAR(printedAfter("; median "), num(rows[1], "relative_rmse"), 6e-5) << r.output;
    double thin[2];
    int nThin = 0;
    for (const auto& row : rows)
        if (row.at("thickness") == "thin" && nThin < 2) thin[nThin++] = num(row, "relative_rmse");
    ASSERT_EQ(nThin, 2);
    const size_t byThickness = r.output.find("by thickness:");
    ASSERT_NE(byThickness, std::string::npos) << r.output;
    const size_t thinAt = r.output.find(" thin ", byThickness);
    ASSERT_NE(thinAt, std::string::npos) << r.output;
    EXPECT_NEAR(printedAfter(r.output.substr(thinAt, r.output.find("(median ", thinAt) - thinAt) +
                             "(median "),
                0.5 * (thin[0] + thin[1]), 6e-5)
        << r.output;

    // the thickness seen independently: the path tracer's own transmittance (alpha) of the
    // thin case's reference gives a mean optical depth near 1 over the cloud's pixels
    for (const char* albedo : {"a1", "a0.9"}) {
        const auto img = nimbus::io::readExr(
            (dir / (std::string(kSphere) + ".thin.front." + albedo + ".a.exr")).string());
        const int a = img.channelIndex("A");
        ASSERT_GE(a, 0);
        double tauSum = 0.0;
        int n = 0;
        for (int y = 0; y < img.height; ++y)
            for (int x = 0; x < img.width; ++x) {
                const double alpha = img.at(x, y, a);
                if (alpha <= 0.01) continue;
                tauSum += -std::log(std::max(1e-6, 1.0 - alpha));
                ++n;
            }
        ASSERT_GT(n, 10);
        EXPECT_GT(tauSum / n, 1.0 / 3.0) << albedo;
        EXPECT_LT(tauSum / n, 3.0) << albedo;
    }
    // the march images are kept beside the references
    EXPECT_TRUE(fs::exists(dir / (std::string(kSphere) + ".thin.front.a1.march.exr")));

    // a second run reads every reference from the cache and renders none
    CliRun again = suite(filter);
    ASSERT_EQ(again.exitCode, 0) << again.output;
    EXPECT_TRUE(contains(again.output, "reference cached 16 spp"));
    EXPECT_FALSE(contains(again.output, "+16 spp"));
    EXPECT_TRUE(contains(again.output, "0.0 s of it in this run"));
    const auto rows2 = readCsv(dir / "suite.csv");
    ASSERT_EQ(rows2.size(), 3u);
    for (size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(num(rows2[i], "reference_seconds_this_run"), 0.0);
        EXPECT_EQ(rows2[i].at("case"), rows[i].at("case"));
        // the same reference and the same deterministic march: the same error
        EXPECT_EQ(rows2[i].at("relative_rmse"), rows[i].at("relative_rmse"));
    }

    // a corrupted cache file is rendered again, never used; the other cases stay cached
    const fs::path bad = dir / (std::string(kSphere) + ".thin.front.a1.a.exr");
    {
        std::ofstream f(bad, std::ios::binary | std::ios::trunc);
        f << "this is not an EXR file";
    }
    CliRun fixed = suite(filter);
    ASSERT_EQ(fixed.exitCode, 0) << fixed.output;
    EXPECT_TRUE(contains(fixed.output, "thin/front/a1: tau 1 (density_scale"));
    EXPECT_TRUE(contains(fixed.output, "unreadable"));
    for (const auto& row : readCsv(dir / "suite.csv"))
        EXPECT_EQ(num(row, "reference_seconds_this_run") > 0.0,
                  row.at("case") == std::string(kSphere) + "/thin/front/a1")
            << row.at("case");
    EXPECT_NO_THROW(nimbus::io::readExr(bad.string())); // rewritten

    // a reference of other settings is stale: rendered again, saying what differs
    const std::string staleA =
        fileBytes((dir / (std::string(kSphere) + ".medium.side.a0.9.a.exr")).string());
    ASSERT_FALSE(staleA.empty());
    CliRun stale = suite(std::string(kSphere) + "/medium/side/a0.9", "--set medium.g=0.5");
    ASSERT_EQ(stale.exitCode, 0) << stale.output;
    EXPECT_TRUE(contains(stale.output, "stale: now \"medium.g = 0.5"));
    EXPECT_TRUE(contains(stale.output, "+16 spp"));
    // the stale one kept beside the new one under its key, byte for byte, both halves
    const std::string base = std::string(kSphere) + ".medium.side.a0.9";
    const std::string staleStem = (dir / base).string();
    auto keptStems = [&]() {
        std::vector<std::string> out;
        for (const auto& e : fs::directory_iterator(dir)) {
            const std::string n = e.path().filename().string();
            if (n.rfind(base + ".k", 0) == 0 && n.size() > 6 &&
                n.compare(n.size() - 6, 6, ".a.exr") == 0)
                out.push_back((dir / n.substr(0, n.size() - 6)).string());
        }
        return out;
    };
    EXPECT_TRUE(contains(stale.output, "kept as")) << stale.output;
    std::vector<std::string> kept = keptStems();
    ASSERT_EQ(kept.size(), 1u) << stale.output;
    EXPECT_EQ(fileBytes(kept[0] + ".a.exr"), staleA);
    EXPECT_TRUE(fs::exists(kept[0] + ".b.exr"));
    const std::string newA = fileBytes(staleStem + ".a.exr");
    EXPECT_NE(newA, staleA);

    // the settings of before again: the kept reference is taken back, not rendered again, and
    // the other one kept in its turn (each of the two under its own name)
    CliRun back = suite(std::string(kSphere) + "/medium/side/a0.9");
    ASSERT_EQ(back.exitCode, 0) << back.output;
    EXPECT_TRUE(contains(back.output, "taken back from")) << back.output;
    EXPECT_FALSE(contains(back.output, "+16 spp")) << back.output;
    EXPECT_EQ(fileBytes(staleStem + ".a.exr"), staleA);
    kept = keptStems();
    ASSERT_EQ(kept.size(), 1u) << back.output;
    EXPECT_EQ(fileBytes(kept[0] + ".a.exr"), newA);
    // and the other way, once more: still two references, none rendered
    CliRun forth = suite(std::string(kSphere) + "/medium/side/a0.9", "--set medium.g=0.5");
    ASSERT_EQ(forth.exitCode, 0) << forth.output;
    EXPECT_TRUE(contains(forth.output, "taken back from")) << forth.output;
    EXPECT_FALSE(contains(forth.output, "+16 spp")) << forth.output;
    EXPECT_EQ(fileBytes(staleStem + ".a.exr"), newA);
    kept = keptStems();
    ASSERT_EQ(kept.size(), 1u);
    EXPECT_EQ(fileBytes(kept[0] + ".a.exr"), staleA);

    // a stale pair under the names of the one-generation scheme before (CASE.a.stale.exr) is
    // found as well
    fs::rename(kept[0] + ".a.exr", staleStem + ".a.stale.exr");
    fs::rename(kept[0] + ".b.exr", staleStem + ".b.stale.exr");
    CliRun legacy = suite(std::string(kSphere) + "/medium/side/a0.9");
    ASSERT_EQ(legacy.exitCode, 0) << legacy.output;
    EXPECT_TRUE(contains(legacy.output, "taken back from")) << legacy.output;
    EXPECT_FALSE(contains(legacy.output, "+16 spp")) << legacy.output;
    EXPECT_EQ(fileBytes(staleStem + ".a.exr"), staleA);
    EXPECT_FALSE(fs::exists(staleStem + ".a.stale.exr"));

    // another size: the reference of this one is kept aside as well, and taken back after
    CliRun small = suite(std::string(kSphere) + "/medium/side/a0.9", "--suite-size 16x9");
    ASSERT_EQ(small.exitCode, 0) << small.output;
    EXPECT_TRUE(contains(small.output, "camera.height = 9")) << small.output;
    EXPECT_TRUE(contains(small.output, "the old one kept as")) << small.output;
    CliRun sized = suite(std::string(kSphere) + "/medium/side/a0.9");
    ASSERT_EQ(sized.exitCode, 0) << sized.output;
    EXPECT_TRUE(contains(sized.output, "taken back from")) << sized.output;
    EXPECT_FALSE(contains(sized.output, "+16 spp")) << sized.output;
    EXPECT_EQ(fileBytes(staleStem + ".a.exr"), staleA);

    // a larger sample budget refines the cached reference instead of starting again
    CliRun more = suite(std::string(kSphere) + "/thin/front/a0.9",
                        "--suite-seconds 1000 --suite-max-spp 48 --suite-noise 0.001");
    ASSERT_EQ(more.exitCode, 0) << more.output;
    EXPECT_TRUE(contains(more.output, "reference cached 16 spp, +32 spp"));
    const auto rows3 = readCsv(dir / "suite.csv");
    ASSERT_EQ(rows3.size(), 1u);
    EXPECT_EQ(num(rows3[0], "reference_spp"), 48.0);
}

// The cache follows what the path tracer sees: a VDB file copied again with the same bytes (new
// modification time, as a data folder copied to another machine) keeps its references, and so
// do settings that only `march` reads; a setting the path tracer reads does not.
TEST_F(Suite, CacheKeyFollowsContentNotTime) {
    TempDir data{"suite_data"};
    const fs::path src = kData / (std::string(kSphere) + ".vdb");
    const fs::path copy = data.path() / (std::string(kSphere) + ".vdb");
    fs::copy_file(src, copy);
    auto run = [&](const std::string& extra) {
        return runNimbus("converge --suite --suite-data " + data.path().string() + " --suite-dir " +
                         dir.string() + " --suite-filter " + kSphere +
                         "/thin/front/a1 --suite-size 32x18 --suite-spp 16 --suite-max-depth 256 "
                         "--suite-seconds 0 " +
                         extra);
    };
    auto renderedNow = [&]() {
        const auto rows = readCsv(dir / "suite.csv");
        return rows.size() == 1 && num(rows[0], "reference_seconds_this_run") > 0.0;
    };
    CliRun first = run("");
    ASSERT_EQ(first.exitCode, 0) << first.output;
    EXPECT_TRUE(renderedNow());

    // the same bytes written again an hour later
    fs::remove(copy);
    fs::copy_file(src, copy);
    fs::last_write_time(copy, fs::last_write_time(src) + std::chrono::hours(1));
    CliRun again = run("");
    ASSERT_EQ(again.exitCode, 0) << again.output;
    EXPECT_FALSE(renderedNow()) << again.output;
    EXPECT_FALSE(contains(again.output, "stale")) << again.output;

    // march's own settings, the single-scattered sky's among them
    CliRun marchOnly = run("--set render.multiple_scattering='\"none\"' --set "
                           "render.sky_scattering='\"single\"' --set render.sky_directions=4 "
                           "--set render.sky_shadow='\"volume\"' --set "
                           "render.forward_scattering='\"none\"' --set render.octaves=1 "
                           "--set render.octave_gate=0.25 --set render.shadow_step_voxels=2 "
                           "--set render.step_tau=0.25 --set render.photon_step_tau=0.25 "
                           "--set render.photon_walk_depth=3 --set render.ms_p1=0.5 "
                           "--set render.epsilon=0.02 --set sky.ambient=0.5 "
                           "--set render.tile_size=8");
    ASSERT_EQ(marchOnly.exitCode, 0) << marchOnly.output;
    EXPECT_FALSE(renderedNow()) << marchOnly.output;

    // a setting of the path tracer's: rendered again
    CliRun other = run("--set render.rr_depth=5");
    ASSERT_EQ(other.exitCode, 0) << other.output;
    EXPECT_TRUE(renderedNow());
    EXPECT_TRUE(contains(other.output, "stale: now \"render.rr_depth = 5")) << other.output;
}

// --suite-light: each light alone, cached apart from both lights' references, and the path
// tracer's references add up: sun alone + sky alone = both, to within their noise (a Z-test
// on the mean over the cloud's pixels, each image's noise from its two halves)
TEST_F(Suite, OneLightAtATimeIsCachedApartAndAddsUp) {
    const std::string filter = std::string(kSphere) + "/thin/side/a1";
    const std::string stem = (dir / (std::string(kSphere) + ".thin.side.a1")).string();
    // the sky alone is the same whatever the sun's position: its files name the sun "any"
    const std::string skyStem = (dir / (std::string(kSphere) + ".thin.any.a1")).string();
    CliRun both = suite(filter);
    ASSERT_EQ(both.exitCode, 0) << both.output;
    const std::string bothA = fileBytes(stem + ".a.exr");
    ASSERT_FALSE(bothA.empty());
    for (const char* light : {"sun", "sky"}) {
        CliRun r = suite(filter, std::string("--suite-light ") + light);
        ASSERT_EQ(r.exitCode, 0) << r.output;
        EXPECT_TRUE(contains(r.output, std::string("light: the ") + light + " alone")) << r.output;
        EXPECT_TRUE(contains(r.output, "reference not cached")) << r.output; // not both's files
        const std::string lightStem = std::string(light) == "sky" ? skyStem : stem;
        EXPECT_TRUE(fs::exists(lightStem + "." + light + ".a.exr"));
        EXPECT_TRUE(fs::exists(lightStem + "." + light + ".march.exr"));
        EXPECT_EQ(readCsv(dir / ("suite." + std::string(light) + ".csv")).size(), 1u);
        // read back from its own cache the second time
        CliRun again = suite(filter, std::string("--suite-light ") + light);
        ASSERT_EQ(again.exitCode, 0) << again.output;
        EXPECT_TRUE(contains(again.output, "reference cached 16 spp")) << again.output;
    }
    // the sky alone of another sun position is read from the same reference
    CliRun front = suite(std::string(kSphere) + "/thin/front/a1", "--suite-light sky");
    ASSERT_EQ(front.exitCode, 0) << front.output;
    EXPECT_TRUE(contains(front.output, "reference cached 16 spp")) << front.output;
    EXPECT_EQ(fileBytes(stem + ".a.exr"), bothA); // both lights' reference untouched
    EXPECT_EQ(readCsv(dir / "suite.csv").size(), 1u);

    // mean over the pixels where both lights' reference has cloud, and its standard error
    // from the halves' per-pixel difference
    const auto refA = nimbus::io::readExr(stem + ".a.exr");
    const int alpha = refA.channelIndex("A");
    ASSERT_GE(alpha, 0);
    auto meanAndError = [&](const std::string& s) {
        const auto a = nimbus::io::readExr(s + ".a.exr"), b = nimbus::io::readExr(s + ".b.exr");
        double sum = 0.0, d2 = 0.0;
        int n = 0;
        for (int y = 0; y < a.height; ++y)
            for (int x = 0; x < a.width; ++x) {
                if (refA.at(x, y, alpha) <= 0.01) continue;
                for (int c = 0; c < 3; ++c) {
                    const double va = a.at(x, y, c), vb = b.at(x, y, c);
                    sum += 0.5 * (va + vb);
                    d2 += (va - vb) * (va - vb);
                    ++n;
                }
            }
        // var(mean of the halves' average) = var(a - b) / 4 / n
        return std::pair<double, double>{sum / n, std::sqrt(d2 / n / 4.0 / n)};
    };
    const auto [mBoth, eBoth] = meanAndError(stem);
    const auto [mSun, eSun] = meanAndError(stem + ".sun");
    const auto [mSky, eSky] = meanAndError(skyStem + ".sky");
    EXPECT_GT(mSun, 0.05 * mBoth);
    EXPECT_GT(mSky, 0.05 * mBoth);
    const double z = (mBoth - mSun - mSky) / std::sqrt(eBoth * eBoth + eSun * eSun + eSky * eSky);
    EXPECT_LT(std::abs(z), 3.29) << "both " << mBoth << " +- " << eBoth << ", sun " << mSun
                                 << " +- " << eSun << ", sky " << mSky << " +- " << eSky;
}

// needs no VDB file: every one of these is refused before anything is read
TEST(SuiteOptions, BadOptionsAreErrors) {
    TempDir dir("suite_options");
    struct Bad {
        std::string args, message;
    };
    const std::vector<Bad> bad = {
        {"--suite-filter nothing_matches_this", "--suite-filter matches no case"},
        {"--suite-filter x --suite-size 64", "--suite-size \"64\": expected WIDTHxHEIGHT"},
        {"--suite-filter x --suite-size 0x36", "expected WIDTHxHEIGHT"},
        {"--suite-filter x --ladder 1,2", "--ladder does not apply to --suite"},
        {"--suite-filter x --suite-spp 1", "--suite-spp"},
        {"--suite-filter x --suite-light moon", "--suite-light"},
        {"--suite-data /nonexistent/folder", "--suite-data /nonexistent/folder: not a directory"},
    };
    for (const Bad& b : bad) {
        CliRun r = runNimbus("converge --suite --suite-dir " + dir.string() + " " + b.args);
        EXPECT_EQ(r.exitCode, 2) << b.args << "\n" << r.output;
        EXPECT_TRUE(contains(r.output, b.message)) << b.args;
    }
    CliRun r = runNimbus("converge --suite-spp 64");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_TRUE(contains(r.output, "a scene file is required (or --suite)"));
}

TEST_F(Suite, InterruptExits130) {
    // a reference of about ten seconds in tiles of a fraction of a second (the renderer looks at
    // the cancel flag between tiles)
    EXPECT_EQ(interruptNimbus("converge --suite --suite-data " + kData.string() + " --suite-dir " +
                              dir.string() + " --suite-filter " + kSphere +
                              "/thin/front/a1 --suite-size 32x18 --suite-spp 6000 --set "
                              "render.tile_size=4"),
              130);
}
