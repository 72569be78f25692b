/// @file scene.h
/// @brief Plain description of a scene: what the scene file says, validated, in world units.
///
/// Nothing here knows about files: plugin/io/scene/ fills these structs from TOML and
/// checks ranges; core/ only reads them. Colours are already in the working space (ACEScg by
/// default) when they arrive here.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/accel.h"
#include "core/geometry.h"
#include "core/sdf/sdf.h"
#include "core/sdf/solid.h"

namespace nimbus {

struct CameraDesc {
    vec3 position{0.0f, 1.0f, -5.0f};
    vec3 lookAt{0.0f, 1.0f, 0.0f};
    vec3 up{0.0f, 1.0f, 0.0f};
    float fovY = 45.0f; ///< vertical field of view, degrees
    int width = 640;
    int height = 360;
};

struct SunDesc {
    bool enabled = true;
    vec3 direction{0.0f, 1.0f, 0.0f}; ///< unit vector pointing TOWARD the sun
    vec3 irradiance{1.0f};            ///< RGB, working space
    /// Angular diameter of the sun's disc in degrees (0: a point). Only pathtrace samples the
    /// disc (exact penumbrae); march and the precomputed volumes use its centre.
    float angularDiameter = 0.0f;
};

enum class SkyKind { None, Uniform, Gradient };

struct SkyDesc {
    SkyKind kind = SkyKind::Gradient;
    vec3 zenith{0.3f, 0.5f, 0.9f};   ///< radiance straight up (uniform sky: everywhere)
    vec3 horizon{0.8f, 0.85f, 0.9f}; ///< radiance at the horizon and below
    float ambient = 1.0f;            ///< scale of the sky term inside the medium
};

/// Phase functions (core/media/phase.h); values = PHASE_* in core/kernels/phase.glsl.
enum class PhaseKind {
    Isotropic = 0,
    HenyeyGreenstein = 1,
    DualHG = 2,    ///< (1 - blend) HG(g) + blend HG(g2)
    Draine = 3,    ///< Draine(g, alpha)
    MieApprox = 4, ///< Jendersie & d'Eon 2023 fit by droplet diameter (5-50 um)
    MieTable = 5   ///< Lorenz-Mie table from a droplet size distribution (core/media/mie.h)
};

class MieTable;

struct MediumDesc {
    vec3 sigma_s{1.0f}; ///< scattering coefficient per unit density (RGB, 1/unit length)
    vec3 sigma_a{0.0f}; ///< absorption coefficient per unit density
    float densityScale = 1.0f;
    PhaseKind phase = PhaseKind::HenyeyGreenstein;
    float g = 0.8f;                 ///< HG asymmetry; first lobe of dual_hg; g of draine
    float g2 = -0.3f;               ///< dual_hg: second lobe
    float blend = 0.2f;             ///< dual_hg: weight of the second lobe
    float alpha = 1.0f;             ///< draine: alpha (0 = HG; g = 0, alpha = 1: Rayleigh)
    float dropletDiameter = 20.0f;  ///< mie_approx: droplet diameter, micrometres, [5, 50]
    float effectiveRadius = 10.0f;  ///< mie_table: effective droplet radius, micrometres
    float effectiveVariance = 0.1f; ///< mie_table: effective variance of the radii
    /// mie_table: the table, if the caller has it already (plan, cache); when null, core
    /// computes it on first use (sharedMieTable in core/media/mie.h) and keeps it for the process.
    std::shared_ptr<const MieTable> mieTable;
};

/// The kinds of field a scene names; Advected is what any of them becomes in a frame when
/// [field.advect] carries it (never a scene file's `kind`).
enum class FieldKind { Homogeneous, Cumulus, Vdb, Gardner, Sdf, Automaton, Advected };
/// How the cumulus noise is evaluated: chosen by the plan, per sample, from baked float tiles
/// (each noise's octaves summed per node), or from baked RGBA8 tiles in Olajos' channel layout
/// (several frequencies per node, combined after interpolation: kern::cumulusBaseChannels).
enum class NoiseEval { Auto, Direct, Baked, Rgba };

/// A box of constant density (tests, fog layers).
struct HomogeneousDesc {
    Box box{vec3(-1.0f), vec3(1.0f)};
    float density = 1.0f;
};

/// Procedural cumulus layer (Olajos 2016, ch. 2), see core/kernels/cloud.glsl.
struct CumulusDesc {
    Box bounds{vec3(-20.0f, 1.5f, -20.0f), vec3(20.0f, 4.5f, 20.0f)}; ///< y range = altitude range
    float density = 1.0f;
    float coverage = 0.85f;
    float softness = 0.25f;
    float erosion = 0.3f;
    float heightA = 50.0f;
    float heightB = 0.5f;
    float basePeriod = 12.0f; ///< world size of one tile of the base noise
    int baseLattice = 4;      ///< lattice cells per tile (lowest octave)
    int baseOctaves = 4;
    float detailPeriod = 2.0f; ///< world size of one tile of the detail noise
    int detailLattice = 4;
    int detailOctaves = 3;
    float towerSpacing = 4.5f;
    float towerRadiusMin = 2.0f;
    float towerRadiusMax = 4.0f;
    float towerHeightMin = 0.25f;
    float towerHeightMax = 1.0f;
    float towerProbability = 0.6f;
    float towerAnisotropy = 0.35f;
    vec3 wind{0.0f};       ///< world units per second: the whole field drifts with it
    vec3 detailWind{0.0f}; ///< extra drift of the detail noise: slowly evolving edges
    std::uint32_t seed = 1;
    NoiseEval eval = NoiseEval::Auto;
    int baseBakeResolution = 128;  ///< voxels per base tile when baked
    int detailBakeResolution = 64; ///< voxels per detail tile when baked
};

/// A density grid from a VDB file, rendered from NanoVDB. core/ never reads files: the host
/// (plugin/vdb) loads the grid named here into a GridBinding (core/bindings.h) per frame.
struct VdbFieldDesc {
    std::string path;             ///< file or per-frame pattern (`smoke.####.vdb`, `$F4`)
    std::string grid = "density"; ///< grid name
    bool levelsetToFog = false;   ///< convert a level set instead of refusing it
    bool hold = false;            ///< a missing frame repeats the last one instead of failing
    float density = 1.0f;         ///< multiplies the grid values
};

/// Gardner's sine-sum texture (core/kernels/gardner.glsl, GardnerTexture).
struct GardnerTextureDesc {
    float frequency = 0.2f;    ///< cycles per world unit of the first term
    int terms = 5;             ///< number of terms n (frequencies f, 2f, ..., 2^(n-1) f)
    float k = 1.0f;            ///< the texture's maximum
    float t0 = 0.5f;           ///< T0, added to each term (>= 0)
    float phase = 1.57079633f; ///< amplitude of the phase shifts (Gardner: pi/2)
    vec3 offset{0.0f};         ///< added to the world point before the sums
};

/// The shape parameters of a Gardner ellipsoid (core/kernels/gardner.glsl, GardnerEllipsoid).
struct GardnerShapeDesc {
    float t1 = 0.0f;      ///< T1: texture threshold at the centre
    float t2 = 0.22f;     ///< T2: texture threshold at the surface (>= T1)
    float d = 0.08f;      ///< D: ramp width from transparent to opaque (> 0)
    float density = 1.0f; ///< density of an opaque point
    GardnerTextureDesc texture;
};

/// One ellipsoid of a Gardner cloud; unset values take the cloud's (GardnerDesc::defaults).
struct GardnerEllipsoidDesc {
    vec3 center{0.0f};
    vec3 radii{1.0f};
    vec3 rotate{0.0f}; ///< degrees about x, then y, then z (R = Rz Ry Rx)
    std::optional<float> t1, t2, d, density, frequency, k, t0, phase;
    std::optional<int> terms;
};

/// A cumulus built from ellipsoids the way Gardner and Elinas & Stuerzlinger do: a few large
/// flattened ellipsoids for the body on a flat base, smaller ones heaped on top and sides.
struct GardnerScatterDesc {
    bool enabled = false;
    int count = 30;    ///< number of ellipsoids
    float size = 3.0f; ///< horizontal radius of the body ellipsoids
    std::uint32_t seed = 1;
    vec3 center{0.0f, 2.0f, 0.0f};  ///< centre of the cloud's flat base
    vec3 extent{14.0f, 7.0f, 9.0f}; ///< width, height and depth the cloud fills
};

/// A cloud of Gardner's textured ellipsoids (core/fields/gardner.h): the listed ellipsoids
/// and/or the scattered cumulus; overlapping ellipsoids take the larger density.
struct GardnerDesc {
    GardnerShapeDesc defaults;
    std::vector<GardnerEllipsoidDesc> ellipsoids;
    GardnerScatterDesc scatter;
};

/// A cloud sculpted from signed distance functions (Thomann 2020, ch. 3-4): density =
/// density * sdfDensityFromDistance(d, falloff), d the tree's (displaced) distance, see
/// core/fields/sdf_field.h.
struct SdfFieldDesc {
    SdfNodeDesc root;      ///< the tree (scene file: [[field.node]] tables)
    float density = 1.0f;  ///< density deeper inside than `falloff`
    float falloff = 0.25f; ///< width of the soft edge inside the surface (world units)
};

/// One row of the automaton's layered wind: the horizontal wind (world units / s) at world
/// altitude y; linear between rows, the first / last row below / above the table.
struct AutomatonWindRow {
    float altitude = 0.0f;
    vec3 wind{0.0f}; ///< y must be 0: the cells shift horizontally per layer (Dobashi 2000)
};

/// The most cells of an automaton grid (x y z): 2^24, 64 MB per float grid; the field keeps
/// about six grids of floats and three bit fields.
constexpr double kMaxAutomatonCells = 16777216.0;

/// A cloud from Dobashi's cellular automaton (core/fields/automaton_field.h,
/// core/sim/automaton.h): the grid of `res` cells spans `bounds`; the controls' defaults are
/// those of sim::AutomatonParams (sizes in cells, times in seconds).
struct AutomatonDesc {
    ivec3 res{256, 32, 256};
    Box bounds{vec3(-20.0f, 1.5f, -20.0f), vec3(20.0f, 4.5f, 20.0f)};
    std::uint32_t seed = 1;
    float simStep = 0.1f; ///< seconds per simulation step
    float warmup = 10.0f; ///< seconds simulated before time 0 (the cover settles)
    float density = 1.0f; ///< density of a fully cloudy smoothed cell
    float pHum = 0.1f, pAct = 0.01f, pExt = 0.1f;
    int ellipsoids = 24; ///< initial number of region ellipsoids (cloudDensity)
    int minEllipsoids = 2, maxEllipsoids = 64;
    float targetCover = 0.35f, coverTolerance = 0.05f;
    int adaptPeriod = 10;
    float sizeMean = 28.0f, sizeVar = 8.0f; ///< cells
    float heightRatio = 0.35f;
    float lifeMean = 40.0f, lifeVar = 15.0f, shrinkTime = 8.0f;
    float regionMargin = 40.0f; ///< cells
    float layerLo = 0.3f, layerHi = 0.6f;
    bool startFull = false;
    std::vector<AutomatonWindRow> wind; ///< empty: still air
    int checkpointEvery = 100;          ///< steps between kept states (going back in time)
};

/// How an advected field's wind is given (AdvectDesc).
enum class AdvectWind { Uniform, Layered, Grid };
/// Where a VDB velocity grid's components sit: at cell centres, or on the cells' lower faces
/// (MAC, Mantaflow's cache); Auto takes the grid class (OpenVDB marks MAC grids "staggered").
enum class VelocityLayout { Auto, Centred, Staggered };

/// Wind advection of a field's density ([field.advect], core/fields/advected_field.h): the
/// source field at time 0 (a VDB sequence: the frame's grid) is sampled on a dense grid of
/// `voxel`-sized cells over `bounds` and carried by the wind in steps of `step` seconds,
/// semi-Lagrangian with Selle et al.'s bounded MacCormack correction (core/sim/advect.h).
struct AdvectDesc {
    bool enabled = false;
    AdvectWind wind = AdvectWind::Uniform;
    vec3 uniform{0.0f};                   ///< Uniform: world units / s
    std::vector<AutomatonWindRow> layers; ///< Layered: rows by altitude (vertical wind allowed)
    std::string velocityPath;             ///< Grid: a VDB file (or per-frame pattern)
    std::string velocityGrid = "velocity";
    VelocityLayout layout = VelocityLayout::Auto;
    float velocityScale = 1.0f; ///< Grid: multiplies the velocities (e.g. cells/s to units/s)
    /// Grid: inactive voxels inside the grid's active box take their neighbours' velocity
    /// (extrapolated outward) instead of the background's 0
    bool velocityExtrapolate = true;
    float voxel = 0.0f; ///< cell size; 0: the VDB grid's voxel, else the source's longest side/128
    bool hasBounds = false;
    Box bounds;        ///< the simulation domain (hasBounds); else the source's grown by the wind
    float step = 0.0f; ///< seconds per step; 0: one step per frame (1 / fps)
    bool maccormack = true;
    /// Seconds to the scene's last frame (set by the host from `frames`): the default bounds
    /// hold the source moved by the wind over this time.
    float until = 0.0f;
    int checkpointEvery = 50; ///< steps between kept states (going back in time)
};

struct FieldDesc {
    FieldKind kind = FieldKind::Cumulus;
    VdbFieldDesc vdb;
    HomogeneousDesc homogeneous;
    CumulusDesc cumulus;
    GardnerDesc gardner;
    SdfFieldDesc sdf;
    AutomatonDesc automaton;
    AdvectDesc advect; ///< cumulus, VDB, Gardner, SDF, homogeneous: carried by a wind
};

/// A further VDB volume beside `field` (scene file `[[volume]]`), referred to by name.
struct NamedVolumeDesc {
    std::string name;
    FieldDesc field; ///< kind Vdb
};

/// One placement of a volume: world = translate + R * (scale * local), R = Rz Ry Rx.
struct InstanceDesc {
    int volume = 0; ///< 0 = `field`, i = volumes[i - 1]
    vec3 translate{0.0f};
    vec3 rotate{0.0f}; ///< degrees about x, then y, then z
    vec3 scale{1.0f};
    float density = 1.0f; ///< multiplies the volume's density
};

/// Opaque diffuse surfaces (Embree, plugin/geom): a ground plane and OBJ meshes.
struct SurfaceMaterialDesc {
    vec3 albedo{0.5f};
    bool holdout = false; ///< matte: hides what is behind, alpha 0, no colour of its own
};

struct GroundDesc {
    bool enabled = false;
    float height = 0.0f;   ///< y of the plane
    float extent = 1.0e4f; ///< half side of the square, centred under the camera
    SurfaceMaterialDesc material;
};

struct MeshDesc {
    std::string path; ///< OBJ file
    vec3 translate{0.0f};
    vec3 rotate{0.0f};
    vec3 scale{1.0f};
    SurfaceMaterialDesc material;
};

/// An opaque solid bounded by an SDF tree (scene file `[[solid]]`, core/sdf/solid.h): sphere
/// traced, Lambertian, with soft sun shadows and ambient occlusion (march; pathtrace shades it as
/// any opaque diffuse surface, hard shadows from the point sun, no AO term).
struct SolidDesc {
    SdfNodeDesc root; ///< the tree (scene file: [[solid.node]] tables)
    SolidShading shading;
};

enum class InScatter { None, Olajos, Powder };
/// march: approximation of the sun light scattered more than once (core/integrators/march.h).
enum class MultipleScattering { None, Grid, Photons, Auto };
/// march: how much of the sky a point inside the medium sees (core/integrators/march.h).
enum class SkyOcclusion { Height, Column };
/// march without multiple scattering: the sky as an ambient term standing for every order of
/// scattering, or the sky light scattered once (core/lighting/sky_volume.h).
enum class SkyScattering { Ambient, Single };
/// march: the light scattered within the phase function's forward peak: kept in the sun's and
/// the camera's beams (delta scaling) or not (core/integrators/march.h).
enum class ForwardScattering { None, Delta };
/// The single-scattered sky's transmittance toward its directions: a shadow march per direction
/// and sample, or a precomputed volume per direction (core/lighting/sky_volume.h).
enum class SkyShadow { March, Volume };
enum class Integrator { March, PathTrace };
enum class ShadowMethod { March, Volume };
enum class Background { Sky, Transparent };
/// Pixel reconstruction filter (values = FILTER_* in core/kernels/pixel.glsl).
enum class PixelFilter { Box = 0, Gaussian = 1, BlackmanHarris = 2 };

struct RenderDesc {
    Integrator integrator = Integrator::March;
    int spp = 16; ///< pathtrace: samples per pixel
    /// pathtrace and photons: scattering events per path at most (1 = single scattering); the
    /// most the scene file allows, so that a walk through a cloud 500 mean free paths across at
    /// albedo 1 ends by leaving it (at 256 such references lost 4-14% of their light, at 65,536
    /// a white furnace of that size 0.11%: docs/accuracy.md, stop 72)
    int maxDepth = 1 << 20;
    int rrDepth = 3; ///< pathtrace: Russian roulette from this depth on
    /// primary step length (world units); 0 = chosen by the plan: stepVoxels x the voxel size
    /// of the VDB volumes, kDefaultStep for procedural fields (core/plan.h)
    float step = 0.0f;
    float stepGrowth = 0.0f; ///< distance-adaptive: step = max(step, stepGrowth * distance)
    /// march: a step (camera or shadow ray) whose optical depth at its sample times the
    /// transmittance in front of it exceeds this is split into that many sub-steps (at most
    /// kern::MAX_SUBSTEPS), each sampled at its own turn of the jitter (kern::substepOffset);
    /// 0 = never split (docs/accuracy.md, "Thick steps split")
    float stepTau = 0.5f;
    float photonStepTau = 0.125f; ///< render.photon_step_tau: stepTau where photons carry the sun
    /// render.photon_second_share: where photons carry the sun, march estimates the sun's light
    /// scattered 2 to photonMarchDepth times itself, by about 1 / share paths per camera ray,
    /// and the photons record the orders above (not in a cloud at most 2 mean free paths deep
    /// along the sun); 0 = the photons carry them too
    float photonSecondShare = 0.002f;
    /// render.photon_march_depth: with photon_second_share, march's paths carry the sun's
    /// orders 2 .. this (vertices up to this - 1 a path), the photons the orders above
    int photonMarchDepth = 8;
    bool jitter = true;
    /// march: camera rays per pixel, stratified over the filter's width and weighted by it;
    /// 1 = one ray through the pixel centre (no filter)
    int pixelSamples = 1;
    PixelFilter filter = PixelFilter::Box; ///< how samples are weighted (march and pathtrace)
    float filterWidth = 1.0f;              ///< filter width in pixels
    float epsilon = 0.01f;                 ///< stop when transmittance drops below this
    /// first shadow-ray step (world units); 0 = chosen by the plan like `step`, from
    /// shadowStepVoxels
    float shadowStep = 0.0f;
    /// step = 0 with VDB volumes: the step as a fraction of the smallest world voxel of the
    /// placed grids (planFrame, core/plan.h)
    float stepVoxels = 1.0f;
    float shadowStepVoxels = 1.0f;             ///< the same for shadowStep = 0
    float shadowGrowth = 0.3f;                 ///< shadow steps grow geometrically by this factor
    ShadowMethod shadow = ShadowMethod::March; ///< sun transmittance: shadow marches or volume
    float lightVolumeCell = 0.0f; ///< light-attenuation voxel size; 0 = the majorant cell
    bool skipEmpty = true;        ///< use the majorant grid to skip empty space
    bool sdfTrace = true; ///< SDF clouds: skip by sphere tracing the distance bound (else the grid)
    /// Instanced volumes: per-instance majorant grids found through the instance boxes
    /// (hierarchical), or one coarse world grid over all instances (false; for comparison).
    bool hierarchicalSkip = true;
    /// pathtrace: trace the sun's shadow ray with a probability from the precomputed density
    /// integral toward the sun (weighted by its inverse: unbiased), so vertices deep in thick
    /// cloud skip most of them
    bool shadowRoulette = true;
    /// pathtrace: next-event estimation of the sky (uniform sphere directions, MIS with phase
    /// sampling); off = the sky through phase-sampled rays alone
    bool skyNee = false;
    float majorantCell = 0.0f; ///< majorant cell size; 0 = chosen by the plan
    /// Multiple-scattering octaves (Wrenninge 2015; Hillaire 2016): octave i adds the sun term
    /// with weight contribution^i, sun optical depth scaled by extinction^i and phase g scaled
    /// by eccentricity^i. 1 = single scattering only. Energy: contribution <= extinction.
    int octaves = 1;
    float octaveExtinction = 0.5f;
    float octaveContribution = 0.5f;
    float octaveEccentricity = 0.5f;
    /// Octaves above the first fade where the cloud along the sun's line through the sample is
    /// optically thin: weighted by 1 - exp(-octaveGate sigma_s tau_line), tau_line the density
    /// integral toward the sun plus the one away from it (a second shadow march per sample, only
    /// with octaves > 1). Light scattered more than once needs a cloud to scatter in; the
    /// octaves, calibrated on a thick cloud, otherwise add it to thin ones too (the default
    /// scene at a twentieth of its density came out 1.30-1.38x the reference). 0 = off (the
    /// default: it costs a second shadow march, 1.27x the default scene's frame and 1.7x
    /// smoke1's); the default scene sets 0.25, chosen on its cases of the validation matrix
    /// (docs/accuracy.md, "Octaves gated by the cloud's depth").
    float octaveGate = 0.0f;
    /// Grid: the sun light scattered more than once and all sky light, from a diffusion solve
    /// on the light-volume grid (core/lighting/diffusion.h); it replaces the sky ambient term.
    /// msStrength scales its sun part (diffusion loses light in moderately thick, porous cloud),
    /// msP1 weights its flux (P1) term. Octaves still add the short-range, forward part.
    /// Photons: the sun's part from photons traced through the field once per frame
    /// (core/lighting/photons.h; no octaves, no calibration), the sky's from the diffusion grid
    /// (or from photons too with photonSky).
    /// Auto: photons where the cloud's mean optical depth along the sun is at most photonDepth
    /// (measured by the plan each frame, core/lighting/cloud_depth.h), the grid elsewhere.
    /// 1000: twice the validation matrix's thick clouds (500), where photons took 13 of 27
    /// albedo-1 rows within 10% and the grid none; above it the grid bounds the frame's cost,
    /// which for photons grows with the depth (docs/accuracy.md, "Photons for thick clouds").
    MultipleScattering multipleScattering = MultipleScattering::Auto;
    float photonDepth = 1000.0f;
    /// Photons walk a majorant grid of their own where their voxel's optical depth at the
    /// cloud's mean extinction (measured along the sun each frame) is at least this, march's
    /// grid elsewhere (FramePlan::photonOwnWalk); 0 = always their own
    float photonWalkDepth = 5.0f;
    /// Photons: photons leaving the sun per frame; 0 = chosen per frame by the cloud's depth
    /// along the sun (FramePlan::photonCount, core/plan.cpp)
    int photons = 0;
    /// Photons: the multiply scattered light inside a voxel is taken to fall off as
    /// max(exp(-photonSkin sigma_t tau_sun), 0.1) with the density integral toward the sun
    /// (core/lighting/photons.h); 0 = flat over the voxel
    float photonSkin = 0.0f;
    /// The photons' grid: its voxel in light-volume cells (1 = the light-volume grid itself);
    /// 0 = chosen by the plan from the cloud's occupied volume and the photon count
    float photonCellScale = 0.0f;
    /// Photons: the scatterings a photon is traced through; at the next one its light goes to
    /// the diffusion grid as a source (core/lighting/photons.h); 0 = traced to maxDepth
    int photonBounces = 0;
    /// Photons walking a grid of their own (FramePlan::photonOwnWalk): after this many
    /// scatterings a photon walks the similar medium (isotropic scattering at sigma_s (1 - g),
    /// the similarity relation; PhotonParams::similarAfter) instead of the real one; 0 = never
    int photonSimilarity = 16;
    /// Photons: the sky's light traced by photons too (its orders above the first; march
    /// integrates its single scattering), so the diffusion grid keeps no sky boundary
    bool photonSky = false;
    /// Not a key: whether multipleScattering = Auto may turn photonSky on by itself where the
    /// medium absorbs (core/plan.cpp). The GLSL hosts (`nimbus rt`, `export-glsl`) clear it: the
    /// GPU march has no shadow-marched sky.
    bool autoPhotonSky = true;
    float msStrength = 1.0f;
    float msP1 = 1.0f;
    /// Sky light inside the medium: Height = darkened toward the base of the layer (v1);
    /// Column = the sky of the upper and lower hemispheres weighted by the openness of the
    /// vertical column above and below the sample, normalised so that an albedo-1 medium under
    /// a uniform sky returns the sky radiance (white furnace). skyOpenness sharpens the
    /// weighting.
    SkyOcclusion skyOcclusion = SkyOcclusion::Height;
    float skyOpenness = 1.0f;
    /// Without multiple scattering: the sky as an ambient term (skyOcclusion) or single-scattered
    /// over skyDirections directions (core/lighting/sky_volume.h): what pathtrace computes with
    /// maxDepth = 1. skyShadow: the transmittance toward each from a shadow march per sample (the
    /// directions drawn from the phase function per sample) or from a volume per direction
    /// (fixed ones).
    SkyScattering skyScattering = SkyScattering::Ambient;
    SkyShadow skyShadow = SkyShadow::March;
    /// 0 = chosen by the plan (FramePlan::skyDirections: 4 where the sky's photons leave its
    /// single scattering to shadow marches, else 8)
    int skyDirections = 0;
    InScatter inScatter = InScatter::Olajos;
    /// march with the diffusion grid: delta scaling of the phase function's forward peak (a
    /// fraction g^2 of the scattering): the sun's single scattering is attenuated by
    /// sigma_t - g^2 sigma_s along the sun's and the camera's paths, and the diffusion grid's
    /// source is what leaves that beam
    ForwardScattering forwardScattering = ForwardScattering::Delta;
    float inScatterC = 2.0f;
    float inScatterStrength = 0.4f; ///< chosen on the validation matrix (docs/accuracy.md)
    Background background = Background::Sky;
    std::uint32_t seed = 0;
    /// true: every frame draws its own random numbers from seed and its frame number (noise
    /// changes from frame to frame: flicker on a static shot); false: every frame draws the same
    /// ones (a static shot does not flicker; the noise stays as a fixed pattern). docs/temporal.md
    bool seedPerFrame = true;
    int threads = 0; ///< 0 = all cores
    int tileSize = 16;
    float fps = 24.0f; ///< frame -> time: t = frame / fps
    /// Motion blur (render.shutter, docs/motion_blur.md): the shutter is open from
    /// shutterOpen to shutterClose frames around the frame's time; equal (the default [0, 0]):
    /// closed, no blur.
    float shutterOpen = 0.0f;
    float shutterClose = 0.0f;
};

struct SceneDesc {
    CameraDesc camera;
    SunDesc sun;
    SkyDesc sky;
    MediumDesc medium;
    FieldDesc field;
    std::vector<NamedVolumeDesc> volumes; ///< further volumes, referred to by instances
    /// Placements of the volumes; empty = `field` once, untransformed.
    std::vector<InstanceDesc> instances;
    GroundDesc ground;
    std::vector<MeshDesc> meshes;
    std::vector<SolidDesc> solids;
    RenderDesc render;
};

} // namespace nimbus
