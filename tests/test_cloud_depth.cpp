// The cloud's depth along the sun (core/lighting/cloud_depth.h) against closed forms on boxes,
// and render.multiple_scattering = "auto" choosing its model from it (core/plan.cpp): photons
// where the cloud is thin, the diffusion grid where it is thick, the same image as naming the
// model it chose, the photons' voxel and the grid's cell from the cloud's occupied volume.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <tbb/task_arena.h>

#include "core/fields/field.h"
#include "core/lighting/cloud_depth.h"
#include "core/plan.h"
#include "render_util.h"
#include "scenes.h"

using namespace nimbus;

namespace {

Field boxField(const Box& b, float density) {
    FieldDesc d;
    d.kind = FieldKind::Homogeneous;
    d.homogeneous.box = b;
    d.homogeneous.density = density;
    return makeField(d, 0.0f);
}

} // namespace

TEST(CloudDepth, AlongAnAxisIsTheBoxsDepth) {
    // a 2 x 1 x 4 box of density 0.5, sigma_t 3: along x every ray crosses 2 units
    const Box b{vec3(-1.0f, 0.0f, -2.0f), vec3(1.0f, 1.0f, 2.0f)};
    const CloudDepth d =
        measureCloudDepth(boxField(b, 0.5f), b, vec3(1.0f, 0.0f, 0.0f), 3.0f, 0.05f);
    EXPECT_EQ(d.rays, 32 * 32);
    EXPECT_EQ(d.hits, d.rays); // the projection is the box's face: every ray hits
    EXPECT_NEAR(d.meanTau, 3.0 * 0.5 * 2.0, 1e-3);
    EXPECT_NEAR(d.occupiedVolume, 8.0, 1e-3);
    // along z: 4 units
    const CloudDepth z =
        measureCloudDepth(boxField(b, 0.5f), b, vec3(0.0f, 0.0f, -2.0f), 3.0f, 0.05f);
    EXPECT_NEAR(z.meanTau, 6.0, 1e-3);
}

TEST(CloudDepth, ObliqueIsMassOverProjectedArea) {
    // any direction: the mean depth of the rays that meet the box is sigma_t rho V / A, A the
    // box's projected area |dx| Ly Lz + |dy| Lx Lz + |dz| Lx Ly (Cauchy); the lattice of rays
    // over the projection's bounding square counts A to within its cells
    const Box b{vec3(0.0f), vec3(1.0f, 2.0f, 3.0f)};
    const vec3 dir = glm::normalize(vec3(0.3f, 0.8f, -0.5f));
    const CloudDepth d = measureCloudDepth(boxField(b, 1.0f), b, dir, 2.0f, 0.01f, 128);
    const double area = std::abs(dir.x) * 6.0 + std::abs(dir.y) * 3.0 + std::abs(dir.z) * 2.0;
    EXPECT_NEAR(d.meanTau, 2.0 * 6.0 / area, 0.02 * 2.0 * 6.0 / area);
    EXPECT_NEAR(d.occupiedVolume, 6.0, 0.02 * 6.0);
}

TEST(CloudDepth, OnlyTheRaysThatMeetDensityCount) {
    // the field fills a quarter of the bounds' width and depth: the empty rays do not dilute
    // the mean, and the occupied volume is the field's
    const Box field{vec3(0.0f), vec3(1.0f)};
    const Box bounds{vec3(-1.0f), vec3(1.0f)};
    const CloudDepth d =
        measureCloudDepth(boxField(field, 2.0f), bounds, vec3(0.0f, 1.0f, 0.0f), 1.0f, 0.02f);
    EXPECT_NEAR(d.hitFraction(), 0.25, 0.01);
    EXPECT_NEAR(d.meanTau, 2.0, 0.03);
    EXPECT_NEAR(d.occupiedVolume, 1.0, 0.03);
    // the box of the samples with density is the field's, grown by at most half the lattice's
    // spacing (2/32) and clipped to the bounds
    for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(d.occupiedBox.lo[a], 0.0f, 0.0625f) << a;
        EXPECT_NEAR(d.occupiedBox.hi[a], 1.0f, 0.0625f) << a;
        EXPECT_LE(d.occupiedBox.lo[a], 0.0f) << a << ": it holds every sample with density";
        EXPECT_GE(d.occupiedBox.hi[a], 1.0f) << a;
    }
    // nothing there: no hits, depth 0, no box
    const CloudDepth none =
        measureCloudDepth(boxField(field, 0.0f), bounds, vec3(0.0f, 1.0f, 0.0f), 1.0f, 0.02f);
    EXPECT_EQ(none.hits, 0);
    EXPECT_EQ(none.meanTau, 0.0);
    EXPECT_TRUE(none.occupiedBox.empty());
}

TEST(CloudDepth, MeasuredAgainOverItsOccupiedBoxNearlyEveryRayHits) {
    // a small cloud in wide bounds (daichi_smoke: 1% of the rays along the sun over its bounds
    // meet it): the photons leave over the box holding density, and the plan measures the share
    // of them that reach it over the box measureCloudDepth found (core/plan.cpp)
    const Box cloud{vec3(0.5f, 0.2f, -1.0f), vec3(2.5f, 2.2f, 1.0f)};
    const Box bounds{vec3(-4.0f), vec3(4.0f)};
    const vec3 sun = glm::normalize(vec3(0.3f, 1.0f, 0.2f));
    const Field f = boxField(cloud, 1.0f);
    const CloudDepth wide = measureCloudDepth(f, bounds, sun, 1.0f, 0.02f);
    EXPECT_LT(wide.hitFraction(), 0.1);
    const CloudDepth tight = measureCloudDepth(f, wide.occupiedBox, sun, 1.0f, 0.02f);
    // the box's projection along an oblique sun is a hexagon in a rectangle: the rays over the
    // rectangle's corners miss, and the box grew by up to a lattice cell of the wide pass (0.43)
    EXPECT_GT(tight.hitFraction(), 0.5);
    RecordProperty("wide_hit_fraction", std::to_string(wide.hitFraction()));
    RecordProperty("tight_hit_fraction", std::to_string(tight.hitFraction()));
    EXPECT_NEAR(tight.meanTau, wide.meanTau, 0.1 * wide.meanTau) << "the same cloud";
}

TEST(CloudDepth, SameOnAnyThreadCount) {
    const Box b{vec3(0.0f), vec3(1.0f, 2.0f, 3.0f)};
    const vec3 dir = glm::normalize(vec3(0.3f, 0.8f, -0.5f));
    const Field f = boxField(b, 1.0f);
    const CloudDepth many = measureCloudDepth(f, b, dir, 2.0f, 0.01f);
    tbb::task_arena one(1);
    const CloudDepth single =
        one.execute([&] { return measureCloudDepth(f, b, dir, 2.0f, 0.01f); });
    EXPECT_EQ(many.meanTau, single.meanTau);
    EXPECT_EQ(many.occupiedVolume, single.occupiedVolume);
}

namespace {

/// The 2-unit box of tests/scenes.h lit from the side, at the optical depth `tau` across.
SceneDesc boxAtDepth(float tau) {
    SceneDesc s = sunlitBox(tau / 2.0f, 16, 0.0f, 90.0f); // the sun along +x: 2 units of box
    s.sky.kind = SkyKind::None;
    s.render.photons = 20000;
    return s;
}

/// boxAtDepth under a uniform sky at albedo 1/1.1: where "auto" chooses photons it traces the
/// sky by photons too.
SceneDesc absorbingBoxAtDepth(float tau) {
    SceneDesc s = boxAtDepth(tau);
    s.sky.kind = SkyKind::Uniform;
    s.medium.sigma_a = 0.1f * s.medium.sigma_s;
    return s;
}

} // namespace

TEST(AutoMultipleScattering, PhotonsWhereThinTheGridWhereThick) {
    SceneDesc thin = boxAtDepth(1.0f);
    ASSERT_EQ(thin.render.multipleScattering, MultipleScattering::Auto); // the default
    const FramePlan a = planFrame(thin, 1);
    EXPECT_TRUE(a.msAuto);
    EXPECT_TRUE(a.photons);
    EXPECT_FALSE(a.diffusion); // no sky here: nothing for the grid
    EXPECT_NEAR(a.cloudTau, 1.0, 1e-3);
    EXPECT_NE(a.msDecision.find("photons"), std::string::npos) << a.msDecision;
    EXPECT_NE(a.explain().find("mean optical depth along the sun 1 <="), std::string::npos)
        << a.explain();

    // a thick albedo-1 cloud (the validation matrix's thick rows are 500 deep) still gets
    // photons, walking a grid of their own and the similar medium deep in it
    const FramePlan deep = planFrame(boxAtDepth(500.0f), 1);
    EXPECT_TRUE(deep.photons);
    EXPECT_FALSE(deep.diffusion);
    EXPECT_NEAR(deep.cloudTau, 500.0, 0.5);
    EXPECT_TRUE(deep.photonOwnWalk);
    EXPECT_GT(deep.photonSimilarity, 0);
    EXPECT_NE(deep.msDecision.find("500 <= render.photon_depth 1000"), std::string::npos)
        << deep.msDecision;

    // above render.photon_depth (1000 by default) the grid bounds the frame's cost
    const SceneDesc thick = boxAtDepth(2000.0f);
    const FramePlan b = planFrame(thick, 1);
    EXPECT_FALSE(b.photons);
    EXPECT_TRUE(b.diffusion);
    EXPECT_NEAR(b.cloudTau, 2000.0, 1.0);
    EXPECT_GT(b.forwardFraction, 0.0f); // the grid's model whole, delta-M beams included
    EXPECT_NE(b.msDecision.find("2000 > render.photon_depth 1000"), std::string::npos)
        << b.msDecision;

    // the threshold is the key's: just above and below it
    thin.render.photonDepth = 0.99f;
    EXPECT_FALSE(planFrame(thin, 1).photons);
    thin.render.photonDepth = 1.01f;
    EXPECT_TRUE(planFrame(thin, 1).photons);
    thin.render.photonDepth = 0.0f; // 0: always the grid, whatever the depth
    const FramePlan off = planFrame(thin, 1);
    EXPECT_FALSE(off.photons);
    EXPECT_TRUE(off.diffusion);
    EXPECT_NE(off.msDecision.find("render.photon_depth = 0"), std::string::npos) << off.msDecision;
}

// In a medium that absorbs, "auto" compares render.photon_depth with the depth the diffuse light
// reaches before absorption takes it, 1 / sqrt(3 (1 - a)(1 - a g)) mean free paths, where that
// is less than the cloud's depth along the sun: a thick cloud at albedo 0.9 gets photons (their
// walks end within about ten scatterings) at any depth, one at albedo 1 only up to
// render.photon_depth.
TEST(AutoMultipleScattering, PhotonsInThickCloudsWhereAbsorptionKeepsTheLightNearTheirSkin) {
    SceneDesc s = absorbingBoxAtDepth(200.0f); // albedo 1/1.1, optical depth 220
    ASSERT_EQ(s.medium.phase, PhaseKind::HenyeyGreenstein);
    const double a = 1.0 / 1.1, g = double(s.medium.g);
    const double reach = 1.0 / std::sqrt(3.0 * (1.0 - a) * (1.0 - a * g)); // 2.59 at g 0.5
    const FramePlan p = planFrame(s, 1);
    EXPECT_NEAR(p.cloudTau, 220.0, 0.1);
    EXPECT_TRUE(p.msAuto);
    EXPECT_TRUE(p.photons);
    EXPECT_TRUE(p.photonSky); // as "auto" does wherever it gives an absorbing cloud photons
    char depth[32];
    std::snprintf(depth, sizeof depth, "%.3g <=", reach);
    EXPECT_NE(p.msDecision.find("the depth the medium's absorption lets diffuse light reach"),
              std::string::npos)
        << p.msDecision;
    EXPECT_NE(p.msDecision.find(depth), std::string::npos) << p.msDecision;

    // the threshold is render.photon_depth's, on that depth
    s.render.photonDepth = float(0.99 * reach);
    const FramePlan below = planFrame(s, 1);
    EXPECT_FALSE(below.photons);
    EXPECT_TRUE(below.diffusion);
    s.render.photonDepth = float(1.01 * reach);
    EXPECT_TRUE(planFrame(s, 1).photons);

    // the mean cosine counts: isotropic scattering at the same albedo reaches less deep
    s.medium.g = 0.0f;
    s.render.photonDepth = float(0.99 * reach);
    EXPECT_TRUE(planFrame(s, 1).photons); // 1 / sqrt(3 (1 - a)) = 1.91 < 0.99 x 2.59

    // the channel that absorbs least decides: its walks go on; one that does not absorb at all
    // leaves the cloud's depth, and the grid
    SceneDesc blue = boxAtDepth(2000.0f);
    blue.medium.sigma_a = vec3(0.0f, 0.0f, 0.1f) * blue.medium.sigma_s;
    const FramePlan q = planFrame(blue, 1);
    EXPECT_FALSE(q.photons);
    char cloud[80];
    // (from 1000 the depth is shown whole)
    std::snprintf(cloud, sizeof cloud, "the cloud's mean optical depth along the sun %.0f >",
                  q.cloudTau);
    EXPECT_NE(q.msDecision.find(cloud), std::string::npos) << q.msDecision;
}

TEST(AutoMultipleScattering, RendersWhatItChose) {
    // "auto" on the thin box is the image of "photons" named, bit for bit; on the thick box the
    // image of "grid"
    SceneDesc s = boxAtDepth(1.0f);
    const Framebuffer autoThin = renderScene(s);
    s.render.multipleScattering = MultipleScattering::Photons;
    const Framebuffer photons = renderScene(s);
    ASSERT_EQ(autoThin.rgba.size(), photons.rgba.size());
    EXPECT_EQ(autoThin.rgba, photons.rgba);
    s.render.multipleScattering = MultipleScattering::Grid;
    EXPECT_NE(renderScene(s).rgba, photons.rgba); // (the two models differ here)

    // on the thick box the image of "grid" named on the cell "auto" chose for it
    SceneDesc t = boxAtDepth(2000.0f);
    const float cell = planFrame(t, 1).lightVolumeCell;
    const Framebuffer autoThick = renderScene(t);
    t.render.multipleScattering = MultipleScattering::Grid;
    t.render.lightVolumeCell = cell;
    EXPECT_EQ(autoThick.rgba, renderScene(t).rgba);
}

// Photons walk a majorant grid of their own where their voxel is optically deep at the cloud's
// mean extinction (render.photon_walk_depth), march's elsewhere: the plan measures the depth,
// says which and counts the memory of the one chosen, and the image follows the choice alone.
TEST(PhotonWalk, TheirOwnGridWhereTheirVoxelIsDeep) {
    SceneDesc s = boxAtDepth(30.0f); // an extinction of 15 across the box's 2 units
    s.render.multipleScattering = MultipleScattering::Photons;
    const FramePlan p = planFrame(s, 1);
    ASSERT_TRUE(p.photons);
    EXPECT_NEAR(p.cloudExtinction, 15.0, 0.15);
    const double depth = p.cloudExtinction * double(p.photonCell);
    ASSERT_GT(depth, 0.0);
    s.render.photonWalkDepth = float(1.01 * depth);
    const FramePlan shallow = planFrame(s, 1);
    EXPECT_FALSE(shallow.photonOwnWalk);
    EXPECT_NE(shallow.explain().find("walking march's majorant grid"), std::string::npos)
        << shallow.explain();
    const Framebuffer onMarch = renderScene(s);
    s.render.photonWalkDepth = float(0.99 * depth);
    const FramePlan deep = planFrame(s, 1);
    EXPECT_TRUE(deep.photonOwnWalk);
    EXPECT_NE(deep.explain().find("walking a majorant grid of their own"), std::string::npos)
        << deep.explain();
    // their own walk keeps two bounds a tracking cell instead of one a majorant cell: the plan
    // counts the bytes of the walk it chose, which the trace holds
    EXPECT_NE(deep.photonGridBytes, shallow.photonGridBytes);
    RenderStats st;
    const Framebuffer own = renderScene(s, &st);
    EXPECT_NEAR(deep.photonGridBytes / st.photonBytes, 1.0, 0.02);
    EXPECT_NE(own.rgba, onMarch.rgba);
    // the image is the choice's: bit for bit that of 0 (always their own) and of a depth no
    // voxel reaches (always march's)
    s.render.photonWalkDepth = 0.0f;
    EXPECT_EQ(renderScene(s).rgba, own.rgba);
    s.render.photonWalkDepth = 1e30f;
    EXPECT_EQ(renderScene(s).rgba, onMarch.rgba);
}

// Where photons carry the sun's multiple scattering, march splits its steps at
// render.photon_step_tau, elsewhere at render.step_tau: the plan says which, and the image
// follows that key alone (docs/accuracy.md, "Finer steps where photons carry the light").
TEST(AutoMultipleScattering, PhotonsSplitStepsAtTheirOwnDepth) {
    SceneDesc s = boxAtDepth(30.0f); // photons: 30 along the sun is below photon_depth
    s.render.step = 0.5f;            // steps of 7.5 mean free paths: split
    s.render.shadowStep = 0.5f;
    s.render.stepTau = 0.5f;
    s.render.photonStepTau = 0.125f;
    const FramePlan a = planFrame(s, 1);
    ASSERT_TRUE(a.photons);
    EXPECT_EQ(a.stepTau, 0.125f);
    EXPECT_NE(a.explain().find("exceeds 0.125 (render.photon_step_tau"), std::string::npos)
        << a.explain();
    const SceneDesc thick = boxAtDepth(2000.0f); // the grid
    const FramePlan b = planFrame(thick, 1);
    ASSERT_FALSE(b.photons);
    EXPECT_EQ(b.stepTau, thick.render.stepTau);
    EXPECT_NE(b.explain().find("(render.step_tau)"), std::string::npos) << b.explain();

    // under photons step_tau leaves the image as it was, bit for bit; photon_step_tau moves it
    const Framebuffer base = renderScene(s);
    s.render.stepTau = 0.0f;
    EXPECT_EQ(renderScene(s).rgba, base.rgba);
    s.render.photonStepTau = 0.0f; // whole steps
    EXPECT_NE(renderScene(s).rgba, base.rgba);
}

TEST(AutoMultipleScattering, GridCellFollowsTheCloudsSize) {
    // "auto" choosing the grid, render.light_volume_cell 0: the finest of 1/8 ... 1 majorant
    // cells at which the cloud fills at most 262,144 cells
    SceneDesc s = boxAtDepth(2000.0f);
    FramePlan p = planFrame(s, 1);
    ASSERT_TRUE(p.diffusion);
    ASSERT_FALSE(p.photons);
    EXPECT_NEAR(p.cloudVolume, 8.0, 0.2); // the 2-unit box
    // the box on its majorant cells of 0.2: 512,000 cells at 1/8, 64,000 at 1/4
    ASSERT_FLOAT_EQ(p.majorantCell, 0.2f);
    EXPECT_FLOAT_EQ(p.lightVolumeCell, 0.05f);
    EXPECT_NE(p.explain().find("of the majorant cell, at which the cloud fills"), std::string::npos)
        << p.explain();

    // majorant cells of 0.1: the box fills 4.1 M cells at 1/8, 512,000 at 1/4, 64,000 at 1/2
    s.render.majorantCell = 0.1f;
    p = planFrame(s, 1);
    EXPECT_FLOAT_EQ(p.lightVolumeCell, 0.05f);
    // majorant cells of 0.03: 296,296 cells at 1 already; never coarser than the majorant cell
    s.render.majorantCell = 0.03f;
    EXPECT_FLOAT_EQ(planFrame(s, 1).lightVolumeCell, 0.03f);

    // a named cell is kept, and a thin cloud (photons) keeps the majorant cell
    s.render.majorantCell = 0.1f;
    s.render.lightVolumeCell = 0.1f;
    EXPECT_FLOAT_EQ(planFrame(s, 1).lightVolumeCell, 0.1f);
    s.render.lightVolumeCell = 0.0f;
    // the grid named takes the same cell as the grid "auto" chose
    s.render.multipleScattering = MultipleScattering::Grid;
    p = planFrame(s, 1);
    EXPECT_FALSE(p.msAuto);
    EXPECT_FLOAT_EQ(p.lightVolumeCell, 0.05f);
    EXPECT_FALSE(p.gridCellNote.empty());
    EXPECT_NE(p.explain().find("of the majorant cell, at which the cloud fills"), std::string::npos)
        << p.explain();
    // ... and at albedo 0 nothing in-scatters: no grid, no measurement, the majorant cell
    SceneDesc absorbing = s;
    absorbing.medium.sigma_a = absorbing.medium.sigma_s + absorbing.medium.sigma_a;
    absorbing.medium.sigma_s = vec3(0.0f);
    p = planFrame(absorbing, 1);
    EXPECT_FLOAT_EQ(p.lightVolumeCell, 0.1f);
    EXPECT_FALSE(p.cloudMeasured());
    s.render.multipleScattering = MultipleScattering::Auto;
    SceneDesc thin = boxAtDepth(1.0f);
    thin.render.majorantCell = 0.1f;
    EXPECT_FLOAT_EQ(planFrame(thin, 1).lightVolumeCell, 0.1f);

    // the diffusion's memory follows the finer grid
    s.render.multipleScattering = MultipleScattering::Auto;
    const double fine = planFrame(s, 1).diffusionBytes;
    s.render.lightVolumeCell = 0.1f;
    const double coarse = planFrame(s, 1).diffusionBytes;
    EXPECT_GT(fine / coarse, 6.0) << fine << " B against " << coarse << " B";
}

TEST(AutoMultipleScattering, NamedModelsAreNotChosen) {
    // a named model is taken as named; the grid's cloud is measured for its cell only
    for (MultipleScattering ms : {MultipleScattering::Grid, MultipleScattering::None}) {
        SceneDesc s = boxAtDepth(1.0f);
        s.render.multipleScattering = ms;
        const FramePlan p = planFrame(s, 1);
        EXPECT_FALSE(p.msAuto);
        EXPECT_FALSE(p.photons);
        EXPECT_EQ(p.diffusion, ms == MultipleScattering::Grid);
        EXPECT_EQ(p.cloudMeasured(), ms == MultipleScattering::Grid);
    }
}

TEST(AutoMultipleScattering, NoSunKeepsTheGrid) {
    SceneDesc s = boxAtDepth(1.0f);
    s.sun.enabled = false;
    s.sky.kind = SkyKind::Uniform;
    const FramePlan p = planFrame(s, 1);
    EXPECT_FALSE(p.photons);
    EXPECT_TRUE(p.diffusion);
    EXPECT_NE(p.msDecision.find("no sun"), std::string::npos) << p.msDecision;
}

TEST(AutoMultipleScattering, PhotonVoxelFollowsTheCloudsSize) {
    // render.photon_cell_scale = 0 (the default): the finer of two rules over 1/16 ... 4
    // light-volume cells: the finest (not below 1/4) at which the cloud fills at most
    // photons / 256 voxels, and the finest (not below 1/8, 1/16 where the cloud is deeper than 2
    // along the sun) at which it fills at most photons x the share of the rays along the sun
    // that meet it / 20 voxels
    SceneDesc s = boxAtDepth(1.0f);
    s.render.multipleScattering = MultipleScattering::Photons;
    s.render.lightVolumeCell = 0.1f; // the box: 20^3 cells
    s.render.photons = 2000000;      // 7,812 voxels by the count; 100,000 by the photons reaching
    FramePlan p = planFrame(s, 1);
    EXPECT_NEAR(p.cloudHitFraction, 1.0, 0.05) << "the box fills its bounds";
    EXPECT_FLOAT_EQ(p.photonCell, 0.05f); // 64,000 voxels; 1/4 would be 512,000
    EXPECT_NE(p.explain().find("at least 256 leaving or 20 reaching wanted"), std::string::npos)
        << p.explain();
    s.render.photons = 1 << 30; // as fine as 1/8 cell, no finer in a cloud this thin
    EXPECT_FLOAT_EQ(planFrame(s, 1).photonCell, 0.0125f);
    {
        SceneDesc deep = boxAtDepth(20.0f); // deeper than 2 along the sun: down to 1/16
        deep.render.multipleScattering = MultipleScattering::Photons;
        deep.render.lightVolumeCell = 0.1f;
        deep.render.photons = 1 << 30;
        const FramePlan d = planFrame(deep, 1);
        EXPECT_FLOAT_EQ(d.photonCell, 0.00625f);
        EXPECT_NE(d.explain().find("not below 0.0625, the depth along the sun > 2"),
                  std::string::npos)
            << d.explain();
        deep.render.photons = 2000000; // 100,000 reaching: as in the thin box, 1/2 cell
        EXPECT_FLOAT_EQ(planFrame(deep, 1).photonCell, 0.05f);
    }
    s.render.photons = 1000; // as coarse as 4 cells
    EXPECT_FLOAT_EQ(planFrame(s, 1).photonCell, 0.4f);
    s.render.photons = 40000; // 2,000 reaching: 2 cells (1,000); 156 by the count: 4 cells
    EXPECT_FLOAT_EQ(planFrame(s, 1).photonCell, 0.2f);
    s.render.photonCellScale = 0.5f; // named: taken as it is
    EXPECT_FLOAT_EQ(planFrame(s, 1).photonCell, 0.05f);
}

TEST(AutoMultipleScattering, SkyGridOnThePhotonsFinerVoxel) {
    // photons carry the sun to the end, the diffusion grid the sky alone: on a grid finer than
    // the light-volume grid where the cloud is small, by the photons' rule of stop 45 (at least
    // 1/4 cell, 256 photons a voxel): the photons' own grid where theirs is that voxel, a grid
    // of its own where the photons' voxel is finer still; the light-volume grid otherwise
    SceneDesc s = boxAtDepth(8.0f);
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(0.7f, 1.0f, 1.3f);
    s.render.lightVolumeCell = 0.1f;
    s.render.photons = 16800000; // 65,625 voxels by the count: half a cell (40^3 on the box)
    FramePlan p = planFrame(s, 1);
    ASSERT_TRUE(p.photons);
    ASSERT_TRUE(p.diffusion);
    EXPECT_FLOAT_EQ(p.photonCell, 0.025f); // 840,000 photons reaching: a quarter cell
    EXPECT_FLOAT_EQ(p.diffusionCell, 0.05f);
    EXPECT_TRUE(p.diffusionOnPhotonGrid());
    EXPECT_FALSE(p.diffusionSharesPhotonGrid());
    EXPECT_FALSE(p.densityGrid); // nothing read on the light-volume grid
    EXPECT_NE(p.explain().find("sky: diffusion on a grid of voxel 0.05"), std::string::npos)
        << p.explain();
    s.render.photonCellScale = 0.5f; // named: the sky on the photons' grid
    p = planFrame(s, 1);
    EXPECT_FLOAT_EQ(p.diffusionCell, 0.05f);
    EXPECT_TRUE(p.diffusionSharesPhotonGrid());
    EXPECT_NE(p.explain().find("sky: diffusion on the photons' grid"), std::string::npos)
        << p.explain();
    s.render.photonCellScale = 2.0f; // photons coarser: the grid stays on its own cell
    EXPECT_FLOAT_EQ(planFrame(s, 1).diffusionCell, 0.1f);
    s.render.photonCellScale = 0.0f;
    s.render.photonBounces = 4; // a hand-off: its source lives on the light-volume grid
    EXPECT_FLOAT_EQ(planFrame(s, 1).diffusionCell, 0.1f);
    s.render.photonBounces = 0;

    // the white furnace on both finer grids: albedo 1 under a uniform sky gives L (1 - T) in
    // every pixel (a sun of 1e-6 keeps the photons, and adds nothing visible)
    s.sun.irradiance = vec3(1e-6f);
    auto furnace = [&](const SceneDesc& sc) {
        const Framebuffer fb = renderScene(sc, nullptr, AovSet{true, false});
        int cloudy = 0;
        for (int i = 0; i < fb.width * fb.height; ++i) {
            cloudy += fb.transmittance[3 * i] < 0.5f;
            for (int c = 0; c < 3; ++c) {
                const float expect = sc.sky.zenith[c] * (1.0f - fb.transmittance[3 * i + c]);
                ASSERT_NEAR(fb.rgba[4 * i + c], expect, 2e-3f * sc.sky.zenith[c])
                    << "pixel " << i << " channel " << c;
            }
        }
        EXPECT_GT(cloudy, 20) << "the furnace must look through the box";
    };
    s.render.photons = 20000;
    s.render.photonCellScale = 0.5f;
    ASSERT_TRUE(planFrame(s, 1).diffusionSharesPhotonGrid());
    furnace(s);
    // cells of 0.4: the count's rule 0.2 (1,000 voxels), the photons reaching 0.1 (8,000)
    s.render.lightVolumeCell = 0.4f;
    s.render.photonCellScale = 0.0f;
    s.render.photons = 300000;
    p = planFrame(s, 1);
    ASSERT_FLOAT_EQ(p.photonCell, 0.1f);
    ASSERT_FLOAT_EQ(p.diffusionCell, 0.2f);
    ASSERT_FALSE(p.diffusionSharesPhotonGrid());
    furnace(s);
}

TEST(AutoMultipleScattering, SkyByPhotonsWhereTheMediumAbsorbs) {
    // "auto" choosing photons traces the sky by photons too where some channel's albedo is
    // below 1 (the grid's sky is exact only at albedo 1), thin clouds too, with twice
    // render.photons shared between the lights; not at albedo 1, not under a named model, not
    // for the GLSL hosts
    SceneDesc s = boxAtDepth(8.0f);
    s.sky.kind = SkyKind::Uniform;
    s.render.photons = 30000;
    FramePlan p = planFrame(s, 1);
    ASSERT_TRUE(p.photons);
    EXPECT_FALSE(p.photonSky);
    EXPECT_TRUE(p.diffusion) << "the grid carries the sky at albedo 1";
    EXPECT_EQ(p.photonCount, 30000);

    s.medium.sigma_a = vec3(0.0f, 0.0f, 0.05f) * s.medium.sigma_s; // one channel absorbs
    p = planFrame(s, 1);
    EXPECT_TRUE(p.photonSky && p.photonSkyAuto && p.skySingle);
    EXPECT_FALSE(p.diffusion) << "no grid: the photons carry the sky";
    EXPECT_EQ(p.photonCount, 60000);
    EXPECT_NE(p.explain().find("sun and sky: 60000 photons"), std::string::npos) << p.explain();
    EXPECT_NE(p.explain().find("shared between the sun and the sky"), std::string::npos)
        << p.explain();
    RenderStats st;
    renderScene(s, &st);
    EXPECT_EQ(st.photonsTraced, 60000u);
    EXPECT_GT(st.photonsFromSky, 0u);

    SceneDesc thin = boxAtDepth(1.0f); // absorbing and thin: the sky by photons as well
    thin.sky.kind = SkyKind::Uniform;
    thin.medium.sigma_a = s.medium.sigma_a;
    thin.render.photons = 30000;
    p = planFrame(thin, 1);
    EXPECT_TRUE(p.photons && p.photonSky && p.photonSkyAuto);
    EXPECT_FALSE(p.diffusion);
    EXPECT_EQ(p.photonCount, 60000) << "a count named is doubled, not raised to the floor";
    EXPECT_EQ(p.photonVoxelCount, 60000);

    s.render.autoPhotonSky = false; // nimbus rt, export-glsl
    p = planFrame(s, 1);
    EXPECT_FALSE(p.photonSky);
    EXPECT_EQ(p.photonCount, 30000);
    s.render.autoPhotonSky = true;
    s.render.multipleScattering = MultipleScattering::Photons; // named: the key decides
    EXPECT_FALSE(planFrame(s, 1).photonSky);
    s.render.photonSky = true;
    p = planFrame(s, 1);
    EXPECT_TRUE(p.photonSky);
    EXPECT_FALSE(p.photonSkyAuto);
    EXPECT_EQ(p.photonCount, 30000) << "the key's photons, shared as documented";
}

TEST(AutoMultipleScattering,
     FourSkyDirectionsWhereTheSkysPhotonsLeaveItsSingleScatteringToMarches) {
    // render.sky_directions = 0 (the default): 4 directions where the sky's photons carry its
    // higher orders and its single scattering is marched, 8 where the sky alone is single-
    // scattered or read from the sky volume's fixed directions; a count named is the count
    SceneDesc s = absorbingBoxAtDepth(8.0f);
    EXPECT_EQ(s.render.skyDirections, 0);
    FramePlan p = planFrame(s, 1);
    ASSERT_TRUE(p.photonSky && p.skySingle);
    EXPECT_EQ(p.skyDirections, 4);
    s.render.skyDirections = 6;
    EXPECT_EQ(planFrame(s, 1).skyDirections, 6);
    s.render.skyDirections = 0;
    s.render.skyShadow = SkyShadow::Volume;
    p = planFrame(s, 1);
    ASSERT_TRUE(p.photonSky && p.skyVolume);
    EXPECT_EQ(p.skyDirections, 8) << "fixed directions blur with fewer";
    s.render.skyShadow = SkyShadow::March;
    s.render.multipleScattering = MultipleScattering::None;
    s.render.skyScattering = SkyScattering::Single;
    p = planFrame(s, 1);
    ASSERT_TRUE(p.skySingle && !p.photonSky);
    EXPECT_EQ(p.skyDirections, 8);
    s.sky.kind = SkyKind::None; // no sky: no directions
    EXPECT_EQ(planFrame(s, 1).skyDirections, 0);
}

TEST(AutoMultipleScattering, PhotonCountFollowsTheCloudsDepth) {
    // render.photons = 0 (the default): 2 M photons up to a depth of 2 along the sun, 1 M per
    // unit of depth above, 8 M from 8; "auto" tracing the sky too doubles the count; a count
    // named is the count
    EXPECT_EQ(SceneDesc{}.render.photons, 0);
    auto count = [](float tau) {
        SceneDesc s = boxAtDepth(tau);
        s.render.photons = 0;
        return planFrame(s, 1);
    };
    const FramePlan thin = count(1.0f);
    ASSERT_TRUE(thin.photons);
    EXPECT_EQ(thin.photonCount, 2000000);
    EXPECT_NE(thin.explain().find("render.photons = 0: from the cloud's mean optical depth"),
              std::string::npos)
        << thin.explain();
    EXPECT_NEAR(double(count(2.0f).photonCount), 2.0e6, 2.0e3);
    EXPECT_NEAR(double(count(5.0f).photonCount), 5.0e6, 2.0e3); // the box's depth to 1e-3
    EXPECT_EQ(count(8.5f).photonCount, 8000000);
    EXPECT_EQ(count(40.0f).photonCount, 8000000);
    // between the two the count grows with the depth, never down
    std::int64_t last = 0;
    for (float tau = 1.0f; tau <= 10.0f; tau += 0.5f) {
        const std::int64_t n = count(tau).photonCount;
        EXPECT_GE(n, last) << "depth " << tau;
        last = n;
    }

    auto absorbing = [](float tau) { // "auto" traces the sky too
        SceneDesc s = absorbingBoxAtDepth(tau);
        s.render.photons = 0;
        return s;
    };
    const FramePlan both = planFrame(absorbing(20.0f), 1); // deep: twice the depth's 8 M
    ASSERT_TRUE(both.photonSkyAuto);
    EXPECT_EQ(both.photonCount, 16000000);
    EXPECT_EQ(both.photonVoxelCount, 16000000);
    // thin: at least 16 M with the sky's, the voxel sized for twice the depth's 2 M (the same
    // voxel as 4 M photons named would get)
    SceneDesc thinSky = absorbing(1.0f);
    const FramePlan floor = planFrame(thinSky, 1);
    ASSERT_TRUE(floor.photonSkyAuto);
    EXPECT_EQ(floor.photonCount, 16000000);
    EXPECT_EQ(floor.photonVoxelCount, 4000000);
    EXPECT_NE(floor.explain().find("at least 16 M, the voxel sized for 4000000"), std::string::npos)
        << floor.explain();
    thinSky.render.photons = 2000000; // named: twice that, on the voxel of that count
    const FramePlan named4 = planFrame(thinSky, 1);
    EXPECT_EQ(named4.photonCount, 4000000);
    EXPECT_FLOAT_EQ(named4.photonCell, floor.photonCell);

    SceneDesc named = boxAtDepth(20.0f);
    named.render.photons = 30000;
    const FramePlan n = planFrame(named, 1);
    EXPECT_EQ(n.photonCount, 30000);
    EXPECT_TRUE(n.photonCountNote.empty()) << n.photonCountNote;
}
