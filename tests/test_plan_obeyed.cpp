// The renderer does what the frame plan (core/plan.h) names and nothing else, proven by counting
// the work actually done where it is done (DESIGN.md, demand 3: "leave out what a given scene
// does not need"): VDB grids read (plugin/vdb vdbReadCount, vdbRecentReads), Embree devices created
// (plugin/geom embreeDevicesCreated), and RenderStats' counters of shadow lookups, light-volume
// voxels, densities at the light grid's centres, diffusion iterations, photons traced, sky-volume
// bytes and AOV bytes. Every "no" case has a "yes" case beside it, so each test can fail.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/render.h"
#include "plugin/geom/embree_geometry.h"
#include "plugin/host/session.h"
#include "plugin/io/image_output.h"
#include "plugin/vdb/vdb_reader.h"
#include "plugin/vdb/vdb_writer.h"
#include "scenes.h"
#include "test_util.h"

using namespace nimbus;
namespace fs = std::filesystem;

namespace {

/// A 24x14 cumulus scene through the session (a fraction of a second to render).
std::string tinyScene(const std::string& extra = "") {
    return "color_space = \"lin_rec709\"\n"
           "frames = \"1\"\n"
           "[camera]\nposition = [0.0, 0.3, -24.0]\nlook_at = [0.0, 5.5, 0.0]\nfov = 45.0\n"
           "width = 24\nheight = 14\n"
           "[sun]\nelevation = 9.0\nazimuth = -30.0\nintensity = 12.0\n"
           "[medium]\nsigma_s = 12.0\ng = 0.5\n"
           "[field]\nkind = \"cumulus\"\nbounds_min = [-30.0, 1.2, -20.0]\n"
           "bounds_max = [30.0, 5.2, 40.0]\nbase_octaves = 2\ndetail_octaves = 1\n"
           "evaluation = \"direct\"\n"
           "[render]\nstep = 0.4\nshadow_step = 0.4\nthreads = 2\nmultiple_scattering = "
           "\"none\"\n" +
           extra;
}

/// Loads `text` (named `name`) into a session and renders its frame 1; fails the test on error.
void renderScene(host::Session& s, const std::string& text, const std::string& name,
                 RenderStats& stats, FramePlan* plan = nullptr) {
    host::Status st = s.loadString(text, name);
    ASSERT_TRUE(st.ok()) << st.message;
    s.takeWarnings();
    Framebuffer fb;
    st = s.render(1, fb, stats, {}, nullptr, plan);
    ASSERT_TRUE(st.ok()) << st.message;
}

/// The reads loadVdbGrid() made since vdbReadCount() was `before` (at most kVdbRecentReads).
std::vector<vdb::VdbRead> readsSince(std::uint64_t before) {
    const std::vector<vdb::VdbRead> recent = vdb::vdbRecentReads();
    const size_t n = std::min<size_t>(size_t(vdb::vdbReadCount() - before), recent.size());
    return std::vector<vdb::VdbRead>(recent.end() - std::ptrdiff_t(n), recent.end());
}

/// A grid of `name` holding a small blob of density around voxel (0, 0, 0).
vdb::VdbGridSpec blob(const std::string& name, double value) {
    vdb::VdbGridSpec g;
    g.name = name;
    g.worldFromIndex = glm::dmat4(0.5); // voxels of 0.5
    g.worldFromIndex[3][3] = 1.0;
    for (int z = -3; z <= 3; ++z)
        for (int y = -3; y <= 3; ++y)
            for (int x = -3; x <= 3; ++x) g.voxels.push_back({glm::ivec3(x, y, z), value, true});
    return g;
}

/// The small cumulus layer at 16x10 with coarse light grids: quick enough to render in every
/// combination of the plan's switches.
SceneDesc quickLayer() {
    SceneDesc s = smallCumulusLayer();
    s.camera.width = 16;
    s.camera.height = 10;
    s.render.step = 0.1f;
    s.render.shadowStep = 0.1f;
    s.render.lightVolumeCell = 0.5f;
    s.render.photons = 3000;
    s.render.threads = 2;
    s.sun.irradiance = vec3(3.0f);
    return s;
}

RenderStats renderDirect(const SceneDesc& s, FramePlan& plan, const AovSet& aovs = {},
                         Framebuffer* out = nullptr) {
    Renderer r(s);
    plan = r.plan(1, aovs);
    Framebuffer fb;
    RenderStats stats;
    EXPECT_TRUE(r.render(plan, out ? *out : fb, stats));
    return stats;
}

} // namespace

// A VDB file with three grids, the scene naming one, and a [[volume]] no instance places: only
// the named grid of the placed volume is read. The other grids' bytes are wiped, so reading
// them could not succeed; placing the spare volume reads it (the count can fail).
TEST(PlanObeyed, GridsTheSceneDoesNotNameAreNeverRead) {
    TempDir dir("plan_vdb");
    const std::string smoke = (dir / "smoke.vdb").string();
    vdb::writeVdbGrids(smoke, {blob("temperature", 7.0), blob("density", 1.0), blob("flame", 3.0)});
    vdb::writeVdbGrids((dir / "spare.vdb").string(), {blob("density", 2.0)});
    std::vector<char> bytes;
    {
        std::ifstream in(smoke, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    for (const vdb::VdbGridInfo& g : vdb::listVdbGrids(smoke)) {
        if (g.name == "density") continue;
        for (std::uint64_t i = g.dataBegin; i < g.dataEnd; ++i) bytes[i] = char(0x5A);
    }
    {
        std::ofstream out(smoke, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), std::streamsize(bytes.size()));
    }
    const std::string scene = "frames = \"1\"\n"
                              "[camera]\nposition = [0.0, 0.0, -12.0]\nlook_at = [0.0, 0.0, 0.0]\n"
                              "width = 12\nheight = 8\n"
                              "[field]\nkind = \"vdb\"\npath = \"smoke.vdb\"\ngrid = \"density\"\n"
                              "[[volume]]\nname = \"spare\"\npath = \"spare.vdb\"\n"
                              "[[instance]]\nvolume = \"field\"\n";
    const std::string name = (dir / "scene.toml").string();
    {
        host::Session s;
        const std::uint64_t before = vdb::vdbReadCount();
        RenderStats stats;
        renderScene(s, scene, name, stats);
        const std::vector<vdb::VdbRead> reads = readsSince(before);
        ASSERT_EQ(reads.size(), 1u);
        EXPECT_EQ(fs::path(reads[0].path).filename(), "smoke.vdb");
        EXPECT_EQ(reads[0].gridName, "density");
        EXPECT_EQ(reads[0].gridsRead, 1) << "one tree of the file's three";
        EXPECT_GT(stats.primarySamples, 0u);
    }
    {
        // placed, the spare volume is read: the count above could have failed
        host::Session s;
        const std::uint64_t before = vdb::vdbReadCount();
        RenderStats stats;
        renderScene(s, scene + "[[instance]]\nvolume = \"spare\"\ntranslate = [3.0, 0.0, 0.0]\n",
                    name, stats);
        const std::vector<vdb::VdbRead> reads = readsSince(before);
        ASSERT_EQ(reads.size(), 2u);
        EXPECT_EQ(fs::path(reads[1].path).filename(), "spare.vdb");
    }
}

// Embree is built only for surfaces or instances: not for a bare cloud, not for SDF solids
// (sphere traced), and once for a ground plane.
TEST(PlanObeyed, NoEmbreeDeviceWithoutSurfacesOrInstances) {
    RenderStats stats;
    FramePlan plan;
    int before = geom::embreeDevicesCreated();
    {
        host::Session s;
        renderScene(s, tinyScene("[ground]\nenabled = false\n"), "bare.toml", stats, &plan);
        EXPECT_FALSE(plan.surfaces);
    }
    EXPECT_EQ(geom::embreeDevicesCreated(), before);
    {
        host::Session s;
        renderScene(s,
                    tinyScene("[[solid]]\n[[solid.node]]\ntype = \"sphere\"\n"
                              "translate = [0.0, 3.0, 0.0]\nradius = 1.0\n"),
                    "solid.toml", stats, &plan);
        EXPECT_EQ(plan.solids, 1);
    }
    EXPECT_EQ(geom::embreeDevicesCreated(), before) << "SDF solids need no Embree";
    {
        host::Session s;
        renderScene(s, tinyScene("[ground]\nenabled = true\n"), "ground.toml", stats, &plan);
        EXPECT_TRUE(plan.surfaces);
    }
    EXPECT_EQ(geom::embreeDevicesCreated(), before + 1);
}

// Without a sun (disabled, or of zero irradiance) no shadow ray takes a density lookup and no
// light-attenuation volume is built, in march and in pathtrace; with one, both are done.
TEST(PlanObeyed, NoShadowWorkWithoutASun) {
    for (Integrator integrator : {Integrator::March, Integrator::PathTrace}) {
        SCOPED_TRACE(integrator == Integrator::March ? "march" : "pathtrace");
        SceneDesc s = quickLayer();
        s.render.integrator = integrator;
        s.render.spp = 2;
        // opaque pixels: pathtrace tracks no camera-ray transmittance for alpha
        s.render.background = Background::Sky;
        s.render.multipleScattering = MultipleScattering::None;
        s.render.shadow = ShadowMethod::March;
        FramePlan plan;
        RenderStats lit = renderDirect(s, plan);
        EXPECT_TRUE(plan.shadows);
        EXPECT_GT(lit.shadowSamples, 0u);
        s.render.shadow = ShadowMethod::Volume;
        lit = renderDirect(s, plan);
        EXPECT_GT(lit.lightVolumes + int(plan.pathtrace), 0) << "march's volume, pathtrace's "
                                                                "shadow roulette";
        for (int variant = 0; variant < 2; ++variant) {
            SceneDesc dark = s;
            if (variant == 0) dark.sun.enabled = false;
            if (variant == 1) dark.sun.irradiance = vec3(0.0f);
            for (ShadowMethod m : {ShadowMethod::March, ShadowMethod::Volume}) {
                dark.render.shadow = m;
                const RenderStats st = renderDirect(dark, plan);
                EXPECT_FALSE(plan.shadows);
                EXPECT_EQ(st.shadowSamples, 0u) << "variant " << variant;
                EXPECT_EQ(st.lightVolumes, 0) << "variant " << variant;
                EXPECT_EQ(st.lightVolumeVoxels, 0u);
                EXPECT_GT(st.primarySamples, 0u);
            }
        }
    }
}

// With the light-attenuation volume no sample marches toward the sun, nor away from it for the
// octave gate (render.octave_gate: the volume read where the sun's line leaves it); with shadow
// marches both are marched, unless the frame builds the sun-depth volume anyway (the diffusion
// grid's sun source): then only the march toward the sun is.
TEST(PlanObeyed, TheLightVolumeSparesTheOctaveGatesMarch) {
    SceneDesc s = quickLayer();
    s.render.multipleScattering = MultipleScattering::None;
    s.render.octaves = 8;
    s.render.octaveGate = 0.25f;
    FramePlan plan;
    s.render.shadow = ShadowMethod::Volume;
    const RenderStats volume = renderDirect(s, plan);
    EXPECT_EQ(volume.lightVolumes, 1);
    EXPECT_EQ(volume.shadowSamples, 0u);
    s.render.shadow = ShadowMethod::March;
    const RenderStats marched = renderDirect(s, plan);
    s.render.octaveGate = 0.0f;
    const RenderStats ungated = renderDirect(s, plan);
    EXPECT_GT(ungated.shadowSamples, 0u);
    EXPECT_GT(marched.shadowSamples, ungated.shadowSamples) << "the gate's second march";
    EXPECT_FALSE(plan.gateVolume);

    s.render.multipleScattering = MultipleScattering::Grid;
    s.render.octaveGate = 0.25f;
    const RenderStats grid = renderDirect(s, plan);
    EXPECT_TRUE(plan.gateVolume);
    s.render.octaveGate = 0.0f;
    const RenderStats gridUngated = renderDirect(s, plan);
    EXPECT_FALSE(plan.gateVolume);
    EXPECT_GT(gridUngated.shadowSamples, 0u);
    EXPECT_EQ(grid.shadowSamples, gridUngated.shadowSamples) << "no second march on the grid";
}

// Multiple scattering off, or a medium that only absorbs (albedo 0): no diffusion solve, no
// photon, no density grid and, at albedo 0, no shadow ray in the medium. On with albedo 1: all.
TEST(PlanObeyed, NoMultipleScatteringWorkWhenOffOrAtAlbedoZero) {
    SceneDesc s = quickLayer();
    FramePlan plan;
    for (MultipleScattering ms : {MultipleScattering::Grid, MultipleScattering::Photons}) {
        s.render.multipleScattering = ms;
        s.medium.sigma_s = vec3(6.0f);
        s.medium.sigma_a = vec3(0.0f);
        RenderStats on = renderDirect(s, plan);
        EXPECT_GT(on.diffusionIterations, 0);
        EXPECT_GT(on.densityGridVoxels, 0u);
        if (ms == MultipleScattering::Photons) EXPECT_EQ(on.photonsTraced, 3000u);

        s.medium.sigma_s = vec3(0.0f);
        s.medium.sigma_a = vec3(6.0f);
        const RenderStats absorbing = renderDirect(s, plan);
        EXPECT_FALSE(plan.scatters);
        EXPECT_EQ(absorbing.diffusionIterations, 0);
        EXPECT_EQ(absorbing.photonsTraced, 0u);
        EXPECT_EQ(absorbing.photonLookups, 0u);
        EXPECT_EQ(absorbing.densityGridVoxels, 0u);
        EXPECT_EQ(absorbing.lightVolumes, 0);
        EXPECT_EQ(absorbing.shadowSamples, 0u) << "nothing in-scatters: no shadow march";
        EXPECT_GT(absorbing.primarySamples, 0u);
    }
    s.medium.sigma_s = vec3(6.0f);
    s.medium.sigma_a = vec3(0.0f);
    s.render.multipleScattering = MultipleScattering::None;
    s.render.octaves = 1;
    const RenderStats off = renderDirect(s, plan);
    EXPECT_EQ(off.diffusionIterations, 0);
    EXPECT_EQ(off.photonsTraced, 0u);
    EXPECT_EQ(off.densityGridVoxels, 0u);
    EXPECT_GT(off.shadowSamples, 0u);

    // at albedo 0 the image is the sky seen through the cloud, whatever the scattering model
    SceneDesc a = quickLayer();
    a.medium.sigma_s = vec3(0.0f);
    a.medium.sigma_a = vec3(6.0f);
    a.render.background = Background::Sky;
    Framebuffer grid, none;
    a.render.multipleScattering = MultipleScattering::Grid;
    renderDirect(a, plan, {}, &grid);
    a.render.multipleScattering = MultipleScattering::None;
    renderDirect(a, plan, {}, &none);
    EXPECT_EQ(grid.rgba, none.rgba);
}

// Each light grid is built exactly when the plan names it, over every combination of the
// switches that decide them: the sun, the albedo, the multiple-scattering model, the sun's
// transmittance and the sky's model. Each count is compared with what the plan says, both ways.
TEST(PlanObeyed, LightGridsPhotonsAndDiffusionOnlyWhenPlanned) {
    struct Sky {
        SkyScattering scattering;
        SkyShadow shadow;
        SkyOcclusion occlusion;
    };
    const Sky skies[] = {{SkyScattering::Ambient, SkyShadow::March, SkyOcclusion::Height},
                         {SkyScattering::Ambient, SkyShadow::March, SkyOcclusion::Column},
                         {SkyScattering::Single, SkyShadow::March, SkyOcclusion::Height},
                         {SkyScattering::Single, SkyShadow::Volume, SkyOcclusion::Height}};
    int seen[6][2] = {}; // [what][planned]: both answers must occur for each
    for (bool sun : {true, false})
        for (float albedo : {1.0f, 0.0f})
            for (MultipleScattering ms :
                 {MultipleScattering::None, MultipleScattering::Grid, MultipleScattering::Photons})
                for (ShadowMethod shadow : {ShadowMethod::March, ShadowMethod::Volume})
                    for (const Sky& sky : skies) {
                        SceneDesc s = quickLayer();
                        s.sun.enabled = sun;
                        s.medium.sigma_s = vec3(6.0f * albedo);
                        s.medium.sigma_a = vec3(6.0f * (1.0f - albedo));
                        s.render.multipleScattering = ms;
                        s.render.shadow = shadow;
                        s.render.skyScattering = sky.scattering;
                        s.render.skyShadow = sky.shadow;
                        s.render.skyOcclusion = sky.occlusion;
                        s.render.skyDirections = 4;
                        FramePlan p;
                        const RenderStats st = renderDirect(s, p);
                        SCOPED_TRACE(p.explain());
                        const int volumes = (p.sunDepthVolume ? 1 : 0) + (p.columnVolumes ? 2 : 0);
                        EXPECT_EQ(st.lightVolumes, volumes);
                        EXPECT_EQ(st.lightVolumeVoxels > 0, volumes > 0);
                        // the memory the plan states for them is what the renderer built
                        EXPECT_EQ(double(st.lightVolumeVoxels + st.densityGridVoxels) * 4.0,
                                  p.lightGridBytes);
                        EXPECT_EQ(st.diffusionIterations > 0, p.diffusion);
                        EXPECT_EQ(st.photonsTraced, p.photons ? 3000u : 0u);
                        EXPECT_EQ(st.skyVolumeBytes, size_t(p.skyVolumeBytes));
                        EXPECT_EQ(st.skyVolumeBytes > 0, p.skyVolume);
                        if (!p.densityGrid && !p.skyVolume) EXPECT_EQ(st.densityGridVoxels, 0u);
                        if (p.densityGrid) EXPECT_GT(st.densityGridVoxels, 0u);
                        EXPECT_EQ(st.shadowSamples > 0,
                                  (p.shadows && p.scatters && !p.lightVolume) ||
                                      (p.skySingle && !p.skyVolume))
                            << "shadow marches exactly toward a sun or sky marched toward";
                        ++seen[0][volumes > 0];
                        ++seen[1][p.diffusion];
                        ++seen[2][p.photons];
                        ++seen[3][p.skyVolume];
                        ++seen[4][p.densityGrid];
                        ++seen[5][p.lightVolume];
                    }
    for (int w = 0; w < 6; ++w) {
        EXPECT_GT(seen[w][0], 0) << w;
        EXPECT_GT(seen[w][1], 0) << w;
    }
}

// AOVs not asked for hold no memory (none is allocated, even in a buffer reused from a frame
// that had them) and are not in the EXR; asked for, they are.
TEST(PlanObeyed, UnrequestedAovsCostNothing) {
    SceneDesc s = quickLayer();
    s.render.multipleScattering = MultipleScattering::None;
    const size_t pixels = size_t(s.camera.width) * s.camera.height;
    FramePlan plan;
    Framebuffer fb;
    RenderStats st = renderDirect(s, plan, {}, &fb);
    EXPECT_EQ(st.aovBytes, 0u);
    EXPECT_EQ(fb.transmittance.capacity() + fb.depth.capacity(), 0u);
    AovSet both;
    both.transmittance = both.depth = true;
    st = renderDirect(s, plan, both, &fb);
    EXPECT_EQ(st.aovBytes, pixels * 4 * sizeof(float));
    st = renderDirect(s, plan, {}, &fb);
    EXPECT_EQ(st.aovBytes, 0u) << "a reused buffer gives the AOVs' memory back";
    EXPECT_EQ(fb.aovBytes(), 0u);

    // pathtrace tracks the camera ray's transmittance (ratio tracking: lookups counted with the
    // shadow rays) for the AOV or for alpha only: over an opaque sky without the AOV, not at
    // all, and the beauty pass is the same
    s.render.integrator = Integrator::PathTrace;
    s.render.spp = 2;
    s.render.background = Background::Sky;
    s.sun.enabled = false;
    AovSet t;
    t.transmittance = true;
    Framebuffer withAov;
    const RenderStats tracked = renderDirect(s, plan, t, &withAov);
    st = renderDirect(s, plan, {}, &fb);
    EXPECT_GT(tracked.shadowSamples, 0u);
    EXPECT_EQ(st.shadowSamples, 0u);
    EXPECT_EQ(fb.rgba, withAov.rgba);

    // through the command: the EXR holds the beauty pass only
    TempDir dir("plan_aov");
    const std::string scene =
        tinyScene("[output]\npath = \"" + (dir / "f.####.exr").string() + "\"\n");
    { std::ofstream((dir / "s.toml").string()) << scene; }
    CliRun r = runNimbus("render " + (dir / "s.toml").string() + " -q");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    io::ExrImage img = io::readExr((dir / "f.0001.exr").string());
    EXPECT_EQ(img.channels, (std::vector<std::string>{"R", "G", "B", "A"}));
    {
        std::ofstream((dir / "d.toml").string()) << tinyScene(
            "[output]\npath = \"" + (dir / "f.####.exr").string() + "\"\naovs = [\"depth\"]\n");
    }
    r = runNimbus("render " + (dir / "d.toml").string() + " -q");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    img = io::readExr((dir / "f.0001.exr").string());
    EXPECT_EQ(img.channels.size(), 5u);
    EXPECT_GE(img.channelIndex("depth"), 0);
}
