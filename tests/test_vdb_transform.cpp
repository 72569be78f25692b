// Index-to-world transforms of VDB grids in rendering: a grid rotated by a known transform seen
// by a camera rotated the same way gives the same image; non-uniform voxel sizes are honoured.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include <glm/gtc/matrix_transform.hpp>
#include <unistd.h>

#include "core/integrators/pathtrace.h"
#include "core/render.h"
#include "core/sampler.h"
#include "plugin/vdb/vdb_field.h"
#include "plugin/vdb/vdb_writer.h"
#include "stats.h"

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

/// A smooth blob on 24 x 16 x 12 voxels, zero on its outer shell.
vdb::VdbGridSpec blob(const glm::dmat4& worldFromIndex) {
    vdb::VdbGridSpec g;
    g.worldFromIndex = worldFromIndex;
    for (int k = 0; k < 12; ++k)
        for (int j = 0; j < 16; ++j)
            for (int i = 0; i < 24; ++i) {
                const double x = (i - 11.5) / 10.0, y = (j - 7.5) / 6.0, z = (k - 5.5) / 4.5;
                const double v = 1.0 - (x * x + y * y + z * z);
                if (v > 0.0) g.voxels.push_back({ivec3(i, j, k), 2.0 * v, true});
            }
    return g;
}

/// A rotated map with non-uniform voxel sizes (0.1, 0.2, 0.15), offset from the origin.
glm::dmat4 rotatedNonUniformMap() {
    return glm::scale(glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(1.0, 2.0, 3.0)), 0.7,
                                  glm::normalize(glm::dvec3(1.0, 2.0, 0.5))),
                      glm::dvec3(0.1, 0.2, 0.15));
}

/// A fresh folder under the temporary directory named for the test (removed by the caller).
fs::path freshDir(const std::string& tag) {
    const fs::path dir = fs::temp_directory_path() / (tag + "_" + std::to_string(getpid()));
    fs::create_directories(dir);
    return dir;
}

/// `g` written to dir/name and bound as a scene binds a [field] of kind "vdb"; `fd` becomes that
/// field's description.
GridBinding writeAndBind(const fs::path& dir, const std::string& name, const vdb::VdbGridSpec& g,
                         FieldDesc& fd) {
    vdb::writeVdbGrids((dir / name).string(), {g});
    fd.kind = FieldKind::Vdb;
    fd.vdb.path = (dir / name).string();
    std::vector<std::string> warnings;
    return vdb::bindVdbField(fd, "", 1, warnings);
}

SceneDesc sceneFor(const std::string& path, const glm::mat3& R) {
    SceneDesc s;
    s.field.kind = FieldKind::Vdb;
    s.field.vdb.path = path;
    const vec3 centre(1.0f + 0.1f * 11.5f, 2.0f + 0.2f * 7.5f, 3.0f + 0.15f * 5.5f);
    s.camera.position = R * (centre + vec3(0.7f, 0.9f, -6.0f));
    s.camera.lookAt = R * centre;
    s.camera.up = R * vec3(0.0f, 1.0f, 0.0f);
    s.camera.fovY = 35.0f;
    s.camera.width = 40;
    s.camera.height = 30;
    s.sun.direction = R * glm::normalize(vec3(0.3f, 0.8f, -0.5f));
    s.sun.irradiance = vec3(2.0f);
    s.sky.kind =
        SkyKind::None; // the gradient sky and its height-based ambient are not rotation invariant
    s.medium.sigma_s = vec3(2.0f);
    s.medium.sigma_a = vec3(0.2f);
    s.render.background = Background::Transparent;
    s.render.step = 0.02f;
    s.render.shadowStep = 0.02f;
    s.render.shadowGrowth = 0.0f;
    return s;
}

Framebuffer renderVdb(SceneDesc s) {
    std::vector<std::string> warnings;
    FrameBindings b;
    b.grids = {vdb::bindVdbField(s.field, "", 1, warnings)};
    Renderer r(s);
    Framebuffer fb;
    RenderStats st;
    EXPECT_TRUE(r.render(r.plan(1, b), b, fb, st));
    return fb;
}

} // namespace

TEST(VdbTransform, RotatedGridAndRotatedCameraGiveTheSameImage) {
    const fs::path dir = freshDir("nimbus_vdbxf");
    // non-uniform voxels (0.1, 0.2, 0.15) placed at (1, 2, 3); then the same rotated by 35 deg
    glm::dmat4 M = glm::translate(glm::dmat4(1.0), glm::dvec3(1.0, 2.0, 3.0)) *
                   glm::scale(glm::dmat4(1.0), glm::dvec3(0.1, 0.2, 0.15));
    const glm::dmat4 Rd =
        glm::rotate(glm::dmat4(1.0), glm::radians(35.0), glm::normalize(glm::dvec3(1.0, 2.0, 0.5)));
    vdb::writeVdbGrids((dir / "a.vdb").string(), {blob(M)});
    vdb::writeVdbGrids((dir / "b.vdb").string(), {blob(Rd * M)});
    const glm::mat3 R = glm::mat3(glm::mat4(Rd));
    Framebuffer a = renderVdb(sceneFor((dir / "a.vdb").string(), glm::mat3(1.0f)));
    Framebuffer b = renderVdb(sceneFor((dir / "b.vdb").string(), R));
    double se = 0.0, peak = 0.0;
    int covered = 0;
    for (size_t i = 0; i < a.rgba.size(); ++i) {
        se += (a.rgba[i] - b.rgba[i]) * (a.rgba[i] - b.rgba[i]);
        peak = std::max(peak, double(a.rgba[i]));
        if (i % 4 == 3) covered += a.rgba[i] > 0.1f;
    }
    ASSERT_GT(covered, 100) << "the blob must fill part of the frame";
    const double psnr = 10.0 * std::log10(peak * peak / (se / a.rgba.size()));
    EXPECT_GT(psnr, 50.0) << "PSNR of the rotated render against the unrotated one";
    fs::remove_all(dir);
}

TEST(VdbTransform, NonUniformVoxelSizesAreHonoured) {
    const fs::path dir = freshDir("nimbus_vdbnu");
    const glm::dmat4 M = glm::translate(glm::dmat4(1.0), glm::dvec3(1.0, 2.0, 3.0)) *
                         glm::scale(glm::dmat4(1.0), glm::dvec3(0.1, 0.2, 0.15));
    vdb::writeVdbGrids((dir / "a.vdb").string(), {blob(M)});
    SceneDesc s = sceneFor((dir / "a.vdb").string(), glm::mat3(1.0f));
    std::vector<std::string> warnings;
    const GridBinding grid = vdb::bindVdbField(s.field, "", 1, warnings);
    Field f = makeField(s.field, 0.0f, grid);
    // at voxel centres the density is the voxel value; the voxel of index (i, j, k) sits at
    // (1 + 0.1 i, 2 + 0.2 j, 3 + 0.15 k)
    for (ivec3 ijk : {ivec3(11, 7, 5), ivec3(5, 9, 3), ivec3(15, 6, 7)}) {
        const vec3 p(1.0f + 0.1f * ijk.x, 2.0f + 0.2f * ijk.y, 3.0f + 0.15f * ijk.z);
        const double x = (ijk.x - 11.5) / 10.0, y = (ijk.y - 7.5) / 6.0, z = (ijk.z - 5.5) / 4.5;
        EXPECT_NEAR(f.density(p), 2.0 * (1.0 - (x * x + y * y + z * z)), 1e-5);
    }
    // and the world bounds span the active voxels (i 2..21, j 2..13, k 2..9: 20 x 12 x 8
    // voxels) at those sizes, plus the same trilinear pad on every axis, which cancels here
    const vec3 e = f.bounds().extent();
    EXPECT_NEAR(e.x - e.y, 20 * 0.1f - 12 * 0.2f, 1e-3f);
    EXPECT_NEAR(e.x - e.z, 20 * 0.1f - 8 * 0.15f, 1e-3f);
    fs::remove_all(dir);
}

TEST(VdbTransform, MajorantSegmentsCoverTheLeavesAndSkipTheGap) {
    // two 8^3 leaves of density 1 at i = 0..7 and i = 24..31 (voxel size 1): trilinear density
    // is non-zero for x in (-1, 8) and (23, 32), so along a ray down the x axis the majorant
    // segments must cover those spans and skip most of the gap between them
    const fs::path dir = freshDir("nimbus_vdbmaj");
    vdb::VdbGridSpec g;
    for (int base : {0, 24})
        for (int k = 0; k < 8; ++k)
            for (int j = 0; j < 8; ++j)
                for (int i = 0; i < 8; ++i) g.voxels.push_back({ivec3(base + i, j, k), 1.0, true});
    FieldDesc fd;
    const GridBinding leaves = writeAndBind(dir, "leaves.vdb", g, fd);
    Field f = makeField(fd, 0.0f, leaves);
    const float cell = 0.5f;
    MajorantGrid grid = buildMajorantGrid(f, cell);
    const Ray ray{vec3(-20.0f, 3.5f, 3.5f), vec3(1.0f, 0.0f, 0.0f)};
    MajorantIterator it(&grid, f.bounds(), ray, 0.0f, 1e30f, 0.0f);
    MajorantSegment seg;
    std::vector<MajorantSegment> segs;
    while (it.next(seg)) segs.push_back(seg);
    ASSERT_FALSE(segs.empty());
    auto covered = [&](float x) {
        for (const auto& s : segs)
            if (x + 20.0f >= s.t0 && x + 20.0f <= s.t1) return true;
        return false;
    };
    const float margin = grid.cellSize.x * 1.1f; // a cell touching the support may stick out
    for (float x = -0.99f; x < 8.0f; x += 0.05f) EXPECT_TRUE(covered(x)) << "x = " << x;
    for (float x = 23.01f; x < 32.0f; x += 0.05f) EXPECT_TRUE(covered(x)) << "x = " << x;
    for (float x = 8.0f + margin; x < 23.0f - margin; x += 0.05f)
        EXPECT_FALSE(covered(x)) << "the gap must be skipped at x = " << x;
    for (const auto& s : segs) EXPECT_FLOAT_EQ(s.sigma_maj, 1.0f);
    // and the density really is zero where the segments skip
    for (float x = 8.0f + margin; x < 23.0f - margin; x += 0.25f)
        EXPECT_EQ(f.density(ray.at(x + 20.0f)), 0.0f);
    fs::remove_all(dir);
}

// GridField keeps a dense copy of a small grid's voxels (core/fields/grid.h): lookups through it
// must give the tree's values to the bit, inside the grid, at its borders and beyond the copy's
// box (where the tree is read again), under a rotated, non-uniform map.
TEST(VdbTransform, DenseCopyGivesTheTreesDensitiesBitForBit) {
    const fs::path dir = freshDir("nimbus_vdbdense");
    const glm::dmat4 worldFromIndex = rotatedNonUniformMap();
    FieldDesc fd;
    const GridBinding binding = writeAndBind(dir, "blob.vdb", blob(worldFromIndex), fd);
    fd.vdb.density = 1.7f;
    ASSERT_NE(binding.grid, nullptr);
    const Field dense = makeField(fd, 0.0f, binding);
    ASSERT_NE(dense.as<GridField>().dense, nullptr) << "a 24 x 16 x 12 grid fits the dense copy";
    Field sparse = dense;
    std::get<GridField>(sparse.data).dense.reset();
    // a copy whose dense voxels are all raised by 1: every point with density must see it (the
    // dense path is taken there, not silently the tree's)
    Field raised = dense;
    {
        auto copy = std::make_shared<DenseVoxels>(*dense.as<GridField>().dense);
        for (float& v : copy->values) v += 1.0f;
        std::get<GridField>(raised.data).dense = copy;
    }

    Sampler rng{7u, 0};
    auto u = [&] { return rng.next(); };
    const Box b = binding.bounds;
    const vec3 margin = 0.5f * (b.hi - b.lo); // well past the copy's 3-voxel pad
    std::size_t nonZero = 0, differ = 0, inside = 0, unraised = 0;
    for (int n = 0; n < 200000; ++n) {
        const vec3 t(u(), u(), u());
        const vec3 p = b.lo - margin + t * (b.hi - b.lo + 2.0f * margin);
        const float a = dense.density(p), s = sparse.density(p);
        nonZero += s > 0.0f;
        differ += std::memcmp(&a, &s, sizeof a) != 0;
        if (s > 0.0f) { // the stencil touches the grid's voxels: within the copy's box
            ++inside;
            unraised += raised.density(p) < s + 0.5f * fd.vdb.density;
        }
    }
    EXPECT_EQ(differ, 0u) << "the dense copy changed densities";
    EXPECT_GT(inside, 2000u);
    EXPECT_EQ(unraised, 0u) << "points with density were not read from the dense copy";
    EXPECT_GT(nonZero, 2000u) << "too few points in the blob";
    fs::remove_all(dir);
}

// A grid whose voxels span more than kDenseVoxelsMax stays sparse (no unbounded allocation),
// and its density is read from the tree.
TEST(VdbTransform, FarApartVoxelsKeepTheGridSparse) {
    const fs::path dir = freshDir("nimbus_vdbsparse");
    vdb::VdbGridSpec g;
    g.voxels.push_back({ivec3(0, 0, 0), 1.0, true});
    g.voxels.push_back({ivec3(4000, 4000, 4000), 1.0, true});
    FieldDesc fd;
    const GridBinding binding = writeAndBind(dir, "far.vdb", g, fd);
    ASSERT_NE(binding.grid, nullptr);
    const Field f = makeField(fd, 0.0f, binding);
    EXPECT_EQ(f.as<GridField>().dense, nullptr) << "4001^3 voxels must not be copied densely";
    EXPECT_EQ(f.density(vec3(0.0f)), 1.0f);
    EXPECT_EQ(f.density(vec3(4000.0f)), 1.0f);
    EXPECT_EQ(f.density(vec3(2000.5f)), 0.0f);
    fs::remove_all(dir);
}

// The path tracer's majorant grids are tight (buildMajorantGrid(..., tight)): each cell holds the
// largest voxel its trilinear stencils read. The bound must hold at every point of the cell,
// under a rotated, non-uniform map, and be tighter than the tree nodes' maxima.
TEST(VdbTransform, TightMajorantGridBoundsTheDensity) {
    const fs::path dir = freshDir("nimbus_vdbtight");
    const glm::dmat4 worldFromIndex = rotatedNonUniformMap();
    FieldDesc fd;
    const GridBinding binding = writeAndBind(dir, "blob.vdb", blob(worldFromIndex), fd);
    fd.vdb.density = 1.7f;
    const Field f = makeField(fd, 0.0f, binding);
    const float cell = 0.25f;
    const MajorantGrid loose = buildMajorantGrid(f, cell);
    const MajorantGrid tight = buildMajorantGrid(f, cell, 0.05f, nullptr, {}, true);
    ASSERT_EQ(tight.res, loose.res);
    double sumLoose = 0.0, sumTight = 0.0;
    std::size_t above = 0;
    for (size_t i = 0; i < tight.maj.size(); ++i) {
        sumLoose += loose.maj[i];
        sumTight += tight.maj[i];
        above += tight.maj[i] > loose.maj[i];
    }
    EXPECT_EQ(above, 0u) << "a voxel bound above the nodes' maxima";
    EXPECT_LT(sumTight, 0.8 * sumLoose) << "the voxel bounds are no tighter than the nodes'";

    // the bound against the density at 200,000 random points, and how close it comes
    Sampler rng{11u, 0};
    std::size_t over = 0, dense = 0;
    double ratio = 0.0, ratioLoose = 0.0;
    for (int n = 0; n < 200000; ++n) {
        const vec3 t(rng.next(), rng.next(), rng.next());
        const vec3 p = tight.bounds.lo + t * tight.bounds.extent();
        const ivec3 c = glm::clamp(ivec3(glm::floor((p - tight.bounds.lo) / tight.cellSize)),
                                   ivec3(0), tight.res - 1);
        const float rho = f.density(p);
        over += rho > tight.at(c);
        if (rho > 0.0f) {
            ++dense;
            ratio += rho / tight.at(c);
            ratioLoose += rho / loose.at(c);
        }
    }
    EXPECT_EQ(over, 0u) << "density above its cell's bound";
    ASSERT_GT(dense, 5000u);
    // delta tracking's real-collision share where there is density: larger (0.33 against 0.29)
    EXPECT_GT(ratio, 1.1 * ratioLoose)
        << ratio / double(dense) << " against " << ratioLoose / double(dense);
    fs::remove_all(dir);
}

// Delta tracking (the path's free flights) and ratio tracking (shadow rays) over the tight grid
// stay unbiased: through the blob, an absorbing medium under a uniform sky of radiance 1 as the
// background, the camera path's radiance is 1 when it escapes, so its mean is the
// transmittance, which the ratio tracking estimates too; both against the quadrature of the
// density along the ray. A majorant below the density anywhere would bias both.
TEST(VdbTransform, TrackingOverATightGridIsUnbiased) {
    const fs::path dir = freshDir("nimbus_vdbtighttrack");
    const glm::dmat4 worldFromIndex = glm::scale(
        glm::translate(glm::dmat4(1.0), glm::dvec3(1.0, 2.0, 3.0)), glm::dvec3(0.1, 0.2, 0.15));
    FieldDesc fd;
    const GridBinding written = writeAndBind(dir, "blob.vdb", blob(worldFromIndex), fd);
    ASSERT_NE(written.grid, nullptr);
    SceneDesc s = sceneFor(fd.vdb.path, glm::mat3(1.0f));
    s.render.integrator = Integrator::PathTrace;
    s.medium.sigma_s = vec3(0.0f);
    s.medium.sigma_a = vec3(0.6f);
    s.sun.irradiance = vec3(0.0f);
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(1.0f);
    s.render.background = Background::Sky;
    std::vector<std::string> warnings;
    FrameBindings b;
    b.grids = {vdb::bindVdbField(s.field, "", 1, warnings)};
    Renderer r(s);
    const FramePlan plan = r.plan(1, b);
    RenderStats st;
    const VolumeSet vs = r.volumesFor(plan, b, st);
    ASSERT_TRUE(vs.useGrid[0]);
    // the path tracer's grid is the tight one
    const MajorantGrid& grid = vs.grids[0];
    const MajorantGrid loose = buildMajorantGrid(vs.fields[0], plan.majorantCell);
    ASSERT_EQ(grid.res, loose.res);
    double sumGrid = 0.0, sumLoose = 0.0;
    for (size_t i = 0; i < grid.maj.size(); ++i) {
        sumGrid += grid.maj[i];
        sumLoose += loose.maj[i];
    }
    EXPECT_LT(sumGrid, 0.9 * sumLoose) << "the path tracer's majorant grid is not the tight one";
    PathContext ctx(s, plan, vs);

    const vec3 centre(1.0f + 0.1f * 11.5f, 2.0f + 0.2f * 7.5f, 3.0f + 0.15f * 5.5f);
    const vec3 o = centre - vec3(5.0f, 0.1f, 0.05f), d(1.0f, 0.0f, 0.0f);
    double tau = 0.0;
    const int N = 100000;
    for (int k = 0; k < N; ++k) tau += vs.densityAt(o + d * (10.0f * (k + 0.5f) / N)) * (10.0 / N);
    const double exact = std::exp(-0.6 * tau);
    ASSERT_GT(tau, 0.4);
    ASSERT_GT(exact, 0.05);
    RayCounters cnt;
    PathContext::Scratch scratch;
    std::vector<std::vector<double>> ratio, escaped;
    const int M = 20000;
    for (int k = 0; k < M; ++k) {
        Sampler rng{kern::pcg(std::uint32_t(k)), 0};
        ratio.push_back({double(ctx.transmittance(o, d, rng, cnt, scratch).x)});
        vec3 Tcam;
        float alpha, depth;
        const vec3 L = ctx.tracePath(Ray{o, d}, rng, Tcam, alpha, depth, cnt, scratch);
        escaped.push_back({double(L.x)});
    }
    const Estimate ratioT = estimateFromSamples(ratio), escapeT = estimateFromSamples(escaped);
    // alpha 0.01 each, and the power to see a 5% bias at this noise
    EXPECT_TRUE(zTestPasses(ratioT, exactValues({exact}), 0.01)) << "tau " << tau;
    EXPECT_TRUE(zTestPasses(escapeT, exactValues({exact}), 0.01)) << "tau " << tau;
    EXPECT_FALSE(zTestPasses(scaled(escapeT, 1.05), exactValues({exact}), 0.01));
    EXPECT_FALSE(zTestPasses(scaled(ratioT, 1.05), exactValues({exact}), 0.01));
    fs::remove_all(dir);
}
