/// @file rt_march.cpp
/// @brief The GLSL march pass: support check, parameter block, shader assembly, dispatch.
#include "plugin/realtime/rt_march.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>
#include <nanovdb/NanoVDB.h>

#include "core/camera.h"
#include "core/fields/cumulus.h"
#include "core/fields/sdf_cloud.h"
#include "core/integrators/march.h"
#include "core/kernels/source.h"
#include "core/media/medium.h"
#include "core/media/phase.h"
#include "core/media/mie.h"
#include "core/media/sky.h"
#include "core/render.h"
#include "core/tracking/volumes.h"
#include "plugin/realtime/march_params.h"
#include "plugin/realtime/pass_source.h"

namespace nimbus::rt {

// march_data.glsl's RT_GRID_TYPE_FLOAT (PNANOVDB_GRID_TYPE_FLOAT): the grid type the accessor reads
static_assert(int(nanovdb::GridType::Float) == 1);
// the in-scatter and pixel-filter values are checked once, beside their other user
// (core/integrators/march.cpp)

namespace {

const char* fieldKindWord(FieldKind k) {
    switch (k) {
    case FieldKind::Homogeneous:
        return "homogeneous";
    case FieldKind::Cumulus:
        return "cumulus";
    case FieldKind::Vdb:
        return "vdb";
    case FieldKind::Gardner:
        return "gardner";
    case FieldKind::Sdf:
        return "sdf";
    case FieldKind::Automaton:
        return "automaton";
    case FieldKind::Advected:
        return "advected";
    }
    return "?";
}

glm::vec4 v4(vec3 v) {
    return glm::vec4(v.x, v.y, v.z, 0.0f);
}

} // namespace

std::vector<Unsupported> unsupported(const SceneDesc& s, const FramePlan& p) {
    std::vector<Unsupported> out;
    auto no = [&](std::string key, std::string message) {
        out.push_back({std::move(key), std::move(message)});
    };
    if (!p.refusal.empty()) no("render", "the frame plan refuses the frame: " + p.refusal);
    if (p.pathtrace)
        no("render.integrator", "render.integrator = \"pathtrace\": the GLSL pass is march only");
    if (s.field.advect.enabled)
        no("field.advect", "[field.advect]: the GLSL pass does not advect fields yet");
    if (s.field.kind != FieldKind::Cumulus && s.field.kind != FieldKind::Vdb &&
        s.field.kind != FieldKind::Sdf)
        no("field.kind",
           std::string("field.kind = \"") + fieldKindWord(s.field.kind) +
               "\": the GLSL pass renders the procedural cumulus field, VDB grids and SDF "
               "clouds only (Gardner, automaton and homogeneous fields are not ported yet)");
    if (!s.volumes.empty()) no("volume", "[[volume]] entries: the GLSL pass renders `field` alone");
    if (p.instanced || !s.instances.empty())
        no("instance",
           "[[instance]] placements: the GLSL pass renders `field` once, untransformed");
    if (s.ground.enabled) no("ground.enabled", "ground.enabled = true: no surfaces on the GPU yet");
    if (!s.meshes.empty()) no("mesh", "[[mesh]] entries: no surfaces on the GPU yet");
    if (!s.solids.empty()) no("solid", "[[solid]] entries: no SDF solids on the GPU yet");
    if (p.skySingle && !p.skyVolume)
        no("render.sky_shadow",
           std::string(p.photonSky ? "render.photon_sky = true"
                                   : "render.sky_scattering = "
                                     "\"single\"") +
               " with render.sky_shadow = \"march\": the single-scattered sky's shadow marches "
               "are not on the GPU yet; use render.sky_shadow = \"volume\" (the sky volume)");
    if (p.columnVolumes)
        no("render.sky_occlusion", "render.sky_occlusion = \"column\": the column volumes are not "
                                   "uploaded to the GPU yet; use \"height\"");
    if (p.rebased)
        no("camera.position",
           "the field or the camera lies far from the origin and the CPU renders this frame "
           "translated (core/rebase.h); the GLSL pass does not rebase yet");
    return out;
}

bool skipsWith(const FramePlan& p, const MajorantGrid* g) {
    if (!p.skipEmpty || !g || g->cellCount() == 0 || g->res.x <= 0 || g->res.y <= 0 ||
        g->res.z <= 0)
        return false;
    const ivec3 blocks = (g->res + ivec3(MajorantGrid::kBlock - 1)) / MajorantGrid::kBlock;
    return g->blockRes == blocks &&
           g->blockDistance.size() == std::size_t(blocks.x) * blocks.y * blocks.z &&
           g->emptyFraction() > 0.0;
}

std::vector<float> majorantBuffer(const MajorantGrid& g) {
    std::vector<float> out(g.maj);
    out.reserve(g.maj.size() + g.blockDistance.size());
    for (std::uint8_t d : g.blockDistance) out.push_back(float(d));
    return out;
}

MajorantGrid majorantGrid(Renderer& r, const FramePlan& p, const FrameBindings& b) {
    if (!p.skipEmpty) return {};
    RenderStats stats;
    VolumeSet vs = r.volumesFor(p, b, stats);
    if (vs.grids.empty()) return {};
    return std::move(vs.grids[0]);
}

MarchFeatures marchFeatures(const SceneDesc& s, const FramePlan& p, const MajorantGrid* majorant) {
    MarchFeatures f;
    f.sun = p.shadows && p.scatters;
    f.ambient = p.ambient && !p.diffusion && !p.skySingle;
    f.backgroundSky = s.render.background == Background::Sky;
    f.multisample = s.render.pixelSamples > 1;
    // the table is read where the phase function is: the sun's octaves, the sky's directions
    f.skyVolume = p.skyVolume; // (the plan builds the sky volume only for the single sky)
    f.mieTable = (f.sun || f.skyVolume) && s.medium.phase == PhaseKind::MieTable;
    f.diffusion = p.diffusion;
    f.photons = p.photons;
    f.photonSkin = p.photons && s.render.photonSkin > 0.0f;
    f.vdb = s.field.kind == FieldKind::Vdb;
    f.bakedNoise = s.field.kind == FieldKind::Cumulus && p.bakeNoise;
    f.rgbaNoise = f.bakedNoise && s.field.cumulus.eval == NoiseEval::Rgba;
    f.skip = skipsWith(p, majorant);
    f.sdf = s.field.kind == FieldKind::Sdf;
    f.lightVolume = f.sun && p.lightVolume;
    f.gateVolume = f.sun && p.gateVolume;
    f.forwardDelta = f.sun && p.forwardFraction > 0.0f;
    return f;
}

std::string MarchFeatures::defines() const {
    std::string d;
    d += std::string("#define RT_SUN ") + (sun ? "1" : "0") + "\n";
    d += std::string("#define RT_AMBIENT ") + (ambient ? "1" : "0") + "\n";
    d += std::string("#define RT_BACKGROUND_SKY ") + (backgroundSky ? "1" : "0") + "\n";
    d += std::string("#define RT_MULTISAMPLE ") + (multisample ? "1" : "0") + "\n";
    d += std::string("#define RT_MIE_TABLE ") + (mieTable ? "1" : "0") + "\n";
    d += std::string("#define RT_MS_DIFFUSION ") + (diffusion ? "1" : "0") + "\n";
    d += std::string("#define RT_MS_PHOTONS ") + (photons ? "1" : "0") + "\n";
    d += std::string("#define RT_PHOTON_SKIN ") + (photonSkin ? "1" : "0") + "\n";
    d += std::string("#define RT_VDB ") + (vdb ? "1" : "0") + "\n";
    d += std::string("#define RT_BAKED_NOISE ") + (bakedNoise ? "1" : "0") + "\n";
    d += std::string("#define RT_RGBA_NOISE ") + (rgbaNoise ? "1" : "0") + "\n";
    d += std::string("#define RT_SKIP ") + (skip ? "1" : "0") + "\n";
    d += std::string("#define RT_SDF ") + (sdf ? "1" : "0") + "\n";
    d += std::string("#define RT_LIGHT_VOLUME ") + (lightVolume ? "1" : "0") + "\n";
    d += std::string("#define RT_GATE_VOLUME ") + (gateVolume ? "1" : "0") + "\n";
    d += std::string("#define RT_SKY_VOLUME ") + (skyVolume ? "1" : "0") + "\n";
    d += std::string("#define RT_FORWARD_DELTA ") + (forwardDelta ? "1" : "0") + "\n";
    d += std::string("#define RT_RESUMABLE ") + (resumable ? "1" : "0") + "\n";
    return d;
}

std::string marchDataShaderSource(const MarchFeatures& f) {
    // source-string numbers in compiler messages: 1..K the kernels (core/kernels/source.h),
    // K + 1 march_params.glsl, K + 2 march_data.glsl, K + 3 march_pass.glsl
    const std::size_t k = kern::kernelSources().size();
    std::string s = "#version 430\n" + f.defines() + kern::glslLibrary();
    s += "#line 1 " + std::to_string(k + 1) + "\n";
    s += march_paramsSource();
    s += "\n#line 1 " + std::to_string(k + 2) + "\n";
    // PNanoVDB's text (source string K + 4) where march_data.glsl marks it, inside its RT_VDB
    // block: the shader has it only with RT_VDB, after the buffer its functions read
    const std::string_view data = march_dataSource();
    const std::string_view marker = "// @pnanovdb";
    const std::size_t at = data.find(marker);
    if (!f.vdb || at == std::string_view::npos) {
        s += data;
        return s;
    }
    const std::size_t eol = data.find('\n', at);
    const std::size_t line =
        1 + std::size_t(std::count(data.begin(), data.begin() + long(at), '\n'));
    s += data.substr(0, eol + 1);
    s += "#line 1 " + std::to_string(k + 4) + "\n";
    s += pnanovdbSource();
    s += "#line " + std::to_string(line + 1) + " " + std::to_string(k + 2) + "\n";
    s += data.substr(eol + 1);
    return s;
}

std::string marchShaderSource(const MarchFeatures& f) {
    std::string s = marchDataShaderSource(f);
    s += "\n#line 1 " + std::to_string(kern::kernelSources().size() + 3) + "\n";
    s += march_passSource();
    return s;
}

MarchShader marchShader(const SceneDesc& s, const FramePlan& p, const MajorantGrid* majorant) {
    MarchShader m;
    m.features = marchFeatures(s, p, majorant);
    m.source = marchShaderSource(m.features);
    return m;
}

std::vector<kern::SdfTreeNode> sdfTreeNodes(const SceneDesc& s) {
    if (s.field.kind != FieldKind::Sdf) return {};
    return flattenSdf(s.field.sdf.root).gpuNodes;
}

std::vector<glm::vec4> mieTableNodes(const MieTable& t) {
    const std::vector<float>& cos = t.cosines();
    std::vector<glm::vec4> nodes(cos.size());
    for (std::size_t i = 0; i < cos.size(); ++i)
        nodes[i] = glm::vec4(cos[i], t.values(0)[i], t.values(1)[i], t.values(2)[i]);
    return nodes;
}

VdbGridBytes vdbGridBytes(const FrameBindings* bindings, std::string* error) {
    const GridBinding* b = bindings ? &bindings->grid(0) : nullptr;
    const auto* g = b ? static_cast<const nanovdb::FloatGrid*>(b->grid) : nullptr;
    if (!g) {
        if (error)
            *error = "the field's VDB grid was not loaded for the frame (no density to upload)";
        return {};
    }
    if (b->shift != glm::dvec3(0.0)) {
        if (error)
            *error =
                "the field's VDB grid is rendered shifted (core/rebase.h); the GLSL pass reads "
                "the grid's own map";
        return {};
    }
    // PNanoVDB's GLSL addresses are 32-bit byte offsets
    if (g->gridSize() >= (std::uint64_t(1) << 32)) {
        if (error)
            *error = "the field's VDB grid has " + std::to_string(g->gridSize()) +
                     " bytes, more than PNanoVDB's 32-bit GLSL addresses reach";
        return {};
    }
    return {g, std::size_t(g->gridSize())};
}

RtMarchParams marchParams(const SceneDesc& s, const FramePlan& p, const MarchGrids* grids,
                          const FrameBindings* bindings, const MajorantGrid* majorant) {
    RtMarchParams P{};
    const Camera cam(s.camera);
    P.camOrigin = v4(cam.origin);
    P.camForward = v4(cam.forward);
    P.camRight = v4(cam.right);
    P.camUp = v4(cam.up);
    P.tanHalfY = cam.tanHalfY;
    P.aspect = cam.aspect;
    P.width = cam.width;
    P.height = cam.height;

    const CumulusDesc& c = s.field.cumulus;
    P.boundsLo = v4(c.bounds.lo);
    P.boundsHi = v4(c.bounds.hi);
    const kern::CumulusParams C = cumulusParams(c, p.time);
    P.layerBottom = C.layer.bottom;
    P.layerTop = C.layer.top;
    P.heightA = C.layer.heightA;
    P.heightB = C.layer.heightB;
    P.coverage = C.layer.coverage;
    P.softness = C.layer.softness;
    P.erosion = C.layer.erosion;
    P.towerSpacing = C.layer.towerSpacing;
    P.towerRadiusMin = C.layer.towerRadiusMin;
    P.towerRadiusMax = C.layer.towerRadiusMax;
    P.towerHeightMin = C.layer.towerHeightMin;
    P.towerHeightMax = C.layer.towerHeightMax;
    P.towerProbability = C.layer.towerProbability;
    P.towerAnisotropy = C.layer.towerAnisotropy;
    P.fieldSeed = C.layer.seed;
    P.fieldDensity = C.density;
    P.basePeriod = C.basePeriod;
    P.baseLattice = C.baseLattice;
    P.baseOctaves = C.baseOctaves;
    P.detailPeriod = C.detailPeriod;
    P.detailLattice = C.detailLattice;
    P.detailOctaves = C.detailOctaves;
    P.baseOffset = v4(C.baseOffset);
    P.detailOffset = v4(C.detailOffset);
    if (s.field.kind == FieldKind::Vdb) {
        // the field's box on the CPU (makeField: the grid binding's bounds) and its scale
        const Box b = bindings ? bindings->grid(0).bounds : Box{};
        P.boundsLo = v4(b.lo);
        P.boundsHi = v4(b.hi);
        P.vdbDensity = s.field.vdb.density;
    }
    if (s.field.kind == FieldKind::Cumulus && p.bakeNoise) {
        // the tiles' nodes per axis (bakeCumulusBase / bakeCumulusDetail bake at these)
        P.baseBakeRes = c.baseBakeResolution;
        P.detailBakeRes = c.detailBakeResolution;
    }
    if (s.field.kind == FieldKind::Sdf) {
        // the field's box on the CPU (makeSdfCloudField: the tree's support, grown by the
        // margin), its density scale and falloff; the nodes go to their own buffer
        const Box b = sdfCloudBounds(s.field.sdf);
        P.boundsLo = v4(b.lo);
        P.boundsHi = v4(b.hi);
        P.sdfScale = s.field.sdf.density;
        P.sdfFalloff = s.field.sdf.falloff;
        P.sdfNodeCount = int(sdfTreeNodes(s).size());
    }

    P.sunDirection = v4(s.sun.direction);
    P.sunIrradiance = v4(s.sun.irradiance);
    const Medium m = Medium::fromDesc(s.medium);
    P.sigmaS = v4(m.sigma_s);
    P.sigmaT = v4(m.sigma_t);
    P.sigmaTr = v4(m.sigma_tr);
    P.mediumG = m.g;
    P.msP1 = s.render.msP1;
    const MieTable* table = m.phase.table();
    P.mieNodes = table ? int(table->cosines().size()) : 0;
    const kern::PhaseParams ph = phaseParams(s.medium, table);
    P.phaseKind = ph.kind;
    P.phaseG = ph.g;
    P.phaseG2 = ph.g2;
    P.phaseBlend = ph.blend;
    P.phaseAlpha = ph.alpha;
    P.phaseDiameter = ph.diameter;

    P.skyKind = int(s.sky.kind);
    P.skyZenith = v4(s.sky.zenith);
    P.skyHorizon = v4(s.sky.horizon);
    P.skySphere = v4(skyMeans(s.sky).sphere);
    P.ambientGround = MarchContext::kAmbientGround;

    const RenderDesc& r = s.render;
    P.frameKey = kern::pcg(frameSeedKey(s, p) ^ kern::pcg(r.seed));
    P.jitter = r.jitter ? 1 : 0;
    P.epsilon = r.epsilon;
    P.step = p.step;
    P.stepGrowth = r.stepGrowth;
    P.shadowStep = p.shadowStep;
    P.shadowGrowth = r.shadowGrowth;
    P.stepTau = p.stepTau;
    P.octaves = r.octaves;
    P.octaveContribution = r.octaveContribution;
    P.octaveExtinction = r.octaveExtinction;
    P.octaveEccentricity = r.octaveEccentricity;
    P.octaveGate = r.octaveGate;
    P.inScatter = int(p.inScatter);
    P.inScatterC = r.inScatterC;
    P.inScatterStrength = r.inScatterStrength;
    P.pixelSamples = std::max(1, r.pixelSamples);
    P.filterKind = int(r.filter);
    P.filterWidth = r.filterWidth;
    if (skipsWith(p, majorant)) {
        P.majorantLo = v4(majorant->bounds.lo);
        P.majorantCell = v4(majorant->cellSize);
        P.majorantResX = majorant->res.x;
        P.majorantResY = majorant->res.y;
        P.majorantResZ = majorant->res.z;
    }
    if (const LightVolume* lv = grids ? grids->towardVolume() : nullptr;
        lv && (p.lightVolume || p.gateVolume)) {
        P.lightLo = v4(lv->bounds.lo);
        P.lightHi = v4(lv->bounds.hi);
        P.lightVoxel = v4(lv->voxel);
        P.lightResX = lv->res.x;
        P.lightResY = lv->res.y;
        P.lightResZ = lv->res.z;
    }
    if (grids && grids->hasSky && p.skyVolume) {
        const SkyVolume& g = grids->sky;
        P.skyVolumeLo = v4(g.bounds.lo);
        P.skyVolumeVoxel = v4(g.voxel);
        P.skyVolumeResX = g.res.x;
        P.skyVolumeResY = g.res.y;
        P.skyVolumeResZ = g.res.z;
        P.skyDirections = g.count();
    }
    if (grids && grids->hasDiffusion) {
        const DiffusionVolume& g = grids->diffusion;
        P.diffusionLo = v4(g.bounds.lo);
        P.diffusionVoxel = v4(g.voxel);
        P.diffusionResX = g.res.x;
        P.diffusionResY = g.res.y;
        P.diffusionResZ = g.res.z;
    }
    if (grids && grids->hasPhotons) {
        const PhotonVolume& g = grids->photons;
        P.photonLo = v4(g.bounds.lo);
        P.photonVoxel = v4(g.voxel);
        P.photonResX = g.res.x;
        P.photonResY = g.res.y;
        P.photonResZ = g.res.z;
        if (g.sunTau && g.skinK > 0.0f) {
            P.skinLo = v4(g.sunTau->bounds.lo);
            P.skinVoxel = v4(g.sunTau->voxel);
            P.skinResX = g.sunTau->res.x;
            P.skinResY = g.sunTau->res.y;
            P.skinResZ = g.sunTau->res.z;
            P.skinK = g.skinK;
            P.skinFloor = g.skinFloor;
        }
    }
    return P;
}

std::string explainMarch(const SceneDesc& s, const FramePlan& p, const MajorantGrid* majorant) {
    std::ostringstream o;
    const std::vector<Unsupported> no = unsupported(s, p);
    if (!no.empty()) {
        for (const Unsupported& u : no) o << "  GPU: not supported: " << u.message << "\n";
        return o.str();
    }
    MarchFeatures f = marchFeatures(s, p, majorant);
    f.resumable = true; // as MarchPass compiles it
    std::string defs = f.defines();
    for (char& ch : defs)
        if (ch == '\n') ch = ';';
    o << "  GPU shader: #version 430, " << defs << " the kernels";
    for (const kern::KernelSource& k : kern::kernelSources()) o << " " << k.name;
    o << ", plugin/realtime/march_params.glsl, march_data.glsl"
      << (f.vdb ? " (with PNanoVDB.h)" : "") << ", march_pass.glsl\n";
    if (f.sdf)
        o << "  GPU field: sdf, " << sdfTreeNodes(s).size()
          << " tree nodes in a storage buffer evaluated by the kernel sdfTreeStep as "
             "SdfTree::distance, density "
          << s.field.sdf.density << ", falloff " << s.field.sdf.falloff
          << " (every step of the box taken: no sphere tracing on the GPU)\n";
    else if (f.vdb)
        o << "  GPU field: vdb, the NanoVDB float grid in a storage buffer read through "
             "PNanoVDB, trilinear as on the CPU, density scale "
          << s.field.vdb.density << "\n";
    else if (f.rgbaNoise)
        o << "  GPU field: cumulus, noise read from the RGBA8 tiles the CPU baked in Olajos' "
             "channel layout (as the CPU plan; "
          << s.field.cumulus.baseBakeResolution << "^3 base, "
          << s.field.cumulus.detailBakeResolution
          << "^3 detail, 3D textures filtered by the texture unit, the channels combined after "
             "the filter)\n";
    else if (f.bakedNoise)
        o << "  GPU field: cumulus, noise read from the tiles the CPU baked (as the CPU plan; "
          << s.field.cumulus.baseBakeResolution << "^3 base, "
          << s.field.cumulus.detailBakeResolution
          << "^3 detail, storage buffers, trilinear as NoiseVolume::sample)\n";
    else
        o << "  GPU field: cumulus, noise evaluated per sample (as the CPU plan), noise octaves "
          << s.field.cumulus.baseOctaves << " (base) / " << s.field.cumulus.detailOctaves
          << " (detail)\n";
    o << "  GPU march: steps " << p.step << " (growth " << s.render.stepGrowth << "), shadow "
      << p.shadowStep << " (growth " << s.render.shadowGrowth << "); ";
    if (f.skip)
        o << "empty-space skipping over the CPU's majorant grid (" << majorant->res.x << "x"
          << majorant->res.y << "x" << majorant->res.z << " cells of " << majorant->cellSize.x
          << ", " << int(std::lround(100.0 * majorant->emptyFraction()))
          << "% empty; a storage buffer): samples in empty cells are not evaluated\n";
    else if (p.skipEmpty && !majorant)
        o << "empty-space skipping decided when the frame is rendered (RT_SKIP: on when the "
             "frame's majorant grid, built then, has an empty cell)\n";
    else
        o << "no empty-space skipping (every step in the field's box: "
          << (p.skipEmpty ? "the majorant grid has no empty cell" : "render.skip_empty = false")
          << ")\n";
    o << "  GPU lighting: "
      << (f.lightVolume ? "sun through the light-attenuation volume (computed on the CPU at voxel "
          : f.sun       ? "sun by a shadow march per sample, "
                        : "no sun, ");
    if (f.lightVolume)
        o << p.lightVolumeCell << ", read from a buffer; a shadow march outside it), ";
    o << (f.photons ? 1 : s.render.octaves) << " octave(s)"
      << (f.gateVolume ? " (gated by the density along the sun's line, read from the CPU's "
                         "sun-depth volume)"
                       : "")
      << ", phase kind " << phaseParams(s.medium).kind
      << (f.mieTable ? " (the Lorenz-Mie table, a buffer)" : "")
      << (f.ambient ? ", sky ambient (height occlusion)" : ", no sky ambient")
      << (f.backgroundSky ? ", sky background" : ", transparent background")
      << "; multiple-scattering grids: "
      << (f.diffusion && f.photons
              ? (p.photonBounces > 0
                     ? "photons (the sun's first " + std::to_string(p.photonBounces) +
                           " scatterings) and diffusion (the higher orders, the sky)"
                     : std::string("photons (sun) and diffusion (sky)"))
          : f.diffusion ? std::string("diffusion")
          : f.photons   ? std::string("photons")
                        : std::string("none"))
      << (f.photonSkin ? ", the photons' skin profile" : "")
      << (f.diffusion || f.photons ? " (computed on the CPU, read from buffers)" : "") << "\n";
    o << "  GPU pixels: " << s.render.pixelSamples << " sample(s) per pixel\n";
    return o.str();
}

BakedNoise bakedNoise(Renderer& r, const FramePlan& p, const FrameBindings& b) {
    BakedNoise n;
    if (r.scene().field.kind != FieldKind::Cumulus || !p.bakeNoise) return n;
    const Field field = r.fieldFor(p, b);
    if (field.kind != FieldKind::Cumulus) return n;
    n.base = field.as<CumulusField>().baseBake;
    n.detail = field.as<CumulusField>().detailBake;
    return n;
}

std::uint32_t accumulationKey(std::uint32_t frameKey, int pass) {
    if (pass <= 0) return frameKey;
    // a salt of its own: the pixel-sample keys hash pcg(k + 1) into the pixel's key
    return kern::pcg(frameKey ^ kern::pcg(std::uint32_t(pass) ^ 0x68e31da4u));
}

MarchPass::MarchPass() = default;
MarchPass::~MarchPass() = default;

bool MarchPass::render(const SceneDesc& s, const FramePlan& p, Framebuffer& fb, MarchStats& stats,
                       std::string* error) {
    return render(s, p, nullptr, fb, stats, error);
}

bool MarchPass::render(const SceneDesc& s, const FramePlan& p, const MarchGrids* grids,
                       Framebuffer& fb, MarchStats& stats, std::string* error) {
    return render(s, p, grids, nullptr, fb, stats, error);
}

bool MarchPass::render(const SceneDesc& s, const FramePlan& p, const MarchGrids* grids,
                       const FrameBindings* bindings, Framebuffer& fb, MarchStats& stats,
                       std::string* error) {
    return render(s, p, grids, bindings, nullptr, fb, stats, error);
}

std::string bakedNoiseError(const SceneDesc& s, const BakedNoise* noise) {
    const CumulusDesc& c = s.field.cumulus;
    if (!noise || !noise->base || !noise->detail)
        return "the frame plan bakes the cumulus noise and its tiles were not given to the GLSL "
               "pass (rt::bakedNoise: Renderer::fieldFor's)";
    if (noise->base->res != c.baseBakeResolution || noise->detail->res != c.detailBakeResolution)
        return "the baked noise tiles given to the GLSL pass are not at the scene's "
               "field.base_bake_resolution / detail_bake_resolution";
    const bool rgba = c.eval == NoiseEval::Rgba;
    if (noise->base->channels() != rgba || noise->detail->channels() != rgba)
        return rgba ? "field.evaluation = \"rgba\" and the noise tiles given to the GLSL pass "
                      "are float tiles, not RGBA8"
                    : "the noise tiles given to the GLSL pass are RGBA8 tiles and "
                      "field.evaluation is not \"rgba\"";
    return "";
}

std::vector<float> skyVolumeBuffer(const SceneDesc& s, const SkyVolume& sky) {
    const std::size_t K = sky.directions.size();
    std::vector<float> out(8 * K + sky.tau.size(), 0.0f);
    for (std::size_t k = 0; k < K; ++k) {
        // the volume's own directions, with the radiance MarchContext's constructor gives them
        const vec3 w = sky.directions[k];
        const vec3 L = skyRadiance(s.sky, w) * s.sky.ambient;
        float* r = out.data() + 8 * k;
        r[0] = w.x, r[1] = w.y, r[2] = w.z;
        r[4] = L.x, r[5] = L.y, r[6] = L.z;
    }
    std::copy(sky.tau.begin(), sky.tau.end(), out.begin() + std::ptrdiff_t(8 * K));
    return out;
}

std::string frameDataError(const SceneDesc& s, const FramePlan& p, const MarchGrids* grids,
                           const BakedNoise* noise, const std::string& consumer) {
    const MarchFeatures f = marchFeatures(s, p);
    if ((f.diffusion && !(grids && grids->hasDiffusion)) ||
        (f.photons && !(grids && grids->hasPhotons)) ||
        (f.photonSkin && !(grids && grids->photons.sunTau && grids->photons.skinK > 0.0f)))
        return "the frame's multiple-scattering grid was not given to " + consumer +
               " (build it with Renderer::marchGrids)";
    if (f.skyVolume && !(grids && grids->hasSky && grids->sky.count() > 0))
        return "the frame's sky volume (render.sky_shadow = \"volume\") was not given to " +
               consumer + " (build it with Renderer::marchGrids)";
    if (f.lightVolume && !(grids && grids->towardVolume()))
        return "the frame's light-attenuation volume (render.shadow = \"volume\") was not given "
               "to " +
               consumer + " (build it with Renderer::marchGrids)";
    if (f.gateVolume && !(grids && grids->towardVolume()))
        return "the frame's sun-depth volume (the octave gate's line integral) was not given to " +
               consumer + " (build it with Renderer::marchGrids)";
    return f.bakedNoise ? bakedNoiseError(s, noise) : "";
}

bool MarchPass::render(const SceneDesc& s, const FramePlan& p, const MarchGrids* grids,
                       const FrameBindings* bindings, const BakedNoise* noise, Framebuffer& fb,
                       MarchStats& stats, std::string* error) {
    return render(s, p, grids, bindings, noise, nullptr, fb, stats, error);
}

bool MarchPass::render(const SceneDesc& s, const FramePlan& p, const MarchGrids* grids,
                       const FrameBindings* bindings, const BakedNoise* noise,
                       const MajorantGrid* majorant, Framebuffer& fb, MarchStats& stats,
                       std::string* error) {
    using Clock = std::chrono::steady_clock;
    const std::vector<Unsupported> no = unsupported(s, p);
    if (!no.empty()) {
        if (error) *error = no.front().message;
        return false;
    }
    MarchFeatures f = marchFeatures(s, p, majorant);
    f.resumable = true; // the march in slices, checked against llvmpipe's loop budget
    if (const std::string e = frameDataError(s, p, grids, noise, "the GLSL pass"); !e.empty()) {
        if (error) *error = e;
        return false;
    }
    VdbGridBytes vdb;
    if (f.vdb) {
        vdb = vdbGridBytes(bindings, error);
        if (!vdb.data) return false;
        GLint64 maxBlock = 0;
        glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &maxBlock);
        if (std::uint64_t(maxBlock) < vdb.size) {
            if (error)
                *error = "the field's VDB grid (" + std::to_string(vdb.size) +
                         " bytes) is larger than this GL's largest shader storage block (" +
                         std::to_string(maxBlock) + " bytes)";
            return false;
        }
    }
    std::unique_ptr<gl::ComputeProgram>& program = programs_[f.key()];
    stats.compileSeconds = 0.0;
    if (!program) {
        const auto t0 = Clock::now();
        program = std::make_unique<gl::ComputeProgram>(marchShaderSource(f));
        stats.compileSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
    }
    if (!program->valid()) {
        if (error) *error = "the march shader does not compile: " + program->log();
        programs_.erase(f.key());
        return false;
    }
    const int w = s.camera.width, h = s.camera.height;
    const std::size_t n = std::size_t(w) * std::size_t(h);
    fb.resize(w, h, p.aovs);
    gl::glErrors(); // drop stale errors
    const auto t0 = Clock::now();
    RtMarchParams P = marchParams(s, p, grids, bindings, majorant);
    P.loopProbe = 2;
    // the Lorenz-Mie table: per node (cos theta, R, G, B), as MieTable holds it
    std::unique_ptr<gl::StorageBuffer> mie, diffusion, photons, skin, grid, baseNoise, detailNoise,
        sdfNodes, bounds, light, sky;
    std::unique_ptr<gl::Texture3D> baseChannels, detailChannels;
    // the majorant grid the CPU renders with: a density bound per cell, then the block distances
    // (RT_SKIP)
    if (f.skip) {
        const std::vector<float> maj = majorantBuffer(*majorant);
        bounds = std::make_unique<gl::StorageBuffer>(maj.size() * sizeof(float), maj.data());
        bounds->bind(13);
    }
    // the cumulus noise tiles the CPU baked, their floats as NoiseVolume holds them
    if (f.rgbaNoise) {
        // Olajos' layout: RGBA8 3D textures, the texture unit filters (units 4 and 5)
        baseChannels = std::make_unique<gl::Texture3D>(noise->base->res, noise->base->rgba.data());
        detailChannels =
            std::make_unique<gl::Texture3D>(noise->detail->res, noise->detail->rgba.data());
        baseChannels->bind(4);
        detailChannels->bind(5);
    } else if (f.bakedNoise) {
        const std::vector<float>& b = noise->base->values;
        const std::vector<float>& d = noise->detail->values;
        baseNoise = std::make_unique<gl::StorageBuffer>(b.size() * sizeof(float), b.data());
        detailNoise = std::make_unique<gl::StorageBuffer>(d.size() * sizeof(float), d.data());
        baseNoise->bind(10);
        detailNoise->bind(11);
    }
    // the SDF cloud's tree: its nodes as SdfTree::evaluate walks them (SdfTreeNode, std430)
    if (f.sdf) {
        const std::vector<kern::SdfTreeNode> nodes = sdfTreeNodes(s);
        sdfNodes = std::make_unique<gl::StorageBuffer>(nodes.size() * sizeof(kern::SdfTreeNode),
                                                       nodes.data());
        sdfNodes->bind(12);
    }
    // the field's NanoVDB grid, its bytes as the CPU samples them (PNanoVDB reads address 0 on)
    if (f.vdb) {
        grid = std::make_unique<gl::StorageBuffer>(vdb.size, vdb.data);
        grid->bind(9);
    }
    if (f.mieTable) {
        const Medium m = Medium::fromDesc(s.medium);
        const std::vector<glm::vec4> nodes = mieTableNodes(*m.phase.table());
        mie = std::make_unique<gl::StorageBuffer>(nodes.size() * sizeof(glm::vec4), nodes.data());
        mie->bind(3);
    }
    // the multiple-scattering grids the CPU computed, RGB per voxel (vec3 is 3 packed floats)
    static_assert(sizeof(vec3) == 3 * sizeof(float));
    if (f.diffusion) {
        const std::vector<vec3>& phi = grids->diffusion.phi;
        diffusion = std::make_unique<gl::StorageBuffer>(phi.size() * sizeof(vec3), phi.data());
        diffusion->bind(4);
    }
    if (f.photons) {
        const std::vector<vec3>& L = grids->photons.radiance;
        photons = std::make_unique<gl::StorageBuffer>(L.size() * sizeof(vec3), L.data());
        photons->bind(5);
    }
    // the sun's light-attenuation volume: the density integral toward the sun per voxel (for
    // the sun's transmittance, the octave gate's line integral or both)
    if (f.lightVolume || f.gateVolume) {
        const std::vector<float>& tau = grids->towardVolume()->tau;
        light = std::make_unique<gl::StorageBuffer>(tau.size() * sizeof(float), tau.data());
        light->bind(15);
    }
    // the single-scattered sky: its directions and radiances, then the sky volume
    if (f.skyVolume) {
        const std::vector<float> b = skyVolumeBuffer(s, grids->sky);
        sky = std::make_unique<gl::StorageBuffer>(b.size() * sizeof(float), b.data());
        sky->bind(7);
    }
    if (f.photonSkin) {
        const std::vector<float>& tau = grids->photons.sunTau->tau;
        skin = std::make_unique<gl::StorageBuffer>(tau.size() * sizeof(float), tau.data());
        skin->bind(6);
    }
    // one pass per pixel sample (march_pass.glsl, main), all of them once per accumulation
    // pass with that pass's frame key; the pass adds to the sums, the resolve below divides.
    // Each pass is dispatched slice by slice until no ray is left marching; a render whose loop
    // budget ran out is discarded and done again in shorter slices (setSliceSteps).
    const int passes = f.multisample ? P.pixelSamples : 1;
    const auto tUploaded = Clock::now();
    const std::uint32_t frameKey = P.frameKey;
    stats.dispatches = 0;
    stats.budgetRetries = 0;
    stats.gpuSeconds = 0.0;
    // the dispatches' time on the GPU's clock: a GL_TIMESTAMP before and after each
    struct Queries {
        GLuint id[2] = {0, 0};
        Queries() { glGenQueries(2, id); }
        ~Queries() { glDeleteQueries(2, id); }
    } stamps;
    for (;;) {
        // zeros: the pixels' sums (12 floats a pixel), the non-finite counter, the rays' state
        // between slices (RtSlices: 4 counters, then 64 bytes per pixel)
        const auto zeros = [](std::unique_ptr<gl::StorageBuffer>& b, std::size_t bytes) {
            if (b && b->size() == bytes)
                b->clear();
            else
                b = std::make_unique<gl::StorageBuffer>(bytes);
        };
        zeros(pixels_, n * 12 * sizeof(float));
        zeros(counters_, sizeof(std::uint32_t));
        zeros(slices_, 16 + n * 64);
        gl::StorageBuffer& pixels = *pixels_;
        gl::StorageBuffer& slices = *slices_;
        pixels.bind(1);
        counters_->bind(2);
        slices.bind(14);
        P.sliceSteps = sliceSteps_;
        std::uint32_t sliced[2] = {0, 0}; // unfinished, loopBudgetSpent (summed over dispatches)
        for (int a = 0; a < accumulate_ && sliced[1] == 0; ++a) {
            P.frameKey = accumulationKey(frameKey, a);
            for (int k = 0; k < passes && sliced[1] == 0; ++k) {
                P.sampleIndex = k;
                for (int slice = 0;; ++slice) {
                    P.sliceIndex = slice;
                    const gl::StorageBuffer params(sizeof P, &P);
                    params.bind(0);
                    const std::uint32_t before = sliced[0];
                    glQueryCounter(stamps.id[0], GL_TIMESTAMP);
                    program->dispatch(unsigned((w + 7) / 8), unsigned((h + 7) / 8));
                    glQueryCounter(stamps.id[1], GL_TIMESTAMP);
                    ++stats.dispatches;
                    slices.read(sliced, sizeof sliced);
                    GLuint64 t[2] = {0, 0};
                    glGetQueryObjectui64v(stamps.id[0], GL_QUERY_RESULT, &t[0]);
                    glGetQueryObjectui64v(stamps.id[1], GL_QUERY_RESULT, &t[1]);
                    stats.gpuSeconds += 1e-9 * double(t[1] - t[0]);
                    if (sliced[1] != 0 || sliced[0] == before) break;
                }
            }
        }
        if (sliced[1] == 0) break;
        if (sliceSteps_ == 1) {
            if (error)
                *error = "the march pass runs out of the GL's loop budget (Mesa llvmpipe: 65535 "
                         "loop iterations per batch of invocations) within one camera step of a "
                         "ray: the shadow march over the field is too long for this GL (thick "
                         "steps split "
                         "into sub-steps count too: raise render.step_tau, or "
                         "render.photon_step_tau where photons carry the light)";
            return false;
        }
        ++stats.budgetRetries;
        sliceSteps_ = sliceSteps_ > 64 ? 64 : std::max(1, sliceSteps_ / 4);
    }
    stats.sliceSteps = sliceSteps_;
    const auto tMarched = Clock::now();
    std::vector<float> out(n * 12);
    pixels_->read(out.data(), out.size() * sizeof(float));
    std::uint32_t bad = 0;
    counters_->read(&bad, sizeof bad);
    const auto tRead = Clock::now();
    stats.uploadSeconds = std::chrono::duration<double>(tUploaded - t0).count();
    stats.marchSeconds = std::chrono::duration<double>(tMarched - tUploaded).count();
    stats.readSeconds = std::chrono::duration<double>(tRead - tMarched).count();
    stats.frameSeconds = std::chrono::duration<double>(tRead - t0).count();
    const std::string e = gl::glErrors();
    if (!e.empty()) {
        if (error) *error = "GL error during the march pass: " + e;
        return false;
    }
    // the weighted sums to pixels, as MarchContext::renderPixel finishes a pixel
    stats.nonFinite = bad;
    // one sample of weight 1 per pixel (no RT_MULTISAMPLE, no accumulation) is taken as it is
    const bool divide = f.multisample || accumulate_ > 1;
    for (std::size_t i = 0; i < n; ++i) {
        const float* q = &out[12 * i];
        float rgba[4] = {q[0], q[1], q[2], q[3]};
        float T[3] = {q[4], q[5], q[6]};
        const float wSum = q[7];
        if (wSum > 0.0f && divide) {
            for (float& v : rgba) v /= wSum;
            for (float& v : T) v /= wSum;
        }
        const float depth = q[9] > 0.0f ? (divide ? q[8] / q[9] : q[8]) : 0.0f;
        if (!(std::isfinite(rgba[0]) && std::isfinite(rgba[1]) && std::isfinite(rgba[2]) &&
              std::isfinite(rgba[3]))) {
            ++stats.nonFinite;
            for (float& v : rgba) v = 0.0f;
        }
        for (int c = 0; c < 4; ++c) fb.rgba[4 * i + std::size_t(c)] = rgba[c];
        if (fb.aovs.transmittance)
            for (int c = 0; c < 3; ++c) fb.transmittance[3 * i + std::size_t(c)] = T[c];
        if (fb.aovs.depth) fb.depth[i] = depth;
    }
    return true;
}

} // namespace nimbus::rt
