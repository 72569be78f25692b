/// @file plan.h
/// @brief The frame plan: the one place that decides what a frame needs (`nimbus render
/// --explain` prints it). The renderer builds what the plan names and nothing else.
#pragma once

#include <string>
#include <vector>

#include "core/bindings.h"
#include "core/fields/advected_field.h"
#include "core/image.h"
#include "core/scene.h"

namespace nimbus {

/// The primary and shadow step of procedural fields when render.step / render.shadow_step are 0
/// (world units; the default scene's kilometres: 50 m).
constexpr float kDefaultStep = 0.05f;

/// The most cells a majorant grid or light-volume grid (times its directions, for the sky
/// volume) may have: 2^27, 512 MB per float per cell. Past it the frame is refused.
constexpr double kMaxGridCells = 134217728.0;

/// Steps per ray past which the plan warns (march's primary or shadow step).
constexpr double kWarnStepsPerRay = 1e6;

/// Steps of the automaton from the seed past which the plan warns (a lone frame re-simulates
/// them all).
constexpr std::uint64_t kWarnAutomatonSteps = 50000;

/// What one frame needs. Everything not named here is never built.
struct FramePlan {
    int frame = 1;
    float time = 0.0f; ///< seconds: frame / fps
    AovSet aovs;
    bool bakeNoise = false;    ///< cumulus noise read from baked tiles (else evaluated directly)
    std::string noiseDecision; ///< why
    bool pathtrace = false;    ///< the integrator is pathtrace (else march)
    bool shadows = true;       ///< sun enabled with non-zero irradiance
    bool ambient = true;       ///< sky present with non-zero ambient
    /// the medium scatters light (medium.sigma_s > 0 in some channel); at albedo 0 nothing
    /// in-scatters, so march builds no multiple scattering, sky grids or in-medium shadow rays
    bool scatters = true;
    bool skipEmpty = true;
    /// an SDF cloud: empty space skipped by sphere tracing its distance bound (the majorant
    /// grid is still built for the light volumes)
    bool sdfTrace = false;
    bool lightVolume = false; ///< sun transmittance from a precomputed light-attenuation volume
    /// march: the octave gate (render.octave_gate) takes the density integral along the sun's
    /// line from the sun-depth volume the frame builds anyway (the light volume, the diffusion's
    /// sun source), read where the line leaves it, instead of a second shadow march per sample
    bool gateVolume = false;
    bool columnVolumes = false; ///< march: density integrals up and down (column sky occlusion)
    bool diffusion = false;     ///< march: multiple scattering of sun and sky solved on a grid
    bool photons = false;       ///< march: the sun's multiple scattering from traced photons
    /// render.multiple_scattering = "auto": the model was chosen here, from the cloud's mean
    /// optical depth along the sun (cloudTau; -1 when it was not measured), or in a medium that
    /// absorbs the depth its diffuse light reaches where less, against render.photon_depth;
    /// msDecision says what was chosen and why
    bool msAuto = false;
    std::string msDecision;
    /// the cloud measured along the sun (core/lighting/cloud_depth.h), for "auto" and for
    /// render.photon_cell_scale = 0: its mean optical depth (-1 until measured) and the volume
    /// it fills
    double cloudTau = -1.0;
    /// "auto" in a medium that absorbs: the depth its diffuse light reaches (mean free paths),
    /// where that is less than cloudTau and so what was compared with render.photon_depth; else -1
    double absorptionDepth = -1.0;
    double cloudVolume = 0.0;
    double cloudExtinction = 0.0; ///< its mean extinction where it has density (per unit length)
    /// the share of the rays along the sun over the box that holds density that meet it (about
    /// the share of the sun's photons that reach the cloud: they leave over that box)
    double cloudHitFraction = 1.0;
    bool cloudMeasured() const { return cloudTau >= 0.0; }
    std::string photonCellNote; ///< render.photon_cell_scale = 0: the voxel chosen and why
    /// the diffusion grid (named or chosen by "auto") with render.light_volume_cell 0: the
    /// light-volume cell refined from the cloud's measured volume (gridCellScale in plan.cpp),
    /// what and why; empty where the cell is the majorant cell
    std::string gridCellNote;
    /// photons: the voxel of the grid they record on (world units) and its memory (without the
    /// per-thread sums of the voxels that record; with the hand-off its sums and source on the
    /// light-volume grid too; 0 while a VDB field is unread). A grid of their own covers only
    /// the box of the majorant cells with density (densityGridWithin), which the plan does not
    /// know: its memory is counted over the field's bounds, at most what the frame takes.
    float photonCell = 0.0f;
    /// the cell of the density grid photons are tracked through, as the plan estimates it from
    /// the majorant cell (photonTrackingCell; tracePhotons takes the majorant grid's own cell;
    /// 0 while a VDB field is unread)
    float photonTrackingCell = 0.0f;
    double photonGridBytes = 0.0;
    /// photons walk a majorant grid of their own (on the cells of the density grid they are
    /// tracked through) instead of march's: where their voxel is optically deep at the cloud's
    /// mean extinction (render.photon_walk_depth; core/lighting/photons.h); photonWalkNote says
    /// why
    bool photonOwnWalk = false;
    std::string photonWalkNote;
    /// Photons walking a grid of their own: the scatterings after which they walk the similar
    /// medium (render.photon_similarity; PhotonParams::similarAfter); 0 = never
    int photonSimilarity = 0;
    /// the diffusion solve's memory (core/lighting/diffusion.h, diffusionBytes) on its grid:
    /// the voxels with density counted from the cloud's measured volume, or all of them where
    /// it was not measured (then an upper bound); 0 while a VDB field is unread
    double diffusionBytes = 0.0;
    /// photons record on a grid of their own, not on the light-volume grid
    bool photonsOwnGrid() const { return photons && photonCell != lightVolumeCell; }
    /// the diffusion grid's voxel (world units): the light-volume cell, or a finer one where
    /// photons carry the sun to the end (no hand-off) and the grid the sky alone: the photons'
    /// voxel, no finer than the photons' first rule gives (countCellScale in plan.cpp); a few cells
    /// across a small cloud made its sky too bright at albedo < 1 (docs/accuracy.md, "The sky's
    /// grid on the photons' voxel"), a sky grid as fine as the photons' finest voxels too bright
    /// again ("The photons' voxel and the density they are tracked through")
    float diffusionCell = 0.0f;
    /// the diffusion is solved on a finer grid than the light-volume grid (its densities, no
    /// sun source): the photons' own grid (diffusionSharesPhotonGrid) or one of its own
    bool diffusionOnPhotonGrid() const { return diffusion && diffusionCell != lightVolumeCell; }
    bool diffusionSharesPhotonGrid() const {
        return diffusionOnPhotonGrid() && photonsOwnGrid() && diffusionCell == photonCell;
    }
    /// photons: the scatterings they are traced through before the diffusion grid takes their
    /// light as its source (render.photon_bounces; 0 = traced to render.max_depth, the grid
    /// carries only the sky)
    int photonBounces = 0;
    /// photons: the sky's light is traced by photons too (render.photon_sky); march adds the
    /// sky's single scattering itself and the diffusion grid has no sky boundary
    bool photonSky = false;
    /// photonSky chosen by render.multiple_scattering = "auto" (the medium absorbs), not by the
    /// key
    bool photonSkyAuto = false;
    /// photons traced per frame, the sun's and the sky's together: render.photons (with 0, 2 M
    /// where the cloud is thin along the sun, 8 M where it is deep), twice that when "auto"
    /// traces the sky too, and then at least 16 M
    std::int64_t photonCount = 0;
    /// the count the photons' voxel is sized for (the rules of photon_cell_scale = 0): the
    /// count above but for the 16 M floor of "auto"'s sky, which lowers the noise of each voxel
    /// rather than making them finer
    std::int64_t photonVoxelCount = 0;
    std::string photonCountNote; ///< render.photons = 0: the count chosen and why
    /// march with the diffusion grid: the fraction g^2 of scattering in the phase function's
    /// forward peak kept in the sun's and the camera's beams (render.forward_scattering; 0: off)
    float forwardFraction = 0.0f;
    /// march: the in-scatter model on the sun's single scattering (render.inscatter), None
    /// with photons: they trace the light scattered more than once that the empirical models
    /// stand for, so the single scattering they add to is kept exact (as the octaves stand down)
    InScatter inScatter = InScatter::None;
    /// march: the sky single-scattered over `skyDirections` directions
    /// (core/lighting/sky_volume.h), their transmittance from shadow marches or (skyVolume) from
    /// density integrals on the light-volume grid
    bool skySingle = false;
    bool skyVolume = false;
    int skyDirections = 0;
    double skyVolumeBytes = 0.0; ///< its memory: voxels x directions x 4 bytes
    /// march: float grids on the light-volume grid: the density integrals (toward the sun, up
    /// and down for the column sky) and the densities kept for the diffusion, the photons or
    /// the sky volume; their memory is lightGrids x voxels x 4 bytes (the sky volume apart)
    int lightGrids = 0;
    double lightGridBytes = 0.0;
    std::string skyNote; ///< why the sky is not what the scene asked for, when it is not
    float lightVolumeCell = 0.0f;
    /// march: the primary and first shadow steps (world units), render.step and
    /// render.shadow_step or, where those are 0, chosen here (see stepDecision)
    float step = kDefaultStep;
    float shadowStep = kDefaultStep;
    std::string stepDecision; ///< what the steps are and why
    float stepTau = 0.0f;     ///< render.step_tau: thick steps split above this (march.cpp)
    /// march estimates the sun's orders 2 .. secondDepth at its samples, about 1 / secondShare
    /// paths a camera ray, and the sun's photons record the orders above
    /// (render.photon_second_share where photons carry the sun, the CPU march, max_depth >= 2,
    /// a cloud more than 2 mean free paths deep along the sun or not measured;
    /// Renderer::marchGrids, for the GPU port, builds the photons with it at 0); 0 = off
    float secondShare = 0.0f;
    /// with secondShare: march's paths carry the sun's orders 2 .. secondDepth, the photons
    /// record the orders above: render.photon_march_depth (at most max_depth) where the
    /// photons' voxel is deeper than the medium's absorption lets diffuse light reach
    /// (photonVoxelDepth > absorptionDepth(medium): a voxel would average the lit skin with
    /// the dark inside), else 2
    int secondDepth = 2;
    /// the photons' voxel's optical depth at the cloud's mean extinction (mean free paths;
    /// -1 where the cloud was not measured)
    double photonVoxelDepth = -1.0;
    float majorantCell = 0.0f; ///< world size of a majorant cell
    int volumes = 1;           ///< `field` and the [[volume]] entries
    int instances = 1;         ///< placements (1: `field` untransformed)
    bool instanced = false;    ///< more than one instance or a transformed one
    bool hierarchical = true;  ///< instanced: instance boxes + per-volume grids (else coarse)
    bool surfaces = false;     ///< ground or meshes
    int solids = 0;            ///< [[solid]] count (core/sdf/solid.h)
    /// the density integral toward the sun on the light-volume grid, for march's attenuation
    /// volume, diffusion sun source or photon skin profile, or pathtrace's shadow roulette
    bool sunDepthVolume = false;
    /// pathtrace: the sun's shadow rays are traced with a probability from the sun-depth volume
    bool shadowRoulette = false;
    /// pathtrace: the sky by next-event estimation too (render.sky_nee)
    bool skyNee = false;
    /// march: the densities at the light-volume grid's voxel centres (diffusion, photons, when
    /// they are on that grid)
    bool densityGrid = false;
    /// field.kind = "automaton" (placed): the simulation is built (else nothing of it is)
    bool automaton = false;
    ivec3 automatonRes{0};
    std::uint64_t automatonSteps = 0; ///< steps from the seed to the frame's state
    double automatonSimTime = 0.0;    ///< seconds: warm-up + frame time
    double automatonBytes = 0.0;      ///< the simulation's and the frame's grids
    /// [field.advect] (placed): the source is sampled onto a dense grid and carried by the wind
    bool advected = false;
    ivec3 advectRes{0};
    float advectVoxel = 0.0f;
    Box advectBounds;
    float advectStep = 0.0f;       ///< seconds per step
    std::uint64_t advectSteps = 0; ///< full steps from time 0 to the frame (plus a partial one)
    AdvectMemory advectMemory;     ///< what the sequence and the frame hold, by part
    std::string advectWind;        ///< what carries it, in words
    bool advectCoarsened = false;  ///< the default voxel was enlarged to fit kMaxAdvectCells
    /// Set when the frame cannot be rendered as configured (a grid past kMaxGridCells): the
    /// message names the key, the cells it would need and the limit. The host refuses the frame.
    std::string refusal;
    /// Settings that will make the frame absurdly slow (a step implying millions of steps per
    /// ray): printed by explain() and by the host before rendering.
    std::vector<std::string> warnings;
    /// The frame is rendered translated by -renderOrigin because the field or the camera lies
    /// far from the world origin (core/rebase.h, Renderer::plan); the picture is unchanged.
    bool rebased = false;
    glm::dvec3 renderOrigin{0.0};
    double originDistance = 0.0; ///< how far the field or the camera lies from the origin
    /// Motion blur (core/tracking/motion_blur.h): the shutter is open (render.shutter) and a
    /// placed volume moves. Each camera sample then looks the density up at its own time
    /// offset in [shutterOpen, shutterClose] / fps seconds; the lighting caches stay at the
    /// frame's time.
    bool motionBlur = false;
    float shutterOpen = 0.0f;  ///< seconds from the frame's time (motionBlur)
    float shutterClose = 0.0f; ///< seconds
    std::string motionNote;    ///< what moves, or why the blur is left out
    std::string explain() const;
};

/// What a frame mixes into its random seeds: its number, or 0 for every frame when the scene
/// asks for the same noise in every frame (render.seed_per_frame = false).
inline std::uint32_t frameSeedKey(const SceneDesc& s, const FramePlan& p) {
    return s.render.seedPerFrame ? std::uint32_t(p.frame) : 0u;
}

/// The noise evaluation the plan chose, fixed (what `converge` and the suite render with, so
/// that their references and ladders take the same noise): the tiles the scene asked for when
/// the plan bakes (float tiles for "auto"), else direct.
inline NoiseEval plannedNoiseEval(const SceneDesc& s, const FramePlan& p) {
    if (!p.bakeNoise) return NoiseEval::Direct;
    return s.field.cumulus.eval == NoiseEval::Rgba ? NoiseEval::Rgba : NoiseEval::Baked;
}

/// Whether render.multiple_scattering = "auto", where it chooses photons, traces the sky by
/// photons too in this medium: some channel's albedo below 0.999 (the grid's sky is exact only
/// at albedo 1; planFrame, FramePlan::photonSkyAuto).
bool autoPhotonSkyMedium(const MediumDesc& m);

/// Whether a frame of this scene may trace the sky by photons: render.photon_sky under
/// "photons" or "auto", or "auto" in a medium autoPhotonSkyMedium takes. The plan turns it on
/// where the frame traces photons and has sky light (FramePlan::photonSky; "auto" alone once the
/// cloud is measured); the scene check asks it whether the single-scattered sky's keys are used.
bool photonSkyPossible(const RenderDesc& r, const MediumDesc& m);

/// Plans frame `frame` of the scene with what is bound to it (a VDB field's bounds size its
/// majorant cell).
FramePlan planFrame(const SceneDesc& scene, int frame, const FrameBindings& bindings,
                    const AovSet& aovs = {});
/// Plans a frame with nothing bound (procedural scenes; a VDB field counts as empty).
FramePlan planFrame(const SceneDesc& scene, int frame, const AovSet& aovs = {});

/// The majorant cell for a volume with the given bounds: render.majorant_cell when set, else
/// about four primary steps (`step`, the plan's) per cell and at most 256 cells along any axis.
float autoMajorantCell(const SceneDesc& s, const Box& bounds, float step);

/// An optical depth as the plan's notes, the frame's log line and the suite's table show it:
/// three significant digits, whole numbers from 1000 ("2000", not "2e+03").
std::string depthText(double depth);

/// The smallest world voxel of the VDB grids the scene places and that are bound (a grid's
/// voxel times the smallest scale of the instances placing it); 0 when there is none.
float finestVoxel(const SceneDesc& s, const FrameBindings& bindings);

} // namespace nimbus
