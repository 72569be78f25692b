/// @file test_rt_march.cpp
/// @brief The GLSL march pass (plugin/realtime/rt_march.h) against the CPU `march` integrator:
/// the shared parameter block unpacks to the kernel structs the CPU uses, the shader's lookups of
/// the Lorenz-Mie table and of the multiple-scattering grids equal the CPU's on thousands of
/// inputs, the default scene's field renders on the GPU (Mesa llvmpipe through EGL here) at
/// PSNR >= 45 dB against the CPU at equal settings (with the Mie table, the diffusion grid and
/// the photon grid too), unsupported settings are refused by key, and `nimbus rt` writes a valid
/// EXR through the same output code as `nimbus render` and exits 2 on an unsupported scene. VDB
/// fields (RT_VDB): PNanoVDB's voxel values and the trilinear density against NanoVDB and
/// GridField::density, and the images, on a grid the test writes (tests/rt_vdb_scene.h) and on
/// smoke1 (skipped without the shared data folder, NIMBUS_SHARED_VDB_DIR). SDF clouds (RT_SDF):
/// the tree's distance and density through the kernel sdfTreeStep against SdfTree::distance and
/// Field::density, on examples/scenes/sdf_cloud.toml's tree and on one with every node kind, and
/// the images of sdf_cloud.toml (the sun's shadow marched), which need the march in slices
/// against llvmpipe's loop budget (RtLoopBudget, RtSdfParity).
///
/// Like the kernel parity tests (tests/test_glsl_parity.cpp), the GPU tests fail, with the EGL
/// error, when no headless OpenGL 4.5 context can be made: the packages are required.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nanovdb/NanoVDB.h>

#include "core/fields/cumulus.h"
#include "core/fields/field.h"
#include "core/fields/sdf_cloud.h"
#include "core/media/medium.h"
#include "core/media/phase.h"
#include "plugin/host/session.h"
#include "plugin/io/image_output.h"
#include "plugin/realtime/gl_compute.h"
#include "plugin/realtime/march_params.h"
#include "plugin/realtime/rt_march.h"
#include "tests/rt_vdb_scene.h"
#include "tests/gl_context.h"
#include "tests/test_util.h"

using namespace nimbus;

namespace {

const std::string kDefaultScene = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/cumulus.toml";

/// The default scene at a small size with multiple scattering `ms` ("none": octaves and the sky
/// ambient only; "grid", "photons": the grids computed on the CPU) and the noise evaluated
/// directly on the CPU too.
std::vector<std::string> paritySettings(int w, int h, const std::string& ms = "none") {
    std::vector<std::string> s{
        "camera.width=" + std::to_string(w), "camera.height=" + std::to_string(h),
        "render.multiple_scattering=\"" + ms + "\"", "field.evaluation=\"direct\""};
    // a count named: parity reads the same photon grid on both sides, so it needs neither the 8 M
    // photons render.photons = 0 gives a deep cloud nor the 2 M it named until 2026-12-04
    if (ms == "photons" || ms == "auto") s.push_back("render.photons=500000");
    // the default scene's steps split at step_tau's 0.5, not photon_step_tau's 0.125: at 0.125
    // nearly every shadow step in the cumulus splits in four, and one camera step's shadow march
    // runs past llvmpipe's loop budget (the pass refuses, saying so; a GPU has no such budget).
    // Parity compares the CPU and the GPU on the same plan either way.
    if (ms == "photons" || ms == "auto") s.push_back("render.photon_step_tau=0.5");
    return s;
}

/// PSNR in dB of `test` against `ref` over the RGB of premultiplied RGBA pixels, the peak being
/// the reference's largest RGB value (an HDR image has no fixed white).
double psnrRgb(const std::vector<float>& ref, const std::vector<float>& test, double* maxAbs) {
    double peak = 0.0, se = 0.0;
    *maxAbs = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
        if (i % 4 == 3) continue;
        const double d = double(test[i]) - double(ref[i]);
        peak = std::max(peak, double(ref[i]));
        se += d * d;
        *maxAbs = std::max(*maxAbs, std::abs(d));
        ++n;
    }
    const double mse = se / double(n);
    return mse > 0.0 ? 10.0 * std::log10(peak * peak / mse) : 1e9;
}

} // namespace

// The block the shader reads rebuilds exactly the kernel structs the CPU renders with.
TEST(RtMarchParams, UnpackToTheCpuKernelStructs) {
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, paritySettings(160, 90)).ok());
    const SceneDesc& s = session.scene();
    for (int frame : {1, 12}) {
        const FramePlan plan = session.plan(frame);
        const rt::RtMarchParams P = rt::marchParams(s, plan);
        const kern::CumulusParams want = cumulusParams(s.field.cumulus, plan.time);
        const kern::CumulusParams got = kern::rtCumulusParams(P);
        static_assert(sizeof want == 28 * 4, "CumulusParams has no padding to compare");
        EXPECT_EQ(std::memcmp(&want, &got, sizeof want), 0) << "frame " << frame;
        const kern::PhaseParams pw = phaseParams(s.medium), pg = kern::rtPhaseParams(P);
        EXPECT_EQ(std::memcmp(&pw, &pg, sizeof pw), 0);
        EXPECT_EQ(P.width, 160);
        EXPECT_EQ(P.height, 90);
        EXPECT_EQ(P.step, plan.step);
        EXPECT_EQ(P.shadowStep, plan.shadowStep);
    }
}

// What the GPU path cannot do is named by its key; the parity settings need nothing else.
TEST(RtMarchSupport, RefusesByKey) {
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, paritySettings(32, 18)).ok());
    const SceneDesc base = session.scene();
    EXPECT_TRUE(rt::unsupported(base, planFrame(base, 1)).empty());
    auto keysOf = [](const SceneDesc& s) {
        std::string keys;
        for (const rt::Unsupported& u : rt::unsupported(s, planFrame(s, 1))) keys += u.key + ";";
        return keys;
    };
    // the diffusion and photon grids (with the photons' skin profile) and the Mie table
    SceneDesc s = base;
    s.render.multipleScattering = MultipleScattering::Grid;
    EXPECT_EQ(keysOf(s), "");
    s.render.multipleScattering = MultipleScattering::Photons;
    EXPECT_EQ(keysOf(s), "");
    s.render.photonSkin = 0.2f;
    EXPECT_EQ(keysOf(s), "");
    s.render.photonSky = true; // the sky's first scattering by shadow marches: CPU-only
    EXPECT_EQ(keysOf(s), "render.sky_shadow;");
    s.render.skyShadow = SkyShadow::Volume; // from the sky volume (RT_SKY_VOLUME)
    EXPECT_EQ(keysOf(s), "");
    s = base;
    s.render.skyScattering = SkyScattering::Single;
    EXPECT_EQ(keysOf(s), "render.sky_shadow;");
    s.render.skyShadow = SkyShadow::Volume;
    EXPECT_EQ(keysOf(s), "");
    s = base;
    s.medium.phase = PhaseKind::MieTable;
    EXPECT_EQ(keysOf(s), "");
    s = base;
    s.field.kind = FieldKind::Vdb; // through PNanoVDB
    EXPECT_FALSE(contains(keysOf(s), "field.kind;"));
    s = base;
    s.field.kind = FieldKind::Gardner;
    EXPECT_TRUE(contains(keysOf(s), "field.kind;"));
    s = base;
    s.field.cumulus.eval = NoiseEval::Baked; // the CPU's tiles in buffers (RT_BAKED_NOISE)
    EXPECT_EQ(keysOf(s), "");
    s = base;
    s.render.integrator = Integrator::PathTrace;
    EXPECT_EQ(keysOf(s), "render.integrator;");
    s = base;
    s.render.shadow = ShadowMethod::Volume; // the CPU's light volume in a buffer
    EXPECT_EQ(keysOf(s), "");
    s = base;
    s.render.skyOcclusion = SkyOcclusion::Column;
    EXPECT_EQ(keysOf(s), "render.sky_occlusion;");
    s = base;
    s.ground.enabled = true;
    EXPECT_EQ(keysOf(s), "ground.enabled;");
}

// The shader carries only the features a frame uses.
TEST(RtMarchShader, DefinesOnlyTheFeaturesInUse) {
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, paritySettings(32, 18)).ok());
    SceneDesc s = session.scene();
    rt::MarchFeatures f = rt::marchFeatures(s, planFrame(s, 1));
    EXPECT_TRUE(f.sun && f.ambient && f.backgroundSky && !f.multisample);
    EXPECT_TRUE(!f.mieTable && !f.diffusion && !f.photons);
    EXPECT_TRUE(contains(f.defines(), "#define RT_MIE_TABLE 0\n"));
    EXPECT_TRUE(contains(f.defines(), "#define RT_MS_DIFFUSION 0\n"));
    {
        // the table with the sun; the diffusion grid replaces the sky ambient; photons carry the
        // sun's higher orders and the diffusion grid the sky's
        SceneDesc m = s;
        m.medium.phase = PhaseKind::MieTable;
        m.render.multipleScattering = MultipleScattering::Grid;
        rt::MarchFeatures g = rt::marchFeatures(m, planFrame(m, 1));
        EXPECT_TRUE(g.mieTable && g.diffusion && !g.photons && !g.ambient);
        EXPECT_TRUE(contains(g.defines(), "#define RT_MIE_TABLE 1\n"));
        EXPECT_TRUE(contains(g.defines(), "#define RT_MS_DIFFUSION 1\n"));
        m.render.multipleScattering = MultipleScattering::Photons;
        g = rt::marchFeatures(m, planFrame(m, 1));
        EXPECT_TRUE(g.diffusion && g.photons && !g.ambient);
        EXPECT_TRUE(contains(g.defines(), "#define RT_MS_PHOTONS 1\n"));
        EXPECT_TRUE(contains(g.defines(), "#define RT_PHOTON_SKIN 0\n"));
        m.render.photonSkin = 0.2f;
        EXPECT_TRUE(rt::marchFeatures(m, planFrame(m, 1)).photonSkin);
        m.sun.enabled = false; // no sun: no octaves, so no table (and no photons)
        g = rt::marchFeatures(m, planFrame(m, 1));
        EXPECT_TRUE(!g.mieTable && !g.photons && g.diffusion);
        // render.shadow = "volume": the light volume replaces the shadow march, with the sun only
        SceneDesc v = s;
        EXPECT_FALSE(f.lightVolume);
        EXPECT_TRUE(contains(f.defines(), "#define RT_LIGHT_VOLUME 0\n"));
        v.render.shadow = ShadowMethod::Volume;
        g = rt::marchFeatures(v, planFrame(v, 1));
        EXPECT_TRUE(g.sun && g.lightVolume);
        EXPECT_TRUE(contains(g.defines(), "#define RT_LIGHT_VOLUME 1\n"));
        v.sun.enabled = false;
        EXPECT_FALSE(rt::marchFeatures(v, planFrame(v, 1)).lightVolume);
        // the single-scattered sky from its volume replaces the ambient term; the Mie table is
        // read toward the sky's directions even without the sun
        SceneDesc k = s;
        EXPECT_FALSE(f.skyVolume);
        EXPECT_TRUE(contains(f.defines(), "#define RT_SKY_VOLUME 0\n"));
        k.render.skyScattering = SkyScattering::Single;
        k.render.skyShadow = SkyShadow::Volume;
        g = rt::marchFeatures(k, planFrame(k, 1));
        EXPECT_TRUE(g.skyVolume && !g.ambient);
        EXPECT_TRUE(contains(g.defines(), "#define RT_SKY_VOLUME 1\n"));
        k.sun.enabled = false;
        k.medium.phase = PhaseKind::MieTable;
        g = rt::marchFeatures(k, planFrame(k, 1));
        EXPECT_TRUE(g.skyVolume && g.mieTable && !g.sun);
    }
    s.sun.enabled = false;
    s.sky.kind = SkyKind::None;
    s.render.background = Background::Transparent;
    s.render.pixelSamples = 4;
    f = rt::marchFeatures(s, planFrame(s, 1));
    EXPECT_TRUE(!f.sun && !f.ambient && !f.backgroundSky && f.multisample);
    const std::string text = rt::marchShaderSource(f);
    EXPECT_TRUE(contains(text, "#define RT_SUN 0\n"));
    EXPECT_TRUE(contains(text, "#define RT_MULTISAMPLE 1\n"));
    EXPECT_TRUE(contains(text, "NB_FN float cumulusDensity(")); // the embedded kernel text
    // the baked noise follows the plan: "baked", and "auto" where the plan bakes
    EXPECT_FALSE(f.bakedNoise);
    EXPECT_TRUE(contains(f.defines(), "#define RT_BAKED_NOISE 0\n"));
    SceneDesc b = s;
    b.field.cumulus.eval = NoiseEval::Baked;
    const rt::MarchFeatures fb = rt::marchFeatures(b, planFrame(b, 1));
    EXPECT_TRUE(fb.bakedNoise);
    EXPECT_TRUE(contains(fb.defines(), "#define RT_BAKED_NOISE 1\n"));
    EXPECT_TRUE(contains(rt::marchShaderSource(fb), "buffer RtBaseNoise"));
    b.field.cumulus.eval = NoiseEval::Auto;
    EXPECT_EQ(rt::marchFeatures(b, planFrame(b, 1)).bakedNoise, planFrame(b, 1).bakeNoise);
}

namespace {

/// Runs `body` (GLSL statements over `uint i`, the invocation's index) once per input after the
/// pass's buffers and lookups (rt::marchDataShaderSource of `f`): the inputs as `testIn[i]`
/// (vec4, binding 7), the results written to `testOut` (floats, binding 8), `perInput` each.
/// The parameter block goes to binding 0; the caller binds the data buffers the lookups read.
std::vector<float> runLookups(const rt::MarchFeatures& f, const rt::RtMarchParams& P,
                              const std::vector<glm::vec4>& in, std::size_t perInput,
                              const std::string& body) {
    const std::string text =
        rt::marchDataShaderSource(f) +
        "\nlayout(local_size_x = 64) in;\n"
        "layout(std430, binding = 7) readonly buffer TestIn { vec4 testIn[]; };\n"
        "layout(std430, binding = 8) buffer TestOut { float testOut[]; };\n"
        "void main() {\n"
        "    uint i = gl_GlobalInvocationID.x;\n"
        "    if (i >= uint(testIn.length())) return;\n" +
        body + "\n}\n";
    const gl::ComputeProgram program(text);
    EXPECT_TRUE(program.valid()) << program.log();
    if (!program.valid()) return {};
    const gl::StorageBuffer params(sizeof P, &P);
    const gl::StorageBuffer input(in.size() * sizeof(glm::vec4), in.data());
    const gl::StorageBuffer output(in.size() * perInput * sizeof(float));
    params.bind(0);
    input.bind(7);
    output.bind(8);
    program.dispatch(unsigned((in.size() + 63) / 64));
    std::vector<float> out(in.size() * perInput);
    output.read(out.data(), out.size() * sizeof(float));
    const std::string e = gl::glErrors();
    EXPECT_TRUE(e.empty()) << e;
    return out;
}

/// @p n points (w 0) spread over box @p b grown by 10% of its size per side, from a pcg sequence
/// seeded with @p seed.
std::vector<glm::vec4> pointsAround(const Box& b, int n, std::uint32_t seed) {
    const vec3 margin = 0.1f * (b.hi - b.lo);
    std::vector<glm::vec4> in;
    auto u = [&] { return kern::hashToUnit(seed = kern::pcg(seed)); };
    for (int k = 0; k < n; ++k) {
        const vec3 t(u(), u(), u());
        const vec3 p = b.lo - margin + t * (b.hi - b.lo + 2.0f * margin);
        in.emplace_back(p.x, p.y, p.z, 0.0f);
    }
    return in;
}

} // namespace

// The Lorenz-Mie table as the shader reads it (march_data.glsl: rtMieEval) equals
// MieTable::eval on the CPU: at every node, between every two nodes, at 8,192 cosines spread over
// [-1, 1] and 2,048 in the forward peak, and outside [-1, 1] (clamped).
TEST(RtMarchLookups, MieTableAsTheCpu) {
    if (!requireContext()) return;
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, {"medium.phase=\"mie_table\""}).ok());
    const SceneDesc& s = session.scene();
    const FramePlan plan = session.plan(1);
    rt::MarchFeatures f = rt::marchFeatures(s, plan);
    ASSERT_TRUE(f.mieTable);
    const Medium medium = Medium::fromDesc(s.medium);
    const MieTable& table = *medium.phase.table();
    const rt::RtMarchParams P = rt::marchParams(s, plan);
    const std::vector<float>& cos = table.cosines();
    ASSERT_EQ(P.mieNodes, int(cos.size()));
    std::vector<glm::vec4> in;
    for (std::size_t k = 0; k < cos.size(); ++k) {
        in.emplace_back(cos[k], 0.0f, 0.0f, 0.0f);
        if (k + 1 < cos.size()) in.emplace_back(0.5f * (cos[k] + cos[k + 1]), 0.0f, 0.0f, 0.0f);
    }
    for (int k = 0; k < 8192; ++k) in.emplace_back(-1.0f + 2.0f * (k + 0.37f) / 8192.0f, 0, 0, 0);
    for (int k = 0; k < 2048; ++k) in.emplace_back(1.0f - 0.01f * (k + 0.61f) / 2048.0f, 0, 0, 0);
    for (float mu : {-1.5f, -1.0f, 1.0f, 1.5f}) in.emplace_back(mu, 0.0f, 0.0f, 0.0f);
    const std::vector<glm::vec4> nodes = rt::mieTableNodes(table);
    const gl::StorageBuffer mie(nodes.size() * sizeof(glm::vec4), nodes.data());
    mie.bind(3);
    const std::vector<float> out = runLookups(f, P, in, 3,
                                              "vec3 v = rtMieEval(testIn[i].x);\n"
                                              "testOut[3u * i] = v.x;\n"
                                              "testOut[3u * i + 1u] = v.y;\n"
                                              "testOut[3u * i + 2u] = v.z;");
    ASSERT_EQ(out.size(), 3 * in.size());
    double worst = 0.0;
    std::size_t bad = 0;
    for (std::size_t i = 0; i < in.size(); ++i) {
        const vec3 want = table.eval(in[i].x);
        for (int c = 0; c < 3; ++c) {
            const double rel = std::abs(double(out[3 * i + std::size_t(c)]) - want[c]) /
                               std::max(double(want[c]), 1e-6);
            worst = std::max(worst, rel);
            if (!(rel <= 1e-5) && bad++ < 5)
                ADD_FAILURE() << "mu " << in[i].x << " channel " << c << ": GPU "
                              << out[3 * i + std::size_t(c)] << ", CPU " << want[c];
        }
    }
    RecordProperty("mie_lookups", std::to_string(in.size()));
    RecordProperty("mie_max_relative_difference", std::to_string(worst));
    std::printf("[ rt lookups ] Mie table: %zu cosines, largest relative difference %.3g\n",
                in.size(), worst);
    EXPECT_EQ(bad, 0u);
}

// The multiple-scattering grids as the shader reads them (march_data.glsl) equal the CPU's
// lookups: DiffusionVolume::sample with its gradient and PhotonVolume::sample with the skin
// profile, at 4,096 points over the grids' bounds and a margin around them (clamped).
TEST(RtMarchLookups, GridsAsTheCpu) {
    if (!requireContext()) return;
    // photons for the sun (with the skin profile) and the diffusion grid for the sky
    host::Session skinned;
    std::vector<std::string> settings = paritySettings(32, 18, "photons");
    settings.push_back("render.photon_skin=0.2");
    ASSERT_TRUE(skinned.load(kDefaultScene, settings).ok());
    const FramePlan skinPlan = skinned.plan(1);
    ASSERT_TRUE(skinPlan.photons && skinPlan.diffusion);
    RenderStats stats;
    const MarchGrids grids = skinned.renderer().marchGrids(skinPlan, skinned.bindings(), stats);
    ASSERT_TRUE(grids.hasDiffusion && grids.hasPhotons);
    ASSERT_TRUE(grids.photons.sunTau != nullptr && grids.photons.skinK > 0.0f);
    const rt::MarchFeatures f = rt::marchFeatures(skinned.scene(), skinPlan);
    ASSERT_TRUE(f.diffusion && f.photons && f.photonSkin);
    const rt::RtMarchParams P = rt::marchParams(skinned.scene(), skinPlan, &grids);
    const gl::StorageBuffer phi(grids.diffusion.phi.size() * sizeof(vec3),
                                grids.diffusion.phi.data());
    const gl::StorageBuffer photons(grids.photons.radiance.size() * sizeof(vec3),
                                    grids.photons.radiance.data());
    const gl::StorageBuffer tau(grids.photons.sunTau->tau.size() * sizeof(float),
                                grids.photons.sunTau->tau.data());
    phi.bind(4);
    photons.bind(5);
    tau.bind(6);
    std::vector<glm::vec4> in = pointsAround(grids.diffusion.bounds, 4096, 12345u);
    const std::vector<float> out =
        runLookups(f, P, in, 15,
                   "vec3 p = vec3(testIn[i].x, testIn[i].y, testIn[i].z);\n"
                   "vec3 gR, gG, gB;\n"
                   "vec3 phi = rtDiffusionSample(p, gR, gG, gB);\n"
                   "vec3 L = rtPhotonSample(p);\n"
                   "float v[15] = float[15](phi.x, phi.y, phi.z, gR.x, gR.y, gR.z, gG.x, gG.y,\n"
                   "                        gG.z, gB.x, gB.y, gB.z, L.x, L.y, L.z);\n"
                   "for (uint k = 0u; k < 15u; k++) testOut[15u * i + k] = v[k];");
    ASSERT_EQ(out.size(), 15 * in.size());
    // tolerances relative to each quantity's largest value over the points
    std::vector<float> want(out.size());
    for (std::size_t i = 0; i < in.size(); ++i) {
        const vec3 p(in[i].x, in[i].y, in[i].z);
        vec3 grad[3];
        const vec3 phiP = grids.diffusion.sample(p, grad);
        const vec3 L = grids.photons.sample(p);
        const float v[15] = {phiP.x,    phiP.y,    phiP.z,    grad[0].x, grad[0].y,
                             grad[0].z, grad[1].x, grad[1].y, grad[1].z, grad[2].x,
                             grad[2].y, grad[2].z, L.x,       L.y,       L.z};
        std::copy(v, v + 15, want.begin() + std::ptrdiff_t(15 * i));
    }
    const char* names[3] = {"diffusion phi", "diffusion gradient", "photon radiance"};
    for (int q = 0; q < 3; ++q) {
        const int first = q == 0 ? 0 : q == 1 ? 3 : 12, count = q == 1 ? 9 : 3;
        double scale = 0.0, worst = 0.0;
        for (std::size_t i = 0; i < in.size(); ++i)
            for (int c = first; c < first + count; ++c)
                scale = std::max(scale, double(std::abs(want[15 * i + std::size_t(c)])));
        ASSERT_GT(scale, 0.0) << names[q];
        for (std::size_t i = 0; i < in.size(); ++i)
            for (int c = first; c < first + count; ++c)
                worst = std::max(worst, std::abs(double(out[15 * i + std::size_t(c)]) -
                                                 want[15 * i + std::size_t(c)]) /
                                            scale);
        RecordProperty(std::string("max_relative_difference_") + std::to_string(q),
                       std::to_string(worst));
        std::printf("[ rt lookups ] %s: %zu points, largest difference %.3g of the largest "
                    "value\n",
                    names[q], in.size(), worst);
        EXPECT_LE(worst, 1e-5) << names[q];
    }
}

// The sun's light-attenuation volume as the shader reads it (march_data.glsl: rtInLightVolume,
// rtLightVolumeSample) equals LightVolume::bounds.contains and LightVolume::sample on the CPU at
// 4,096 random points over its box grown by 10% per side and at its 8 corners and 6 face
// centres (on the faces: inside, as Box::contains says).
TEST(RtMarchLookups, LightVolumeAsTheCpu) {
    if (!requireContext()) return;
    host::Session session;
    std::vector<std::string> settings = paritySettings(32, 18);
    settings.push_back("render.shadow=\"volume\"");
    ASSERT_TRUE(session.load(kDefaultScene, settings).ok());
    const FramePlan plan = session.plan(1);
    ASSERT_TRUE(plan.lightVolume);
    RenderStats stats;
    const MarchGrids grids = session.renderer().marchGrids(plan, session.bindings(), stats);
    const LightVolume* lv = grids.towardVolume();
    ASSERT_NE(lv, nullptr);
    const rt::MarchFeatures f = rt::marchFeatures(session.scene(), plan);
    ASSERT_TRUE(f.lightVolume);
    const rt::RtMarchParams P = rt::marchParams(session.scene(), plan, &grids);
    EXPECT_EQ(P.lightResX * P.lightResY * P.lightResZ, int(lv->tau.size()));
    const gl::StorageBuffer tau(lv->tau.size() * sizeof(float), lv->tau.data());
    tau.bind(15);
    const Box b = lv->bounds;
    std::vector<glm::vec4> in = pointsAround(b, 4096, 777u);
    const vec3 c = 0.5f * (b.lo + b.hi);
    for (int k = 0; k < 8; ++k)
        in.emplace_back(k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y, k & 4 ? b.hi.z : b.lo.z,
                        0.0f);
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
            vec3 p = c;
            p[axis] = side ? b.hi[axis] : b.lo[axis];
            in.emplace_back(p.x, p.y, p.z, 0.0f);
        }
    const std::vector<float> out =
        runLookups(f, P, in, 2,
                   "vec3 p = vec3(testIn[i].x, testIn[i].y, testIn[i].z);\n"
                   "testOut[2u * i] = rtInLightVolume(p) ? 1.0 : 0.0;\n"
                   "testOut[2u * i + 1u] = rtLightVolumeSample(p);");
    ASSERT_EQ(out.size(), 2 * in.size());
    float scale = 0.0f;
    for (float t : lv->tau) scale = std::max(scale, t);
    ASSERT_GT(scale, 0.0f);
    std::size_t inside = 0, disagree = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < in.size(); ++i) {
        const vec3 p(in[i].x, in[i].y, in[i].z);
        const bool cpuInside = b.contains(p);
        inside += cpuInside;
        disagree += cpuInside != (out[2 * i] == 1.0f);
        worst = std::max(worst, std::abs(double(out[2 * i + 1]) - lv->sample(p)) / scale);
    }
    std::printf("[ rt lookups ] light volume: %zu points (%zu inside), %zu containment "
                "disagreements, largest difference %.3g of the largest value\n",
                in.size(), inside, disagree, worst);
    RecordProperty("max_relative_difference", std::to_string(worst));
    EXPECT_GT(inside, in.size() / 2); // the points test the inside, not only the margin
    EXPECT_LT(inside, in.size());
    EXPECT_EQ(disagree, 0u);
    EXPECT_LE(worst, 1e-5);
}

// The baked noise tiles as the shader reads them (march_data.glsl: rtNoiseSample, and the
// density rtBakedCumulusDensity) equal the CPU's (NoiseVolume::sample, CumulusField::density
// with both tiles): the tiles are the ones Renderer::fieldFor baked, uploaded as they are.
// Lookups at 6,144 points per tile in voxel units: random over three tile periods around the
// tile (negative coordinates and beyond res: the wrap), on the tile's borders (0 and res - 1 +
// a fraction, res, -1 + a fraction, with fractions 0, 1e-3, 0.5, 1 - 1e-3, on one axis or all
// three), and integer nodes; densities at 8,192 world points over the field's box at frames 1
// and 12 (the wind offsets).
TEST(RtMarchLookups, BakedNoiseAsTheCpu) {
    if (!requireContext()) return;
    host::Session session;
    std::vector<std::string> settings = paritySettings(32, 18);
    settings.push_back("field.evaluation=\"baked\"");
    ASSERT_TRUE(session.load(kDefaultScene, settings).ok());
    std::uint32_t h = 777u;
    auto u = [&] { return kern::hashToUnit(h = kern::pcg(h)); };
    double worstNoise = 0.0, worstDensity = 0.0, largestDensity = 0.0;
    std::size_t lookups = 0, densities = 0, cloudy = 0;
    for (int frame : {1, 12}) {
        const FramePlan plan = session.plan(frame);
        ASSERT_TRUE(plan.bakeNoise);
        const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
        ASSERT_TRUE(noise.base && noise.detail);
        ASSERT_EQ(rt::bakedNoiseError(session.scene(), &noise), "");
        const rt::MarchFeatures f = rt::marchFeatures(session.scene(), plan);
        ASSERT_TRUE(f.bakedNoise);
        const rt::RtMarchParams P = rt::marchParams(session.scene(), plan);
        ASSERT_EQ(P.baseBakeRes, noise.base->res);
        ASSERT_EQ(P.detailBakeRes, noise.detail->res);
        const gl::StorageBuffer base(noise.base->values.size() * sizeof(float),
                                     noise.base->values.data());
        const gl::StorageBuffer detail(noise.detail->values.size() * sizeof(float),
                                       noise.detail->values.data());
        base.bind(10);
        detail.bind(11);
        // the tile lookups (w: 0 base, 1 detail)
        std::vector<glm::vec4> in;
        for (int tile = 0; tile < 2; ++tile) {
            const float n = float(tile == 0 ? noise.base->res : noise.detail->res);
            for (int k = 0; k < 2048; ++k)
                in.emplace_back(-n + 3.0f * n * u(), -n + 3.0f * n * u(), -n + 3.0f * n * u(),
                                float(tile));
            const float edges[] = {0.0f, n - 1.0f, n, -1.0f};
            const float fracs[] = {0.0f, 1e-3f, 0.5f, 1.0f - 1e-3f};
            for (int k = 0; k < 2048; ++k) {
                const float e = edges[k % 4] + fracs[(k / 4) % 4];
                const int axis = (k / 16) % 4; // 3: all three on the border
                vec3 p(n * u(), n * u(), n * u());
                if (axis == 3)
                    p = vec3(e);
                else
                    p[axis] = e;
                in.emplace_back(p.x, p.y, p.z, float(tile));
            }
            for (int k = 0; k < 2048; ++k)
                in.emplace_back(std::floor(n * u()), std::floor(n * u()), std::floor(n * u()),
                                float(tile));
        }
        const std::vector<float> out =
            runLookups(f, P, in, 1,
                       "vec3 u = vec3(testIn[i].x, testIn[i].y, testIn[i].z);\n"
                       "testOut[i] = testIn[i].w == 0.0f ? rtNoiseSample(0, P.baseBakeRes, u)\n"
                       "                                 : rtNoiseSample(1, P.detailBakeRes, u);");
        ASSERT_EQ(out.size(), in.size());
        for (std::size_t i = 0; i < in.size(); ++i) {
            const NoiseVolume& v = in[i].w == 0.0f ? *noise.base : *noise.detail;
            const float want = v.sample(vec3(in[i].x, in[i].y, in[i].z));
            worstNoise = std::max(worstNoise, double(std::abs(out[i] - want)));
        }
        lookups += in.size();
        // the densities, as the CPU frame's field reads them
        const Field field = session.renderer().fieldFor(plan, session.bindings());
        ASSERT_EQ(field.kind, FieldKind::Cumulus);
        const Box b = field.bounds();
        std::vector<glm::vec4> pts;
        for (int k = 0; k < 8192; ++k) {
            const vec3 p = b.lo + vec3(u(), u(), u()) * (b.hi - b.lo);
            pts.emplace_back(p.x, p.y, p.z, 0.0f);
        }
        const std::vector<float> rho =
            runLookups(f, P, pts, 1,
                       "testOut[i] = rtBakedCumulusDensity(rtCumulusParams(P), "
                       "vec3(testIn[i].x, testIn[i].y, testIn[i].z));");
        ASSERT_EQ(rho.size(), pts.size());
        for (std::size_t i = 0; i < pts.size(); ++i) {
            const float want = field.density(vec3(pts[i].x, pts[i].y, pts[i].z));
            if (want > 0.0f) ++cloudy;
            largestDensity = std::max(largestDensity, double(want));
            worstDensity = std::max(worstDensity, double(std::abs(rho[i] - want)));
        }
        densities += pts.size();
    }
    RecordProperty("baked_noise_lookups", std::to_string(lookups));
    RecordProperty("baked_noise_max_abs_difference", std::to_string(worstNoise));
    RecordProperty("baked_density_max_abs_difference", std::to_string(worstDensity));
    std::printf("[ rt lookups ] baked noise: %zu tile lookups, largest difference %.3g; %zu "
                "densities (%zu > 0, largest %.3g), largest difference %.3g\n",
                lookups, worstNoise, densities, cloudy, largestDensity, worstDensity);
    EXPECT_GT(cloudy, densities / 100);
    // the tiles' lookups: the same floats, the same arithmetic
    EXPECT_LE(worstNoise, 1e-6);
    // the densities add the kernels' envelope and domain on the GPU (a few ulp apart)
    EXPECT_LE(worstDensity, 1e-5 * largestDensity);
}

/// Renders frame `frame` of the default scene with `extra` settings on the CPU (march) and on
/// the GPU; returns the PSNR of the GPU image against the CPU image (and records it).
double sceneGpuAgainstCpu(const std::string& scene, const std::vector<std::string>& settings,
                          int frame, const std::string& tag, double* maxAbs,
                          std::size_t minCloudyPercent = 10) {
    host::Session session;
    const host::Status st = session.load(scene, settings);
    EXPECT_TRUE(st.ok()) << st.message;
    Framebuffer cpu, gpu;
    RenderStats cpuStats;
    EXPECT_TRUE(session.bind(frame).ok()); // a VDB field's grid, in session.bindings()
    FramePlan plan = session.plan(frame);
    // the GPU march takes no paths of its own for the sun's second scattering (the CPU's
    // render.photon_second_share): the CPU frame leaves them out too, so that its photons carry
    // that order and both sides compute the same light from the same grids
    plan.secondShare = 0.0f;
    EXPECT_TRUE(plan.refusal.empty()) << plan.refusal;
    // the CPU frame, and the multiple-scattering grids it was rendered with
    MarchGrids grids;
    EXPECT_TRUE(session.renderer().render(plan, session.bindings(), cpu, cpuStats, {}, &grids));
    EXPECT_EQ(grids.hasDiffusion, plan.diffusion) << tag;
    EXPECT_EQ(grids.hasPhotons, plan.photons) << tag;
    // the noise tiles the CPU frame sampled, when its plan baked them (none otherwise)
    const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
    EXPECT_EQ(noise.base != nullptr, plan.bakeNoise) << tag;
    // the majorant grid the CPU frame skipped with, as `nimbus rt` passes it (RT_SKIP)
    const MajorantGrid majorant = rt::majorantGrid(session.renderer(), plan, session.bindings());
    rt::MarchPass pass;
    rt::MarchStats gpuStats;
    std::string error;
    EXPECT_TRUE(pass.render(session.scene(), plan, &grids, &session.bindings(), &noise, &majorant,
                            gpu, gpuStats, &error))
        << error;
    EXPECT_EQ(gpu.rgba.size(), cpu.rgba.size());
    if (gpu.rgba.size() != cpu.rgba.size()) return 0.0;
    EXPECT_EQ(gpuStats.nonFinite, 0u);
    // the picture is not trivially empty: the field covers a good part of the frame
    std::size_t cloudy = 0;
    for (std::size_t i = 0; i < cpu.transmittance.size(); i += 3)
        if (cpu.transmittance[i] < 0.9f) ++cloudy;
    EXPECT_GT(cloudy, cpu.transmittance.size() / 3 * minCloudyPercent / 100) << tag;
    const double psnr = psnrRgb(cpu.rgba, gpu.rgba, maxAbs);
    ::testing::Test::RecordProperty("psnr_db_" + tag, std::to_string(psnr));
    ::testing::Test::RecordProperty("max_abs_" + tag, std::to_string(*maxAbs));
    ::testing::Test::RecordProperty("gpu_seconds_" + tag, std::to_string(gpuStats.frameSeconds));
    std::printf("[ rt parity ] %s: PSNR %.2f dB, largest difference %.3g, GPU %.3f s "
                "(compile %.3f s; slices of %d steps, %d dispatches, %d renders discarded), CPU "
                "integration %.3f s, %zu of %zu pixels cloudy\n",
                tag.c_str(), psnr, *maxAbs, gpuStats.frameSeconds, gpuStats.compileSeconds,
                gpuStats.sliceSteps, gpuStats.dispatches, gpuStats.budgetRetries,
                cpuStats.integrateSeconds, cloudy, cpu.transmittance.size() / 3);
    // the AOVs too: transmittance and depth are written by the same pass
    if (!cpu.transmittance.empty()) {
        double dT = 0.0;
        for (std::size_t i = 0; i < cpu.transmittance.size(); ++i)
            dT = std::max(dT, double(std::abs(cpu.transmittance[i] - gpu.transmittance[i])));
        ::testing::Test::RecordProperty("max_abs_transmittance_" + tag, std::to_string(dT));
    }
    return psnr;
}

// The default scene at 96x54 (160x90 until 2026-12-04: the same branches, 2.8x the pixels and
// about 1.5x the time on llvmpipe) against the CPU.
double gpuAgainstCpu(int frame, const std::vector<std::string>& extra, const std::string& tag,
                     double* maxAbs, const std::string& ms = "none") {
    std::vector<std::string> settings = paritySettings(96, 54, ms);
    settings.insert(settings.end(), extra.begin(), extra.end());
    return sceneGpuAgainstCpu(kDefaultScene, settings, frame, tag, maxAbs);
}

TEST(RtMarchParity, DefaultSceneFrame1) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {}, "default_frame1", &maxAbs), 45.0);
}

// frame 12: the wind offsets of the field, the frame's own seeds
TEST(RtMarchParity, DefaultSceneFrame12) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(12, {}, "default_frame12", &maxAbs), 45.0);
}

// the other branches of the pass: Olajos in-scatter, a Draine phase function, one octave,
// several filtered samples per pixel, no jitter, a transparent background
TEST(RtMarchParity, OtherSettings) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(
        gpuAgainstCpu(1,
                      {"render.inscatter=\"olajos\"", "medium.phase=\"draine\"", "medium.g=0.6",
                       "render.octaves=1", "render.pixel_samples=4", "render.filter=\"gaussian\"",
                       "render.filter_width=2.0", "render.background=\"transparent\""},
                      "variant", &maxAbs),
        45.0);
    EXPECT_GE(gpuAgainstCpu(1, {"render.jitter=false", "medium.phase=\"mie_approx\""},
                            "no_jitter_mie_approx", &maxAbs),
              45.0);
}

// the Lorenz-Mie table (render.phase = "mie_table"), read from a buffer as MieTable::eval reads
// it, through the octaves (PhaseFunction::octave blends it toward isotropic)
TEST(RtMarchParity, MieTable) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {"medium.phase=\"mie_table\""}, "mie_table", &maxAbs), 45.0);
}

// field.evaluation = "baked": the noise read from the tiles the CPU baked (the same floats, the
// same trilinear lookup), at frames 1 and 12 (the wind moves the domain through the tiles)
TEST(RtMarchParity, BakedNoise) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {"field.evaluation=\"baked\""}, "baked_frame1", &maxAbs), 45.0);
    EXPECT_GE(gpuAgainstCpu(12, {"field.evaluation=\"baked\""}, "baked_frame12", &maxAbs), 45.0);
    // with the diffusion grid (built over the baked field on the CPU)
    EXPECT_GE(gpuAgainstCpu(1, {"field.evaluation=\"baked\""}, "baked_grid", &maxAbs, "grid"),
              45.0);
}

// field.evaluation = "rgba": Olajos' channel layout, RGBA8 3D textures filtered by the texture
// unit (its weights are the GL's own, so the image is close to the CPU's, not equal), at frames
// 1 and 12 and with the diffusion grid; the pass refuses float tiles for it
TEST(RtMarchParity, RgbaNoiseTextures) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {"field.evaluation=\"rgba\""}, "rgba_frame1", &maxAbs), 45.0);
    EXPECT_GE(gpuAgainstCpu(12, {"field.evaluation=\"rgba\""}, "rgba_frame12", &maxAbs), 45.0);
    EXPECT_GE(gpuAgainstCpu(1, {"field.evaluation=\"rgba\""}, "rgba_grid", &maxAbs, "grid"), 45.0);
    host::Session session;
    std::vector<std::string> settings = paritySettings(48, 27);
    settings.push_back("field.evaluation=\"rgba\"");
    ASSERT_TRUE(session.load(kDefaultScene, settings).ok());
    const FramePlan plan = session.plan(1);
    EXPECT_TRUE(plan.bakeNoise);
    const rt::MarchFeatures f = rt::marchFeatures(session.scene(), plan);
    EXPECT_TRUE(f.bakedNoise && f.rgbaNoise);
    EXPECT_TRUE(contains(f.defines(), "#define RT_RGBA_NOISE 1\n"));
    EXPECT_TRUE(contains(rt::explainMarch(session.scene(), plan), "Olajos' channel layout"));
    CumulusDesc floats = session.scene().field.cumulus;
    floats.eval = NoiseEval::Baked;
    rt::BakedNoise wrong;
    wrong.base = bakeCumulusBase(floats);
    wrong.detail = bakeCumulusDetail(floats);
    Framebuffer fb;
    rt::MarchStats stats;
    std::string error;
    rt::MarchPass pass;
    EXPECT_FALSE(pass.render(session.scene(), plan, nullptr, nullptr, &wrong, fb, stats, &error));
    EXPECT_TRUE(contains(error, "are float tiles, not RGBA8")) << error;
}

// field.evaluation = "auto" where the plan bakes (160x90 of the default scene): the GPU follows
// the CPU's plan (the frame's tiles, RT_BAKED_NOISE)
TEST(RtMarchParity, AutoFollowsThePlansBake) {
    if (!requireContext()) return;
    host::Session session;
    std::vector<std::string> settings = paritySettings(160, 90);
    settings.push_back("field.evaluation=\"auto\"");
    ASSERT_TRUE(session.load(kDefaultScene, settings).ok());
    ASSERT_TRUE(session.plan(1).bakeNoise) << session.plan(1).noiseDecision;
    EXPECT_TRUE(rt::marchFeatures(session.scene(), session.plan(1)).bakedNoise);
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {"field.evaluation=\"auto\""}, "auto_baked_frame1", &maxAbs), 45.0);
    // without the tiles the pass refuses the frame rather than evaluate the noise itself
    Framebuffer fb;
    rt::MarchStats stats;
    std::string error;
    rt::MarchPass pass;
    EXPECT_FALSE(pass.render(session.scene(), session.plan(1), fb, stats, &error));
    EXPECT_TRUE(contains(error, "tiles were not given")) << error;
}

// render.multiple_scattering = "grid": the diffusion grid the CPU solved, read trilinearly with
// its gradient (the P1 radiance), in place of the sky ambient; the default scene as it ships
TEST(RtMarchParity, DiffusionGrid) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {}, "ms_grid", &maxAbs, "grid"), 45.0);
    // with the Mie table too (the diffusion's P1 term takes the table's mean cosine)
    EXPECT_GE(
        gpuAgainstCpu(1, {"medium.phase=\"mie_table\""}, "ms_grid_mie_table", &maxAbs, "grid"),
        45.0);
}

// render.shadow = "volume": the sun's density integral read from the CPU's light-attenuation
// volume (RT_LIGHT_VOLUME) as MarchContext reads it, with multiple scattering off and with the
// diffusion grid. The CPU images with the volume and with shadow marches differ by about 30 dB
// (29.76 dB at 320x180), so a pass that ignored the volume would fail here.
TEST(RtMarchParity, LightVolume) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {"render.shadow=\"volume\""}, "light_volume", &maxAbs), 45.0);
    EXPECT_GE(
        gpuAgainstCpu(1, {"render.shadow=\"volume\""}, "light_volume_ms_grid", &maxAbs, "grid"),
        45.0);
}

// The single-scattered sky from the CPU's sky volume (render.sky_shadow = "volume",
// RT_SKY_VOLUME): its directions, radiances and density integrals read from one buffer as
// MarchContext::skyWeights and skySingleScatter read them; alone (render.sky_scattering =
// "single"), with the Lorenz-Mie table toward the sky's directions, and under the sky's photons
// (render.photon_sky). On the CPU the sky's first scattering changes the image by far more than
// the parity bound (a pass that left it out, or kept the ambient term, would fail).
TEST(RtMarchParity, SingleScatteredSkyFromTheVolume) {
    if (!requireContext()) return;
    const std::vector<std::string> single = {"render.sky_scattering=\"single\"",
                                             "render.sky_shadow=\"volume\""};
    {
        host::Session a, b;
        ASSERT_TRUE(a.load(kDefaultScene, paritySettings(160, 90)).ok());
        std::vector<std::string> sets = paritySettings(160, 90);
        sets.insert(sets.end(), single.begin(), single.end());
        ASSERT_TRUE(b.load(kDefaultScene, sets).ok());
        ASSERT_TRUE(b.plan(1).skyVolume);
        Framebuffer fa, fb;
        RenderStats sa, sb;
        ASSERT_TRUE(a.render(1, fa, sa).ok());
        ASSERT_TRUE(b.render(1, fb, sb).ok());
        double maxAbs = 0.0;
        const double apart = psnrRgb(fa.rgba, fb.rgba, &maxAbs);
        std::printf("[ rt parity ] CPU, ambient sky against the single-scattered sky: %.2f dB\n",
                    apart);
        EXPECT_LT(apart, 35.0);
    }
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, single, "sky_single_volume", &maxAbs), 45.0);
    std::vector<std::string> mie = single;
    mie.push_back("medium.phase=\"mie_table\"");
    EXPECT_GE(gpuAgainstCpu(1, mie, "sky_single_volume_mie_table", &maxAbs), 45.0);
    EXPECT_GE(gpuAgainstCpu(1, {"render.photon_sky=true", "render.sky_shadow=\"volume\""},
                            "photon_sky_volume", &maxAbs, "photons"),
              45.0);
}

// render.multiple_scattering = "photons": the sun's photon grid (one octave) and the sky's
// diffusion grid
TEST(RtMarchParity, PhotonGrid) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(gpuAgainstCpu(1, {}, "ms_photons", &maxAbs, "photons"), 45.0);
    // with the skin profile (the density integral toward the sun from the light volume)
    EXPECT_GE(gpuAgainstCpu(1, {"render.photon_skin=0.2"}, "ms_photons_skin", &maxAbs, "photons"),
              45.0);
    // on a grid of their own, finer than the light volume (render.photon_cell_scale)
    EXPECT_GE(
        gpuAgainstCpu(1, {"render.photon_cell_scale=0.5"}, "ms_photons_half", &maxAbs, "photons"),
        45.0);
    // traced through 4 scatterings, the higher orders diffused from their light
    // (render.photon_bounces: the diffusion grid the GPU reads carries them)
    EXPECT_GE(
        gpuAgainstCpu(1, {"render.photon_bounces=4"}, "ms_photons_hand_off", &maxAbs, "photons"),
        45.0);
}

// --- VDB grids (field.kind = "vdb", RT_VDB): PNanoVDB in GLSL against NanoVDB on the CPU --------

namespace {

const std::string kSharedVdb = NIMBUS_SHARED_VDB_DIR;
const std::string kSmoke1 = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/smoke1.toml";

bool sharedSmoke1Here() {
    return std::filesystem::exists(kSharedVdb + "/openvdb_smoke1.vdb");
}

/// The lookups of march_data.glsl (RT_VDB) against the CPU on the grid of `scene`, frame 1:
/// rtVdbValue(ijk) against NanoVDB's accessor at integer coordinates, and rtVdbDensity(p)
/// against Field::density (GridField::density: trilinear, the map, the density scale, the box)
/// at world points: random over the box and 10% around it, at voxel centres, and on the
/// borders of leaves (index 8n - 1 .. 8n) and lower nodes (128n) with fractions 0, 1e-3, 0.5 and
/// 1 - 1e-3 (in float). Returns the number of points; *worst gets the largest difference
/// relative to the grid's largest density.
std::size_t vdbLookupsAgainstCpu(const std::string& scene, const std::vector<std::string>& sets,
                                 double* worst) {
    *worst = 1e30;
    host::Session session;
    const host::Status st = session.load(scene, sets);
    EXPECT_TRUE(st.ok()) << st.message;
    EXPECT_TRUE(session.bind(1).ok());
    const FramePlan plan = session.plan(1);
    const rt::MarchFeatures f = rt::marchFeatures(session.scene(), plan);
    EXPECT_TRUE(f.vdb);
    const GridBinding& binding = session.bindings().grid(0);
    const auto* grid = static_cast<const nanovdb::FloatGrid*>(binding.grid);
    EXPECT_NE(grid, nullptr);
    if (!grid || !f.vdb) return 0;
    std::string error;
    const rt::VdbGridBytes bytes = rt::vdbGridBytes(&session.bindings(), &error);
    EXPECT_NE(bytes.data, nullptr) << error;
    if (!bytes.data) return 0;
    const gl::StorageBuffer buffer(bytes.size, bytes.data);
    buffer.bind(9);
    const rt::RtMarchParams P =
        rt::marchParams(session.scene(), plan, nullptr, &session.bindings());
    const Field field = makeField(session.scene().field, plan.time, binding);
    EXPECT_EQ(P.vdbDensity, session.scene().field.vdb.density);

    // integer coordinates: the active index box and 3 voxels around it, every 3rd voxel along
    // each axis, plus every voxel of the leaf and node borders the box crosses
    const nanovdb::CoordBBox ib = grid->indexBBox();
    std::vector<glm::vec4> ijk;
    std::uint32_t h = 2024u;
    auto u = [&] { return kern::hashToUnit(h = kern::pcg(h)); };
    for (int n = 0; n < 20000; ++n) {
        nanovdb::Coord c;
        for (int a = 0; a < 3; ++a)
            c[a] = ib.min()[a] - 3 + int(u() * float(ib.max()[a] - ib.min()[a] + 7));
        // every 4th point snapped onto a leaf border
        if (n % 4 == 0) c[n % 3] = (c[n % 3] & ~7) + ((n / 4) % 2 ? 7 : 8);
        ijk.emplace_back(float(c[0]), float(c[1]), float(c[2]), 1.0f);
    }
    const std::vector<float> values =
        runLookups(f, P, ijk, 1,
                   "testOut[i] = rtVdbValue(ivec3(int(testIn[i].x), int(testIn[i].y), "
                   "int(testIn[i].z)));");
    EXPECT_EQ(values.size(), ijk.size());
    if (values.size() != ijk.size()) return 0;
    auto acc = grid->getAccessor();
    std::size_t valueDiffs = 0, nonZero = 0;
    for (std::size_t i = 0; i < ijk.size(); ++i) {
        const nanovdb::Coord c(int(ijk[i].x), int(ijk[i].y), int(ijk[i].z));
        const float want = acc.getValue(c);
        nonZero += want != 0.0f;
        if (std::memcmp(&want, &values[i], 4) != 0 && valueDiffs++ < 5)
            ADD_FAILURE() << "voxel " << c[0] << " " << c[1] << " " << c[2] << ": GPU " << values[i]
                          << ", CPU " << want;
    }
    EXPECT_EQ(valueDiffs, 0u) << "voxel values differ from NanoVDB's accessor";
    EXPECT_GT(nonZero, ijk.size() / 10) << "too few voxels with density among the lookups";

    // world points
    std::vector<glm::vec4> in;
    const Box b = binding.bounds;
    const vec3 margin = 0.1f * (b.hi - b.lo);
    for (int n = 0; n < 8192; ++n) {
        const vec3 t(u(), u(), u());
        const vec3 p = b.lo - margin + t * (b.hi - b.lo + 2.0f * margin);
        in.emplace_back(p.x, p.y, p.z, 0.0f);
    }
    auto world = [&](float x, float y, float z) {
        const nanovdb::Vec3f w = grid->indexToWorldF(nanovdb::Vec3f(x, y, z));
        in.emplace_back(w[0], w[1], w[2], 0.0f);
    };
    for (int n = 0; n < 2048; ++n) { // voxel centres
        nanovdb::Coord c;
        for (int a = 0; a < 3; ++a)
            c[a] = ib.min()[a] + int(u() * float(ib.max()[a] - ib.min()[a] + 1));
        world(float(c[0]), float(c[1]), float(c[2]));
    }
    const float fractions[4] = {0.0f, 1e-3f, 0.5f, 1.0f - 1e-3f};
    for (int n = 0; n < 8192; ++n) { // leaf and lower-node borders along one axis
        float x[3];
        for (int a = 0; a < 3; ++a)
            x[a] = float(ib.min()[a]) + u() * float(ib.max()[a] - ib.min()[a]);
        const int a = n % 3;
        const int period = n % 5 == 0 ? 128 : 8;
        const int lo = int(std::floor(x[a] / float(period))) * period;
        const int border = lo - 1 + (n / 3) % 2; // the last voxel of a node or the first
        x[a] = float(border) + fractions[(n / 6) % 4];
        world(x[0], x[1], x[2]);
    }
    const std::vector<float> out = runLookups(
        f, P, in, 1,
        "testOut[i] = rtVdbDensity(vec3(testIn[i].x, testIn[i].y, testIn[i].z), P.vdbDensity);");
    EXPECT_EQ(out.size(), in.size());
    if (out.size() != in.size()) return 0;
    double scale = 0.0, maxDiff = 0.0;
    std::size_t identical = 0, dense = 0;
    std::vector<float> want(in.size());
    for (std::size_t i = 0; i < in.size(); ++i) {
        want[i] = field.density(vec3(in[i].x, in[i].y, in[i].z));
        scale = std::max(scale, double(want[i]));
        dense += want[i] > 0.0f;
    }
    EXPECT_GT(scale, 0.0);
    for (std::size_t i = 0; i < in.size(); ++i) {
        const double d = std::abs(double(out[i]) - double(want[i]));
        maxDiff = std::max(maxDiff, d);
        identical += std::memcmp(&out[i], &want[i], 4) == 0;
    }
    *worst = maxDiff / std::max(scale, 1e-30);
    std::printf("[ rt lookups ] VDB %s: %zu voxel values identical to NanoVDB's accessor (%zu "
                "non-zero); %zu densities (%zu non-zero): %zu bit-identical to "
                "GridField::density, largest difference %.3g of the largest density %.4g\n",
                grid->gridName(), ijk.size() - valueDiffs, nonZero, in.size(), dense, identical,
                *worst, scale);
    EXPECT_GT(dense, in.size() / 10) << "too few points with density";
    return in.size();
}

} // namespace

// The lookups on a grid the test writes itself (tests/rt_vdb_scene.h): no shared data needed.
TEST(RtVdbLookups, WrittenGridAsTheCpu) {
    if (!requireContext()) return;
    TempDir dir("rt_vdb_lookups");
    double worst = 1.0;
    const std::size_t n = vdbLookupsAgainstCpu(writeRtVdbScene(dir.string()), {}, &worst);
    RecordProperty("vdb_lookups", std::to_string(n));
    RecordProperty("vdb_max_relative_difference", std::to_string(worst));
    EXPECT_GT(n, 0u);
    EXPECT_LE(worst, 1e-6);
}

// The same on OpenVDB's smoke plume (examples/scenes/smoke1.toml; the shared data folder).
TEST(RtVdbLookups, Smoke1AsTheCpu) {
    if (!sharedSmoke1Here())
        GTEST_SKIP() << "shared VDB folder " << kSharedVdb
                     << " (openvdb_smoke1.vdb) is absent: smoke1 lookups skipped";
    if (!requireContext()) return;
    double worst = 1.0;
    const std::size_t n = vdbLookupsAgainstCpu(kSmoke1, {}, &worst);
    RecordProperty("vdb_lookups", std::to_string(n));
    RecordProperty("vdb_max_relative_difference", std::to_string(worst));
    EXPECT_GT(n, 0u);
    EXPECT_LE(worst, 1e-6);
}

// The shader of a VDB frame has PNanoVDB and no cumulus; a cumulus frame's has no PNanoVDB.
TEST(RtVdbShader, HasPnanovdbOnlyForVdb) {
    TempDir dir("rt_vdb_shader");
    host::Session session;
    ASSERT_TRUE(session.load(writeRtVdbScene(dir.string()), {}).ok());
    const rt::MarchFeatures f = rt::marchFeatures(session.scene(), session.plan(1));
    EXPECT_TRUE(f.vdb);
    EXPECT_TRUE(contains(f.defines(), "#define RT_VDB 1\n"));
    const std::string text = rt::marchShaderSource(f);
    EXPECT_TRUE(contains(text, "buffer RtVdbGrid { uint pnanovdb_buf_data[]; };"));
    EXPECT_TRUE(contains(text, "pnanovdb_readaccessor_get_value_address("));
    host::Session cumulus;
    ASSERT_TRUE(cumulus.load(kDefaultScene, paritySettings(32, 18)).ok());
    const rt::MarchFeatures g = rt::marchFeatures(cumulus.scene(), cumulus.plan(1));
    EXPECT_FALSE(g.vdb);
    EXPECT_TRUE(contains(g.defines(), "#define RT_VDB 0\n"));
    // without RT_VDB PNanoVDB's text is not spliced in at all (only march_data.glsl's own
    // lookups stand there, inside their #if RT_VDB)
    EXPECT_TRUE(contains(text, "struct pnanovdb_readaccessor_t"));
    EXPECT_FALSE(contains(rt::marchShaderSource(g), "struct pnanovdb_readaccessor_t"));
    EXPECT_FALSE(contains(rt::marchShaderSource(g), "pnanovdb_buf_read_uint32("));
    // a VDB frame without its grid bound is an error, not an empty picture
    Framebuffer fb;
    rt::MarchStats stats;
    std::string error;
    if (!requireContext()) return;
    rt::MarchPass pass;
    EXPECT_FALSE(
        pass.render(session.scene(), session.plan(1), nullptr, nullptr, fb, stats, &error));
    EXPECT_TRUE(contains(error, "VDB grid was not loaded")) << error;
}

// The written grid's image: the sun's shadow marches and octaves, the sky ambient, then the
// diffusion grid (solved on the CPU over the VDB field).
TEST(RtVdbParity, WrittenGrid) {
    if (!requireContext()) return;
    TempDir dir("rt_vdb_parity");
    const std::string scene = writeRtVdbScene(dir.string());
    double maxAbs = 0.0;
    EXPECT_GE(sceneGpuAgainstCpu(scene, {}, 1, "vdb_written", &maxAbs), 45.0);
    EXPECT_GE(sceneGpuAgainstCpu(scene, {"render.multiple_scattering=\"grid\""}, 1,
                                 "vdb_written_ms_grid", &maxAbs),
              45.0);
    // ten times as dense, steps of several mean free paths split (render.step_tau): the
    // camera's and the shadow marches' sub-steps
    EXPECT_GE(sceneGpuAgainstCpu(scene, {"field.density=15.0", "render.step_tau=0.25"}, 1,
                                 "vdb_written_step_tau", &maxAbs),
              45.0);
}

// smoke1 as it ships (the diffusion grid, 8 octaves) at 160x90.
TEST(RtVdbParity, Smoke1) {
    if (!sharedSmoke1Here())
        GTEST_SKIP() << "shared VDB folder " << kSharedVdb
                     << " (openvdb_smoke1.vdb) is absent: smoke1 parity skipped";
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(sceneGpuAgainstCpu(kSmoke1,
                                 {"camera.width=160", "camera.height=90",
                                  "output.aovs=[\"transmittance\", \"depth\"]"},
                                 1, "smoke1", &maxAbs, 5),
              45.0);
}

// --- Empty-space skipping (RT_SKIP): the same image, bit for bit, with fewer lookups ------------

namespace {

/// What skipAgainstNoSkip found.
struct SkipRun {
    bool skip = false;          ///< RT_SKIP was compiled in
    double emptyFraction = 0.0; ///< of the majorant grid's cells
    std::size_t differing = 0;  ///< floats of RGBA, transmittance and depth not bit-identical
    std::size_t floats = 0;     ///< floats compared
    std::size_t cloudy = 0;     ///< pixels with transmittance < 0.9
    double skipSeconds = 0.0, fullSeconds = 0.0;
};

/// Renders frame `frame` of `scene` with the GLSL pass twice: with the frame's majorant grid
/// (rt::majorantGrid, the grid the CPU renders with: RT_SKIP) and without (every step taken),
/// with the multiple-scattering grids and noise tiles the frame needs, and compares every float
/// of the RGBA, transmittance and depth bit for bit.
SkipRun skipAgainstNoSkip(const std::string& scene, const std::vector<std::string>& settings,
                          int frame, const std::string& tag) {
    SkipRun r;
    host::Session session;
    const host::Status st = session.load(scene, settings);
    EXPECT_TRUE(st.ok()) << st.message;
    if (!st.ok()) return r;
    EXPECT_TRUE(session.bind(frame).ok());
    const FramePlan plan = session.plan(frame);
    RenderStats gridStats;
    const MarchGrids grids =
        rt::readsMarchGrids(plan)
            ? session.renderer().marchGrids(plan, session.bindings(), gridStats)
            : MarchGrids{};
    const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
    const MajorantGrid majorant = rt::majorantGrid(session.renderer(), plan, session.bindings());
    r.skip = rt::marchFeatures(session.scene(), plan, &majorant).skip;
    r.emptyFraction = majorant.emptyFraction();
    EXPECT_FALSE(rt::marchFeatures(session.scene(), plan).skip) << tag;
    rt::MarchPass pass;
    Framebuffer skipped, full;
    rt::MarchStats skipStats, fullStats;
    std::string error;
    EXPECT_TRUE(pass.render(session.scene(), plan, &grids, &session.bindings(), &noise, &majorant,
                            skipped, skipStats, &error))
        << tag << ": " << error;
    EXPECT_TRUE(pass.render(session.scene(), plan, &grids, &session.bindings(), &noise, nullptr,
                            full, fullStats, &error))
        << tag << ": " << error;
    r.skipSeconds = skipStats.frameSeconds;
    r.fullSeconds = fullStats.frameSeconds;
    EXPECT_EQ(skipStats.nonFinite, 0u) << tag;
    auto compare = [&](const std::vector<float>& a, const std::vector<float>& b) {
        EXPECT_EQ(a.size(), b.size()) << tag;
        if (a.size() != b.size()) return;
        for (std::size_t i = 0; i < a.size(); ++i)
            r.differing += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
        r.floats += a.size();
    };
    compare(skipped.rgba, full.rgba);
    compare(skipped.transmittance, full.transmittance);
    compare(skipped.depth, full.depth);
    for (std::size_t i = 0; i < full.transmittance.size(); i += 3)
        r.cloudy += full.transmittance[i] < 0.9f;
    ::testing::Test::RecordProperty("skip_differing_" + tag, std::to_string(r.differing));
    ::testing::Test::RecordProperty("skip_empty_fraction_" + tag, std::to_string(r.emptyFraction));
    std::printf("[ rt skip ] %s: RT_SKIP %d (majorant %dx%dx%d, %.1f%% empty): %zu of %zu floats "
                "differ; %zu pixels cloudy; GPU %.3f s skipping, %.3f s not\n",
                tag.c_str(), int(r.skip), majorant.res.x, majorant.res.y, majorant.res.z,
                100.0 * r.emptyFraction, r.differing, r.floats, r.cloudy, r.skipSeconds,
                r.fullSeconds);
    return r;
}

const std::string kDragonVdb = kSharedVdb + "/vpt_dragon.vdb";
/// A sparse fog volume (vpt_dragon.vdb from the shared data folder: 19,660 active voxels of 0.1).
const std::string kDragon = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/dragon.toml";

} // namespace

// The default scene: samples in the majorant grid's empty cells are not evaluated, and the image
// is the one the pass renders taking every step, bit for bit: multiple scattering off with the
// noise evaluated per sample (frames 1 and 12: the wind moves the cloud through the grid's
// cells), and as the scene ships (the diffusion grid; the plan bakes the noise at 160x90).
TEST(RtSkip, DefaultSceneBitIdentical) {
    if (!requireContext()) return;
    for (int frame : {1, 12}) {
        const SkipRun r = skipAgainstNoSkip(kDefaultScene, paritySettings(160, 90), frame,
                                            "default_frame" + std::to_string(frame));
        EXPECT_TRUE(r.skip);
        EXPECT_GT(r.emptyFraction, 0.0);
        EXPECT_GT(r.cloudy, 160u * 90u / 10u);
        EXPECT_EQ(r.differing, 0u) << "frame " << frame;
    }
    const SkipRun r = skipAgainstNoSkip(kDefaultScene, {"camera.width=160", "camera.height=90"}, 1,
                                        "default_as_shipped");
    EXPECT_TRUE(r.skip);
    EXPECT_EQ(r.differing, 0u);
}

// smoke1 as it ships (the diffusion grid; the shared data folder).
TEST(RtSkip, Smoke1BitIdentical) {
    if (!sharedSmoke1Here())
        GTEST_SKIP() << "shared VDB folder " << kSharedVdb
                     << " (openvdb_smoke1.vdb) is absent: smoke1 skipping skipped";
    if (!requireContext()) return;
    const SkipRun r = skipAgainstNoSkip(
        kSmoke1,
        {"camera.width=160", "camera.height=90", "output.aovs=[\"transmittance\", \"depth\"]"}, 1,
        "smoke1");
    EXPECT_TRUE(r.skip);
    EXPECT_GT(r.cloudy, 160u * 90u / 20u);
    EXPECT_EQ(r.differing, 0u);
}

// Sparse VDB grids: the grid the test writes (three blobs with empty leaves between them) and
// the shared folder's dragon (examples/scenes/dragon.toml; skipped without it).
TEST(RtSkip, SparseVdbBitIdentical) {
    if (!requireContext()) return;
    TempDir dir("rt_skip_vdb");
    SkipRun r = skipAgainstNoSkip(writeRtVdbScene(dir.string()),
                                  {"output.aovs=[\"transmittance\", \"depth\"]"}, 1, "blobs");
    EXPECT_TRUE(r.skip);
    EXPECT_GT(r.emptyFraction, 0.05);
    EXPECT_GT(r.cloudy, 160u * 90u / 10u);
    EXPECT_EQ(r.differing, 0u);
    if (!std::filesystem::exists(kDragonVdb))
        GTEST_SKIP() << kDragonVdb << " is absent: the dragon's case skipped";
    r = skipAgainstNoSkip(
        kDragon,
        {"camera.width=160", "camera.height=90", "output.aovs=[\"transmittance\", \"depth\"]"}, 1,
        "dragon");
    EXPECT_TRUE(r.skip);
    EXPECT_GT(r.emptyFraction, 0.2);
    EXPECT_GT(r.cloudy, 160u * 90u / 50u);
    EXPECT_EQ(r.differing, 0u);
}

// Rays parallel to the axes (direction components exactly 0: the exit from a cell is found from
// the other axes only): the camera looks along +z and the centre row and column of an odd-sized
// image have x or y of exactly 0; the sun straight overhead, (0, 1, 0), sends every shadow ray
// along y. The frame finishes (the pass stays bounded) with the same image as without skipping.
TEST(RtSkip, AxisParallelRays) {
    if (!requireContext()) return;
    TempDir dir("rt_skip_axis");
    const std::string blobs = writeRtVdbScene(dir.string());
    std::ifstream in(blobs);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string sun = "elevation = 30.0\nazimuth = 60.0\n";
    ASSERT_NE(text.find(sun), std::string::npos);
    text.replace(text.find(sun), sun.size(), "direction = [0.0, 1.0, 0.0]\n");
    const std::string scene = dir.string() + "/blobs_axis.toml";
    std::ofstream(scene) << text;
    const SkipRun r = skipAgainstNoSkip(
        scene,
        {"camera.width=161", "camera.height=91", "output.aovs=[\"transmittance\", \"depth\"]"}, 1,
        "blobs_axis");
    EXPECT_TRUE(r.skip);
    EXPECT_EQ(r.floats, 161u * 91u * 8u);
    EXPECT_EQ(r.differing, 0u);
}

// RT_SKIP is compiled in only with a majorant grid that has an empty cell, and not with
// render.skip_empty = false (no grid is built); its buffer and lookups exist only with it.
TEST(RtSkip, OnlyWithAnEmptyCell) {
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, paritySettings(32, 18)).ok());
    const FramePlan plan = session.plan(1);
    const MajorantGrid grid = rt::majorantGrid(session.renderer(), plan, session.bindings());
    ASSERT_GT(grid.cellCount(), 0u);
    const rt::MarchFeatures on = rt::marchFeatures(session.scene(), plan, &grid);
    EXPECT_TRUE(on.skip);
    EXPECT_TRUE(contains(on.defines(), "#define RT_SKIP 1\n"));
    EXPECT_TRUE(contains(rt::explainMarch(session.scene(), plan, &grid), "empty-space skipping"));
    const rt::RtMarchParams P = rt::marchParams(session.scene(), plan, nullptr, nullptr, &grid);
    EXPECT_EQ(P.majorantResX, grid.res.x);
    EXPECT_EQ(P.majorantResZ, grid.res.z);
    EXPECT_EQ(P.majorantCell.y, grid.cellSize.y);
    EXPECT_EQ(P.majorantLo.x, grid.bounds.lo.x);
    // the grid covers the box the pass marches (a sample outside it is looked up, not skipped)
    for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(P.majorantLo[a], P.boundsLo[a]) << a;
        EXPECT_NEAR(P.majorantLo[a] + float(grid.res[a]) * P.majorantCell[a], P.boundsHi[a],
                    1e-4f * (P.boundsHi[a] - P.boundsLo[a]))
            << a;
    }
    // no empty cell: nothing to skip
    MajorantGrid full = grid;
    for (float& m : full.maj) m = 1.0f;
    EXPECT_FALSE(rt::marchFeatures(session.scene(), plan, &full).skip);
    EXPECT_EQ(rt::marchParams(session.scene(), plan, nullptr, nullptr, &full).majorantResX, 0);
    EXPECT_FALSE(rt::marchFeatures(session.scene(), plan, nullptr).skip);
    const std::string text = rt::marchShaderSource(on);
    EXPECT_TRUE(contains(text, "buffer RtMajorant"));
    rt::MarchFeatures off = on;
    off.skip = false;
    EXPECT_TRUE(contains(off.defines(), "#define RT_SKIP 0\n"));
    // render.skip_empty = false: no grid, no RT_SKIP
    host::Session noSkip;
    std::vector<std::string> sets = paritySettings(32, 18);
    sets.push_back("render.skip_empty=false");
    ASSERT_TRUE(noSkip.load(kDefaultScene, sets).ok());
    const FramePlan p2 = noSkip.plan(1);
    const MajorantGrid none = rt::majorantGrid(noSkip.renderer(), p2, noSkip.bindings());
    EXPECT_EQ(none.cellCount(), 0u);
    EXPECT_FALSE(rt::marchFeatures(noSkip.scene(), p2, &none).skip);
    EXPECT_TRUE(contains(rt::explainMarch(noSkip.scene(), p2, &none), "render.skip_empty = false"));
}

// `nimbus rt` writes the frame through the output code of `nimbus render` (colour conversion to
// output.color_space, metadata, AOVs): both EXRs of the same frame agree at PSNR >= 45 dB; with
// multiple_scattering = "grid" (the default scene's) the CLI computes the grid on the CPU first.
namespace {

/// `nimbus rt` and `nimbus render` of `frame` (`--frames frame`) with their own arguments, each
/// writing <dir>/gpu.####.exr and <dir>/cpu.####.exr: both must exit 0 and the GPU EXR's values
/// be finite; psnr is that of its RGBA against the CPU EXR's (recorded as psnr_db_<tag>,
/// printed), 0 when a run failed.
struct CliParity {
    double psnr = 0.0;
    CliRun gpu;
    io::ExrImage g, c;
};
CliParity rtAgainstRenderCli(const std::string& scene, int frame, const std::string& dir,
                             const std::string& gpuArgs, const std::string& cpuArgs,
                             const std::string& tag) {
    CliParity r;
    const std::string frames = " --frames " + std::to_string(frame);
    r.gpu = runNimbus("rt " + scene + frames + " -o " + dir + "/gpu.####.exr" + gpuArgs);
    EXPECT_EQ(r.gpu.exitCode, 0) << r.gpu.output;
    const CliRun cpu = runNimbus("render " + scene + frames + " --progress none -o " + dir +
                                 "/cpu.####.exr" + cpuArgs);
    EXPECT_EQ(cpu.exitCode, 0) << cpu.output;
    if (r.gpu.exitCode != 0 || cpu.exitCode != 0) return r;
    char number[16];
    std::snprintf(number, sizeof number, "%04d", frame);
    r.g = io::readExr(dir + "/gpu." + number + ".exr");
    r.c = io::readExr(dir + "/cpu." + number + ".exr");
    EXPECT_EQ(r.g.width, r.c.width);
    EXPECT_EQ(r.g.height, r.c.height);
    if (r.g.width != r.c.width || r.g.height != r.c.height) return r;
    std::vector<float> gr, cr;
    std::size_t nonFinite = 0;
    for (int y = 0; y < r.g.height; ++y)
        for (int x = 0; x < r.g.width; ++x)
            for (const char* ch : {"R", "G", "B", "A"}) {
                const float gv = r.g.at(x, y, r.g.channelIndex(ch));
                nonFinite += !std::isfinite(gv);
                gr.push_back(gv);
                cr.push_back(r.c.at(x, y, r.c.channelIndex(ch)));
            }
    EXPECT_EQ(nonFinite, 0u) << tag;
    double maxAbs = 0.0;
    r.psnr = psnrRgb(cr, gr, &maxAbs);
    ::testing::Test::RecordProperty("psnr_db_" + tag, std::to_string(r.psnr));
    std::printf("[ rt parity ] %s: PSNR %.2f dB\n", tag.c_str(), r.psnr);
    return r;
}

} // namespace

TEST(RtCli, WritesTheSameExrAsRender) {
    // "baked": no multiple-scattering grid, the noise from the tiles the CPU bakes
    for (const std::string ms : {"none", "grid", "baked"}) {
        TempDir dir("rt_cli");
        const std::string sets = " --set camera.width=64 --set camera.height=36 --set "
                                 "'render.multiple_scattering=\"" +
                                 (ms == "baked" ? std::string("none") : ms) +
                                 "\"' --set 'field.evaluation=\"" +
                                 (ms == "baked" ? "baked" : "direct") + "\"'" +
                                 // the grid on voxels of 0.5, not the scene's 0.117: its solve
                                 // with the noise evaluated directly was most of both sides' time
                                 (ms == "grid" ? " --set render.light_volume_cell=0.5" : "");
        auto preview = [&](const std::string& name) {
            return " --set 'output.preview=\"" + dir.string() + "/" + name + ".####.png\"'";
        };
        const CliParity r =
            rtAgainstRenderCli(kDefaultScene, 3, dir.string(), sets + preview("gpu"),
                               sets + preview("cpu"), "cli_64x36_" + ms);
        EXPECT_TRUE(contains(r.gpu.output, "frame 3: 64x36,"));
        EXPECT_EQ(contains(r.gpu.output, "multiple-scattering grid computed on the CPU"),
                  ms == "grid")
            << r.gpu.output;
        ASSERT_EQ(r.g.width, 64);
        ASSERT_EQ(r.g.height, 36);
        EXPECT_EQ(r.g.channels, r.c.channels);
        EXPECT_EQ(r.g.attributes.at("nimbus/colorSpace"), r.c.attributes.at("nimbus/colorSpace"));
        EXPECT_TRUE(contains(r.g.attributes.at("nimbus/settings/renderer"), "GLSL march pass"));
        EXPECT_GE(r.g.channelIndex("A"), 0);
        EXPECT_GE(r.psnr, 45.0) << ms;
    }
}

// An unsupported scene is refused before any GPU work, with exit 2 and the key in the message;
// no file is written.
TEST(RtCli, RefusesUnsupportedSceneWithExit2) {
    TempDir dir("rt_refuse");
    // the default scene with the column sky occlusion (its volumes are not on the GPU; without
    // the diffusion grid, which carries the sky instead)
    const std::string column =
        " --set 'render.multiple_scattering=\"none\"' --set 'render.sky_occlusion=\"column\"'";
    const CliRun r = runNimbus("rt " + kDefaultScene + " --frames 1 -o " + dir.string() +
                               "/x.####.exr --set camera.width=32 --set camera.height=18" + column);
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_TRUE(contains(r.output, "render.sky_occlusion"));
    EXPECT_FALSE(std::filesystem::exists(dir.string() + "/x.0001.exr"));
    // --explain stops on a refusal too
    const CliRun x = runNimbus("rt " + kDefaultScene + " --frames 1 --explain" + column);
    EXPECT_EQ(x.exitCode, 2) << x.output;
    EXPECT_TRUE(contains(x.output, "render.sky_occlusion"));
    // the light-attenuation volume is no longer refused: the shader reads the CPU's
    const CliRun v =
        runNimbus("rt " + kDefaultScene + " --frames 1 --set 'render.shadow=\"volume\"' --explain");
    EXPECT_EQ(v.exitCode, 0) << v.output;
    EXPECT_TRUE(contains(v.output, "RT_LIGHT_VOLUME 1")) << v.output;
    EXPECT_TRUE(contains(v.output, "sun through the light-attenuation volume")) << v.output;
    // baked noise is no longer refused: the shader reads the CPU's tiles
    const CliRun b = runNimbus("rt " + kDefaultScene +
                               " --frames 1 --set "
                               "'render.multiple_scattering=\"none\"' --set "
                               "'field.evaluation=\"baked\"' --explain");
    EXPECT_EQ(b.exitCode, 0) << b.output;
    EXPECT_TRUE(contains(b.output, "#define RT_BAKED_NOISE 1"));
    const CliRun e = runNimbus("rt " + kDefaultScene +
                               " --frames 1 --set "
                               "'render.multiple_scattering=\"none\"' --explain");
    EXPECT_EQ(e.exitCode, 0) << e.output;
    EXPECT_TRUE(contains(e.output, "#define RT_SUN 1"));
}

// `nimbus rt` on a VDB scene (the grid the test writes): the CLI binds the frame's grid, renders
// it on the GPU and writes the EXR `nimbus render` writes, within 45 dB; --explain names the
// field and RT_VDB.
TEST(RtCli, VdbWritesTheSameExrAsRender) {
    TempDir dir("rt_cli_vdb");
    const std::string scene = writeRtVdbScene(dir.string());
    const std::string sets = " --set camera.width=64 --set camera.height=36";
    const CliParity r = rtAgainstRenderCli(scene, 1, dir.string(), sets, sets, "cli_vdb_64x36");
    EXPECT_EQ(r.g.width, 64);
    EXPECT_GE(r.psnr, 45.0);
    const CliRun e = runNimbus("rt " + scene + " --frames 1 --explain" + sets);
    EXPECT_EQ(e.exitCode, 0) << e.output;
    EXPECT_TRUE(contains(e.output, "#define RT_VDB 1")) << e.output;
    EXPECT_TRUE(contains(e.output, "GPU field: vdb")) << e.output;
}

// --- SDF clouds (RT_SDF) ----------------------------------------------------------------------

namespace {

const std::string kSdfCloud = std::string(NIMBUS_SOURCE_DIR) + "/examples/scenes/sdf_cloud.toml";
/// sdf_cloud.toml with the sun's transmittance marched per sample (the scene ships with the
/// light-attenuation volume): the case that needs the march in slices on llvmpipe.
const std::string kSdfShadowMarch = "render.shadow=\"march\"";

/// A tree with every primitive and operator kind, smooth and hard blends, rotated, translated and
/// non-uniformly scaled nodes, and Perlin and Worley displacement on primitives and operators.
SdfNodeDesc everyKindTree() {
    auto at = [](SdfNodeDesc d, vec3 t, vec3 r = vec3(0.0f), vec3 sc = vec3(1.0f)) {
        d.transform.translate = t;
        d.transform.rotate = r;
        d.transform.scale = sc;
        return d;
    };
    SdfNodeDesc ell;
    ell.kind = SdfKind::Ellipsoid;
    ell.radii = vec3(1.6f, 0.9f, 1.2f);
    SdfNodeDesc rbox;
    rbox.kind = SdfKind::RoundBox;
    rbox.size = vec3(1.0f, 0.7f, 0.8f);
    rbox.rounding = 0.3f;
    SdfNodeDesc cap;
    cap.kind = SdfKind::Capsule;
    cap.a = vec3(-1.0f, 0.0f, 0.0f);
    cap.b = vec3(1.2f, 0.5f, 0.2f);
    cap.radius = 0.5f;
    SdfNodeDesc tor;
    tor.kind = SdfKind::Torus;
    tor.majorRadius = 1.1f;
    tor.minorRadius = 0.35f;
    tor.displacement = {0.15f, SdfNoise::Perlin, 2.0f, 3, 0.5f, 11u};
    SdfNodeDesc cone;
    cone.kind = SdfKind::Cone;
    cone.radius = 0.9f;
    cone.height = 1.8f;
    SdfNodeDesc plane;
    plane.kind = SdfKind::Plane;
    plane.normal = vec3(0.2f, -1.0f, 0.1f); // normalised by flattenSdf
    plane.offset = 0.4f;
    SdfNodeDesc hole = sdfSphere(0.8f);
    SdfNodeDesc blob =
        sdfOp(SdfKind::Union,
              {at(sdfSphere(1.3f), vec3(-2.5f, 1.0f, 0.0f)),
               at(ell, vec3(-0.5f, 1.4f, 0.3f), vec3(10.0f, 30.0f, -20.0f)),
               at(sdfBox(vec3(0.8f, 0.6f, 0.9f)), vec3(1.5f, 1.0f, -0.2f), vec3(0.0f, 45.0f, 0.0f),
                  vec3(1.0f, 1.5f, 0.8f)),
               at(rbox, vec3(3.2f, 1.2f, 0.4f), vec3(0.0f, 0.0f, 25.0f)),
               at(cap, vec3(0.0f, 2.6f, 0.0f)), at(tor, vec3(-1.5f, 2.8f, 0.5f), vec3(70.0f, 0, 0)),
               at(cone, vec3(2.0f, 2.4f, -0.5f), vec3(0.0f), vec3(1.2f))},
              0.6f);
    blob.displacement = {0.25f, SdfNoise::Perlin, 1.7f, 4, 0.55f, 3u};
    SdfNodeDesc carved = sdfOp(
        SdfKind::Subtraction,
        {blob, at(hole, vec3(0.3f, 1.5f, -1.2f)), at(sdfBox(vec3(0.4f)), vec3(-2.0f, 0.5f, -1.0f))},
        0.3f);
    SdfNodeDesc hard = sdfOp(SdfKind::Union, {carved, at(sdfSphere(0.5f), vec3(0, 4.2f, 0))});
    SdfNodeDesc root = sdfOp(SdfKind::Intersection, {hard, plane}, 0.4f);
    root.displacement = {0.35f, SdfNoise::Worley, 1.1f, 3, 0.5f, 7u};
    root.transform.translate = vec3(0.2f, 0.1f, -0.3f);
    root.transform.rotate = vec3(0.0f, 15.0f, 0.0f);
    root.transform.scale = vec3(1.1f, 0.9f, 1.0f);
    return root;
}

struct SdfLookupResult {
    std::size_t points = 0, inShell = 0, identicalDistance = 0, identicalDensity = 0;
    double maxDistance = 0.0, maxDensity = 0.0;
};

/// rtSdfDistance and rtSdfDensity (march_data.glsl, RT_SDF: the kernel sdfTreeStep over the node
/// buffer) against SdfTree::distance and Field::density of the field `sdf` in scene `base`, at
/// 8,192 random points over the field's box and 10% around it and 4,096 points near the surface
/// (random points pulled to the level set by a few Newton steps on the CPU's distance).
SdfLookupResult sdfLookupsAgainstCpu(const SceneDesc& base, const SdfFieldDesc& sdf) {
    SdfLookupResult r;
    SceneDesc s = base;
    s.field.kind = FieldKind::Sdf;
    s.field.sdf = sdf;
    const FramePlan plan = planFrame(s, 1);
    const rt::MarchFeatures f = rt::marchFeatures(s, plan);
    EXPECT_TRUE(f.sdf);
    const rt::RtMarchParams P = rt::marchParams(s, plan);
    const std::vector<kern::SdfTreeNode> nodes = rt::sdfTreeNodes(s);
    const SdfTree tree = flattenSdf(sdf.root);
    EXPECT_EQ(P.sdfNodeCount, int(tree.nodes.size()));
    EXPECT_EQ(nodes.size(), tree.nodes.size());
    EXPECT_EQ(std::memcmp(nodes.data(), tree.gpuNodes.data(), nodes.size() * sizeof nodes[0]), 0);
    const Field field = makeField(s.field, plan.time);
    EXPECT_EQ(P.boundsLo.x, field.box.lo.x);
    EXPECT_EQ(P.boundsHi.y, field.box.hi.y);
    const gl::StorageBuffer buffer(nodes.size() * sizeof(kern::SdfTreeNode), nodes.data());
    buffer.bind(12);

    std::vector<glm::vec4> in;
    std::uint32_t h = 4242u;
    auto u = [&] { return kern::hashToUnit(h = kern::pcg(h)); };
    const Box b = field.box;
    const vec3 margin = 0.1f * (b.hi - b.lo);
    auto randomPoint = [&] {
        return b.lo - margin + vec3(u(), u(), u()) * (b.hi - b.lo + 2.0f * margin);
    };
    for (int n = 0; n < 8192; ++n) {
        const vec3 p = randomPoint();
        in.emplace_back(p.x, p.y, p.z, 0.0f);
    }
    for (int n = 0; n < 4096; ++n) { // near the surface: Newton steps along the gradient
        vec3 p = randomPoint();
        for (int k = 0; k < 6; ++k) {
            const float d = tree.distance(p), e = 1e-3f;
            const vec3 g((tree.distance(p + vec3(e, 0, 0)) - d) / e,
                         (tree.distance(p + vec3(0, e, 0)) - d) / e,
                         (tree.distance(p + vec3(0, 0, e)) - d) / e);
            const float g2 = glm::dot(g, g);
            if (g2 > 1e-6f) p -= (d + 0.5f * sdf.falloff * u()) * g / g2;
        }
        in.emplace_back(p.x, p.y, p.z, 0.0f);
    }
    const std::vector<float> out =
        runLookups(f, P, in, 2,
                   "vec3 p = vec3(testIn[i].x, testIn[i].y, testIn[i].z);\n"
                   "testOut[2u * i] = rtSdfDistance(p);\n"
                   "testOut[2u * i + 1u] = rtSdfDensity(p);");
    EXPECT_EQ(out.size(), 2 * in.size());
    if (out.size() != 2 * in.size()) return r;
    r.points = in.size();
    for (std::size_t i = 0; i < in.size(); ++i) {
        const vec3 p(in[i].x, in[i].y, in[i].z);
        const float d = tree.distance(p), rho = field.density(p);
        r.inShell += rho > 0.0f && rho < sdf.density;
        r.maxDistance = std::max(r.maxDistance, double(std::abs(out[2 * i] - d)));
        r.maxDensity = std::max(r.maxDensity, double(std::abs(out[2 * i + 1] - rho)));
        r.identicalDistance += std::memcmp(&out[2 * i], &d, 4) == 0;
        r.identicalDensity += std::memcmp(&out[2 * i + 1], &rho, 4) == 0;
    }
    return r;
}

void reportSdfLookups(const std::string& tag, const SdfLookupResult& r, float scale) {
    ::testing::Test::RecordProperty("sdf_points_" + tag, std::to_string(r.points));
    ::testing::Test::RecordProperty("sdf_max_distance_diff_" + tag, std::to_string(r.maxDistance));
    ::testing::Test::RecordProperty("sdf_max_density_diff_" + tag, std::to_string(r.maxDensity));
    std::printf("[ rt lookups ] SDF %s: %zu points (%zu in the soft shell): distance %zu "
                "bit-identical, largest difference %.3g; density (scale %g) %zu bit-identical, "
                "largest difference %.3g\n",
                tag.c_str(), r.points, r.inShell, r.identicalDistance, r.maxDistance, double(scale),
                r.identicalDensity, r.maxDensity);
    EXPECT_GT(r.inShell, r.points / 10) << tag << ": too few points in the soft shell";
    EXPECT_LE(r.maxDistance, 1e-5) << tag;
    EXPECT_LE(r.maxDensity, 1e-5 * double(scale)) << tag;
}

} // namespace

// The tree of examples/scenes/sdf_cloud.toml and a tree with every node kind, evaluated in GLSL
// through the kernel sdfTreeStep, against SdfTree::distance and Field::density on the CPU.
TEST(RtSdfLookups, TreesAsTheCpu) {
    if (!requireContext()) return;
    host::Session session;
    ASSERT_TRUE(session.load(kSdfCloud, {kSdfShadowMarch}).ok());
    const SceneDesc& s = session.scene();
    ASSERT_EQ(s.field.kind, FieldKind::Sdf);
    reportSdfLookups("sdf_cloud", sdfLookupsAgainstCpu(s, s.field.sdf), s.field.sdf.density);
    SdfFieldDesc every;
    every.root = everyKindTree();
    every.density = 2.0f;
    every.falloff = 0.4f;
    const SdfTree t = flattenSdf(every.root);
    bool kinds[11] = {};
    for (const SdfNode& n : t.nodes) kinds[int(n.kind)] = true;
    for (int k = 0; k < 11; ++k) EXPECT_TRUE(kinds[k]) << sdfKindName(SdfKind(k));
    reportSdfLookups("every_kind", sdfLookupsAgainstCpu(s, every), every.density);
}

// The shader of an SDF frame has the node buffer and its loop and no cumulus; a cumulus frame's
// has neither.
TEST(RtSdfShader, HasTheTreeOnlyForSdf) {
    host::Session session;
    ASSERT_TRUE(session.load(kSdfCloud, {kSdfShadowMarch}).ok());
    const FramePlan plan = session.plan(1);
    const rt::MarchFeatures f = rt::marchFeatures(session.scene(), plan);
    EXPECT_TRUE(f.sdf && !f.vdb);
    EXPECT_TRUE(contains(f.defines(), "#define RT_SDF 1\n"));
    const std::string text = rt::marchShaderSource(f);
    EXPECT_TRUE(contains(text, "buffer RtSdfNodes { SdfTreeNode rtSdfNode[]; };"));
    host::Session cumulus;
    ASSERT_TRUE(cumulus.load(kDefaultScene, paritySettings(32, 18)).ok());
    const rt::MarchFeatures g = rt::marchFeatures(cumulus.scene(), cumulus.plan(1));
    EXPECT_FALSE(g.sdf);
    EXPECT_TRUE(contains(g.defines(), "#define RT_SDF 0\n"));
    // nimbus rt renders SDF clouds, with shadow marches and with the light-attenuation volume
    // the scene ships with (RT_LIGHT_VOLUME)
    auto keysOf = [](const SceneDesc& sc) {
        std::string keys;
        for (const rt::Unsupported& u : rt::unsupported(sc, planFrame(sc, 1))) keys += u.key + ";";
        return keys;
    };
    EXPECT_EQ(keysOf(session.scene()), "");
    host::Session shipped;
    ASSERT_TRUE(shipped.load(kSdfCloud, {}).ok());
    EXPECT_EQ(keysOf(shipped.scene()), "");
    EXPECT_TRUE(rt::marchFeatures(shipped.scene(), shipped.plan(1)).lightVolume);
}

// sdf_cloud.toml at 96x54 (160x90 until 2026-12-04: the loop budget is per SIMD batch,
// whatever the image's size) with the sun's shadow marched: as it ships otherwise (the diffusion
// grid) and with multiple scattering off (octaves and the sky ambient). Before the march in
// slices (RT_RESUMABLE) llvmpipe 22.3.6 gave 33.61 dB (grid) and 27.09 dB (none): its loop
// budget (65535 loop iterations per SIMD batch, all loops together) ran out in the shadow
// marches and cut them short (docs/realtime.md, "SDF clouds").
TEST(RtSdfParity, SdfCloud) {
    if (!requireContext()) return;
    double maxAbs = 0.0;
    EXPECT_GE(sceneGpuAgainstCpu(kSdfCloud,
                                 {"camera.width=96", "camera.height=54", kSdfShadowMarch,
                                  "render.multiple_scattering=\"grid\"",
                                  "output.aovs=[\"transmittance\", \"depth\"]"},
                                 1, "sdf_cloud", &maxAbs, 5),
              45.0);
    EXPECT_GE(
        sceneGpuAgainstCpu(kSdfCloud,
                           {"camera.width=96", "camera.height=54", kSdfShadowMarch,
                            "render.multiple_scattering=\"none\"",
                            "output.aovs=[\"transmittance\", \"depth\"]"},
                           1, "sdf_cloud_ms_none", &maxAbs, 5),
        45.0); // as the scene ships: the sun through its light-attenuation volume (RT_LIGHT_VOLUME)
    EXPECT_GE(sceneGpuAgainstCpu(kSdfCloud,
                                 {"camera.width=96", "camera.height=54",
                                  "output.aovs=[\"transmittance\", \"depth\"]"},
                                 1, "sdf_cloud_light_volume", &maxAbs, 5),
              45.0);
}

// `nimbus rt` on sdf_cloud.toml writes the EXR `nimbus render` writes, within 45 dB (31.04 dB at
// 64x36 before the march in slices). 500,000 photons: "auto" picks them for this cloud (depth
// 15.4 along the sun), and its default 8 M took 14 of each side's 18 s.
TEST(RtCli, SdfWritesTheSameExrAsRender) {
    TempDir dir("rt_cli_sdf");
    const std::string sets = " --set camera.width=64 --set camera.height=36 --set "
                             "'render.shadow=\"march\"' --set 'output.preview=\"\"' --set "
                             "render.photons=500000";
    const CliParity r = rtAgainstRenderCli(kSdfCloud, 1, dir.string(), sets, sets, "cli_sdf_64x36");
    EXPECT_EQ(r.g.width, 64);
    EXPECT_GE(r.psnr, 45.0);
    const CliRun e = runNimbus("rt " + kSdfCloud + " --frames 1 --explain" + sets);
    EXPECT_EQ(e.exitCode, 0) << e.output;
    EXPECT_TRUE(contains(e.output, "#define RT_SDF 1")) << e.output;
    EXPECT_TRUE(contains(e.output, "GPU field: sdf")) << e.output;
}

// The loop probe (march_data.glsl, rtLoopBudgetHeld, RT_RESUMABLE) after nested loops of
// outer x inner iterations whose trip counts come from a buffer (nothing is unrolled): wherever
// the inner loops did not all run to their end, the probe says so. Mesa llvmpipe ends every
// loop of a shader once one SIMD batch's loops have taken 65535 iterations in all
// (LP_MAX_TGSI_LOOP_ITERATIONS): 300 x 300 is cut short there (90,300 iterations), 100 x 100
// (10,100) is not; a GL without such a budget runs both in full, and the probe holds.
TEST(RtLoopBudget, ProbeSeesLoopsCutShort) {
    if (!requireContext()) return;
    host::Session session;
    ASSERT_TRUE(session.load(kDefaultScene, paritySettings(32, 18)).ok());
    rt::MarchFeatures f = rt::marchFeatures(session.scene(), session.plan(1));
    f.resumable = true;
    rt::RtMarchParams P = rt::marchParams(session.scene(), session.plan(1));
    P.loopProbe = 2;
    for (const int size : {100, 300}) {
        const std::vector<glm::vec4> in(64, glm::vec4(float(size)));
        const std::vector<float> out =
            runLookups(f, P, in, 2,
                       "int outer = int(testIn[i].x), inner = int(testIn[i].y), c = 0;\n"
                       "for (int a = 0; a < outer; a++)\n"
                       "    for (int b = 0; b < inner; b++) c++;\n"
                       "testOut[2u * i] = float(c);\n"
                       "testOut[2u * i + 1u] = rtLoopBudgetHeld() ? 1.0f : 0.0f;");
        ASSERT_EQ(out.size(), 128u);
        int cut = 0, held = 0;
        for (std::size_t i = 0; i < 64; ++i) {
            const bool full = out[2 * i] == float(size * size);
            const bool probeHeld = out[2 * i + 1] == 1.0f;
            // never a loop cut short with the probe holding
            EXPECT_TRUE(full || !probeHeld) << size << " at " << i << ": " << out[2 * i];
            cut += full ? 0 : 1;
            held += probeHeld ? 1 : 0;
        }
        if (size == 100) EXPECT_EQ(held, 64) << "10,100 iterations are within any budget";
        std::printf("[ loop budget ] %d x %d: %d of 64 invocations cut short, probe held in %d\n",
                    size, size, cut, held);
    }
}

// The march in slices (RT_RESUMABLE) gives the image of the whole-ray march: the default scene
// with the sun at 64x36, whole rays in one dispatch and slices of 3 and of 1 camera steps (the
// ray's state carried between dispatches), equal bit for bit, AOVs included.
TEST(RtSlices, SlicedMarchEqualsWholeRays) {
    if (!requireContext()) return;
    host::Session session;
    std::vector<std::string> settings = paritySettings(64, 36);
    settings.push_back("output.aovs=[\"transmittance\", \"depth\"]");
    ASSERT_TRUE(session.load(kDefaultScene, settings).ok());
    const FramePlan plan = session.plan(1);
    auto render = [&](int steps, rt::MarchStats& stats) {
        rt::MarchPass pass;
        pass.setSliceSteps(steps);
        Framebuffer fb;
        std::string error;
        EXPECT_TRUE(pass.render(session.scene(), plan, fb, stats, &error)) << error;
        return fb;
    };
    rt::MarchStats whole, three, one;
    const Framebuffer a = render(rt::MarchPass::kWholeRay, whole);
    const Framebuffer b = render(3, three);
    const Framebuffer c = render(1, one);
    ASSERT_FALSE(a.rgba.empty());
    EXPECT_EQ(three.sliceSteps, 3);
    EXPECT_GT(three.dispatches, 10);
    EXPECT_GT(one.dispatches, three.dispatches);
    EXPECT_EQ(a.rgba, b.rgba);
    EXPECT_EQ(a.rgba, c.rgba);
    ASSERT_FALSE(a.transmittance.empty());
    EXPECT_EQ(a.transmittance, c.transmittance);
    EXPECT_EQ(a.depth, c.depth);
    std::printf("[ slices ] default 64x36: whole rays %d dispatch(es) (%d renders discarded), "
                "slices of 3: %d, of 1: %d\n",
                whole.dispatches, whole.budgetRetries, three.dispatches, one.dispatches);
}

// The SDF cloud skips over its majorant grid too (the grid the CPU builds for the frame: the
// tree's bound per cell); the sun's shadow marched, the march in slices as nimbus rt runs it.
TEST(RtSkip, SdfCloudBitIdentical) {
    if (!requireContext()) return;
    const SkipRun r = skipAgainstNoSkip(
        kSdfCloud,
        {"camera.width=64", "camera.height=36", "render.shadow=\"march\"",
         "render.multiple_scattering=\"none\"", "output.aovs=[\"transmittance\", \"depth\"]"},
        1, "sdf_cloud");
    EXPECT_TRUE(r.skip);
    EXPECT_GT(r.emptyFraction, 0.05);
    EXPECT_GT(r.cloudy, 64u * 36u / 20u);
    EXPECT_EQ(r.differing, 0u);
}
