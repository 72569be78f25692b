/// @file test_vdb_writer.cpp
/// @brief Baking fog volumes (writeFogVdb, bakeFogVdb): bake -> read back gives identical voxel
///        values, transform (voxel-centre convention) and grid class.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "plugin/vdb/vdb_reader.h"
#include "plugin/vdb/vdb_writer.h"
#include "tests/test_util.h"

using namespace nimbus::vdb;
namespace fs = std::filesystem;

namespace {

class VdbBake : public ::testing::Test {
  protected:
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    std::vector<std::string> listing() const {
        std::vector<std::string> out;
        for (const auto& e : fs::recursive_directory_iterator(dir_))
            out.push_back(fs::relative(e.path(), dir_).string());
        return out;
    }
    TempDir dir_{"vdbbake"};
};

/// A deterministic field with zeros, tiny values and large ones, x fastest.
std::vector<float> pattern(int nx, int ny, int nz) {
    std::vector<float> v(std::size_t(nx) * ny * nz);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                const int h = (i * 73856093) ^ (j * 19349663) ^ (k * 83492791);
                float x = float((h >> 4) & 1023) / 1023.0f;
                if (((h >> 14) & 3) == 0) x = 0.0f;   // a quarter are empty
                if (((h >> 16) & 7) == 1) x *= 1e-6f; // some are tiny
                if (i + j + k == 7) x = 123.456f;     // one big value
                v[std::size_t(i) + std::size_t(nx) * (j + std::size_t(ny) * k)] = x;
            }
    return v;
}

std::string bakeError(const std::function<void()>& f) {
    try {
        f();
        ADD_FAILURE() << "did not throw";
    } catch (const VdbError& e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST_F(VdbBake, DenseBakeReadsBackIdentical) {
    const int nx = 13, ny = 9, nz = 17; // not multiples of the 8^3 leaves
    const std::vector<float> dense = pattern(nx, ny, nz);
    const glm::vec3 origin(-1.25f, 3.0f, 100.5f), vs(0.1f, 0.2f, 0.05f);
    const std::string p = path("sub/dir/bake.vdb");
    VdbBakeStats stats = writeFogVdb(p, "density", nx, ny, nz, dense.data(), origin, vs);

    std::uint64_t positive = 0;
    for (float v : dense) positive += v > 0.0f;
    EXPECT_EQ(stats.activeVoxelCount, positive);
    EXPECT_FLOAT_EQ(stats.maxValue, 123.456f);
    EXPECT_EQ(listing().size(), 3u) << "sub, sub/dir, sub/dir/bake.vdb: no temp files left";

    LoadedVdbGrid g = loadVdbGrid({.path = p});
    EXPECT_EQ(g.gridClass, "fog volume");
    EXPECT_EQ(g.sourceValueType, "float");
    EXPECT_TRUE(g.warnings.empty());
    EXPECT_TRUE(contains(g.creator, "Nimbus"));
    EXPECT_EQ(g.activeVoxelCount, positive);
    EXPECT_EQ(g.leafCount, stats.leafCount);
    auto acc = g.grid()->getAccessor();
    int mismatches = 0;
    for (int k = -1; k <= nz; ++k)
        for (int j = -1; j <= ny; ++j)
            for (int i = -1; i <= nx; ++i) {
                const bool inside = i >= 0 && j >= 0 && k >= 0 && i < nx && j < ny && k < nz;
                const float expected =
                    inside ? dense[std::size_t(i) + std::size_t(nx) * (j + std::size_t(ny) * k)]
                           : 0.0f;
                const nanovdb::Coord ijk(i, j, k);
                if (acc.getValue(ijk) != expected || acc.isActive(ijk) != (expected > 0.0f))
                    ++mismatches;
            }
    EXPECT_EQ(mismatches, 0);

    // Transform: index (i,j,k) is the centre where sample (i,j,k) was taken.
    EXPECT_EQ(g.voxelSize, vs);
    for (glm::ivec3 ijk : {glm::ivec3(0), glm::ivec3(12, 8, 16), glm::ivec3(5, 0, 9)}) {
        const glm::vec3 w = glm::vec3(g.worldFromIndex * glm::vec4(glm::vec3(ijk), 1.0f));
        const glm::vec3 expected = origin + glm::vec3(ijk) * vs;
        for (int a = 0; a < 3; ++a) EXPECT_NEAR(w[a], expected[a], 1e-5f * std::abs(expected[a]));
    }
}

TEST_F(VdbBake, OneVoxelCoversHalfAVoxelAroundItsCentre) {
    const float one = 0.75f;
    const glm::vec3 centre(10.0f, -2.0f, 0.5f), vs(0.5f, 0.25f, 1.0f);
    writeFogVdb(path("one.vdb"), "density", 1, 1, 1, &one, centre, vs);
    LoadedVdbGrid g = loadVdbGrid({.path = path("one.vdb")});
    EXPECT_EQ(g.activeVoxelCount, 1u);
    EXPECT_EQ(g.worldBounds.lo, centre - 0.5f * vs);
    EXPECT_EQ(g.worldBounds.hi, centre + 0.5f * vs);
    EXPECT_EQ(g.maxValue, 0.75f);
}

TEST_F(VdbBake, CallbackBakeSamplesVoxelCentresAndMatchesDense) {
    const glm::ivec3 res(20, 11, 9);
    const glm::vec3 vs(0.05f), origin = glm::vec3(-0.5f) + 0.5f * vs;
    auto field = [](glm::vec3 p) { return std::max(0.0f, 0.3f - glm::length(p)) * 10.0f; };
    std::atomic<int> calls{0};
    VdbBakeStats stats = bakeFogVdb(path("cb.vdb"), "density", res, origin, vs, [&](glm::vec3 p) {
        ++calls;
        return field(p);
    });
    EXPECT_EQ(calls.load(), res.x * res.y * res.z);
    EXPECT_GT(stats.activeVoxelCount, 0u);

    std::vector<float> dense(std::size_t(res.x) * res.y * res.z);
    for (int k = 0; k < res.z; ++k)
        for (int j = 0; j < res.y; ++j)
            for (int i = 0; i < res.x; ++i)
                dense[i + res.x * (j + res.y * k)] =
                    field(glm::vec3(glm::dvec3(origin) + glm::dvec3(i, j, k) * glm::dvec3(vs)));
    writeFogVdb(path("dense.vdb"), "density", res.x, res.y, res.z, dense.data(), origin, vs);

    LoadedVdbGrid a = loadVdbGrid({.path = path("cb.vdb")});
    LoadedVdbGrid b = loadVdbGrid({.path = path("dense.vdb")});
    EXPECT_EQ(a.activeVoxelCount, b.activeVoxelCount);
    auto accA = a.grid()->getAccessor();
    auto accB = b.grid()->getAccessor();
    for (int k = 0; k < res.z; ++k)
        for (int j = 0; j < res.y; ++j)
            for (int i = 0; i < res.x; ++i) {
                const nanovdb::Coord ijk(i, j, k);
                ASSERT_EQ(accA.getValue(ijk), accB.getValue(ijk)) << i << " " << j << " " << k;
                // The value at index (i,j,k) is the field at the world point of that index.
                const glm::vec3 w =
                    glm::vec3(a.worldFromIndex * glm::vec4(float(i), float(j), float(k), 1.0f));
                ASSERT_NEAR(accA.getValue(ijk), field(w), 1e-5f);
            }
}

TEST_F(VdbBake, ToleranceDropsSmallAndNegativeSamples) {
    const std::vector<float> dense = {0.0f, 0.01f, 0.02f, -1.0f, 0.5f, 0.015f, 0.0f, 2.0f};
    VdbBakeStats s = writeFogVdb(path("tol.vdb"), "smoke", 8, 1, 1, dense.data(), glm::vec3(0),
                                 glm::vec3(1), 0.015f);
    EXPECT_EQ(s.activeVoxelCount, 3u); // 0.02, 0.5, 2
    LoadedVdbGrid g = loadVdbGrid({.path = path("tol.vdb"), .gridName = "smoke"});
    auto acc = g.grid()->getAccessor();
    const float expected[8] = {0, 0, 0.02f, 0, 0.5f, 0, 0, 2.0f};
    for (int i = 0; i < 8; ++i) EXPECT_EQ(acc.getValue(nanovdb::Coord(i, 0, 0)), expected[i]);
    EXPECT_EQ(g.negativeCount, 0u);
}

TEST_F(VdbBake, AllZeroBakeIsAnEmptyGrid) {
    const std::vector<float> zeros(64, 0.0f);
    VdbBakeStats s =
        writeFogVdb(path("zero.vdb"), "density", 4, 4, 4, zeros.data(), glm::vec3(0), glm::vec3(1));
    EXPECT_EQ(s.activeVoxelCount, 0u);
    EXPECT_EQ(s.leafCount, 0u);
    LoadedVdbGrid g = loadVdbGrid({.path = path("zero.vdb")});
    EXPECT_TRUE(g.empty());
    EXPECT_EQ(g.warnings.size(), 1u);
}

TEST_F(VdbBake, BadInputsAreRefusedAndNothingIsWritten) {
    std::vector<float> dense(27, 1.0f);
    dense[1 + 3 * (2 + 3 * 1)] = std::numeric_limits<float>::quiet_NaN();
    std::string msg = bakeError([&] {
        writeFogVdb(path("nan.vdb"), "density", 3, 3, 3, dense.data(), glm::vec3(0), glm::vec3(1));
    });
    EXPECT_TRUE(contains(msg, "nan.vdb: grid \"density\": sample (1, 2, 1) is nan"));
    msg = bakeError([&] {
        writeFogVdb(path("vs.vdb"), "density", 3, 3, 3, dense.data(), glm::vec3(0),
                    glm::vec3(1, 0, 1));
    });
    EXPECT_TRUE(contains(msg, "voxel size > 0"));
    msg = bakeError([&] {
        writeFogVdb(path("res.vdb"), "density", 0, 3, 3, dense.data(), glm::vec3(0), glm::vec3(1));
    });
    EXPECT_TRUE(contains(msg, "at least 1 voxel"));
    msg = bakeError([&] {
        bakeFogVdb(path("cb.vdb"), "density", glm::ivec3(2), glm::vec3(0), glm::vec3(1),
                   [](glm::vec3) { return std::numeric_limits<float>::infinity(); });
    });
    EXPECT_TRUE(contains(msg, "is inf"));
    EXPECT_TRUE(listing().empty()) << listing().front();
}

TEST_F(VdbBake, AFailedWriteIsAVdbErrorAndLeavesTheOldFile) {
    const float one = 1.0f;
    writeFogVdb(path("keep.vdb"), "density", 1, 1, 1, &one, glm::vec3(0), glm::vec3(1));
    // A directory where the file should go: the rename fails.
    fs::create_directories(path("taken.vdb"));
    std::string msg = bakeError([&] {
        writeFogVdb(path("taken.vdb"), "density", 1, 1, 1, &one, glm::vec3(0), glm::vec3(1));
    });
    EXPECT_TRUE(contains(msg, "taken.vdb: cannot write the VDB file"));
    EXPECT_EQ(loadVdbGrid({.path = path("keep.vdb")}).activeVoxelCount, 1u);
    EXPECT_EQ(listing().size(), 2u) << "no temp file left behind";
}
