/// @file render.h
/// @brief Frame plans and the renderer: what a frame needs, then the `march` integrator over
/// tiles in parallel (TBB).
///
/// Data flow of one frame (DESIGN.md): scene -> plan (what is needed, nothing else) -> fields
/// (noise baked or direct) -> majorant grid -> integrate tiles -> framebuffer. Output is
/// bit-identical for identical inputs and seed, whatever the thread count: every random number
/// is a hash of (pixel, frame, seed, sample index) and every tile is independent.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "core/bindings.h"
#include "core/fields/field.h"
#include "core/image.h"
#include "core/lighting/diffusion.h"
#include "core/lighting/light_volume.h"
#include "core/lighting/photons.h"
#include "core/lighting/sky_volume.h"
#include "core/tracking/majorant.h"
#include "core/scene.h"
#include "core/plan.h"
#include "core/tracking/volumes.h"

namespace nimbus {

struct RenderStats {
    std::uint64_t rays = 0;
    std::uint64_t primarySamples = 0; ///< density lookups on camera rays
    std::uint64_t shadowSamples = 0;  ///< density lookups on shadow rays
    /// density lookups on the flights of march's paths for the sun's second scattering
    std::uint64_t secondSamples = 0;
    std::uint64_t nonFinite = 0; ///< pixels that were NaN/Inf (replaced by 0); should be 0
    std::size_t majorantCells = 0;
    double majorantEmptyFraction = 0.0;
    bool majorantUsed = false; ///< march skips with it only when at least half its cells are empty
    double bakeSeconds = 0.0;  ///< noise baking charged to this frame (0 when reused)
    /// field.kind = "automaton": simulation steps computed for this frame (all from step 0 for
    /// a renderer's first frame, the steps since the previous frame after that) and the time
    /// the frame's field took (steps, smoothing, advection, block maxima)
    std::uint64_t automatonSteps = 0;
    double automatonSeconds = 0.0;
    /// [field.advect]: advection steps computed for this frame (from time 0 for a lone frame,
    /// since the previous frame in a sequence) and the seconds the field took
    std::uint64_t advectSteps = 0;
    double advectSeconds = 0.0;
    double majorantSeconds = 0.0; ///< majorant grids and the instance query
    double lightVolumeSeconds = 0.0;
    std::uint64_t lightVolumeLookups = 0; ///< density lookups spent building it
    /// Work done, counted where it is done (tests/test_plan_obeyed.cpp proves with these that
    /// the renderer builds what the plan names and nothing else):
    int lightVolumes = 0;                ///< density integrals propagated (one per direction)
    std::uint64_t lightVolumeVoxels = 0; ///< their voxels, all directions
    std::uint64_t densityGridVoxels = 0; ///< densities looked up at light-grid voxel centres
    double diffusionSeconds = 0.0;       ///< march: solving the multiple-scattering grid
    int diffusionIterations = 0;
    /// the solve's residual over its right-hand side (DiffusionVolume::residual), and whether it
    /// reached DiffusionParams::tolerance before the iteration cap (or a cancel) stopped it
    float diffusionResidual = 0.0f;
    bool diffusionConverged = true;
    double diffusionBytes = 0.0; ///< what the diffusion solve held (DiffusionVolume::bytes)
    /// render.multiple_scattering = "auto": the cloud's mean optical depth along the sun it
    /// chose the model by (FramePlan::cloudTau); -1 when not measured
    double cloudDepth = -1.0;
    /// ... and in a medium that absorbs, the depth its diffuse light reaches, where that is less
    /// than cloudDepth and so what "auto" chose by (FramePlan::absorptionDepth); else -1
    double absorptionDepth = -1.0;
    double photonSeconds = 0.0;       ///< march: tracing the photons
    std::uint64_t photonsTraced = 0;  ///< photons that left the sun or the sky
    std::uint64_t photonsFromSky = 0; ///< of them, those that left the sky (render.photon_sky)
    /// photons whose light went on in the diffusion grid (render.photon_bounces)
    std::uint64_t photonsHandedOff = 0;
    /// scatterings of the photons' walks (render.photon_similarity: each of the similar
    /// medium's counting one)
    std::uint64_t photonScatterings = 0;
    /// bytes the photons held beyond the light-volume grid (PhotonVolume::bytes, with a
    /// density grid of their own): what FramePlan::photonGridBytes estimates
    double photonBytes = 0.0;
    std::uint64_t photonLookups = 0; ///< density lookups spent on them
    double skyVolumeSeconds = 0.0;   ///< march: the single-scattered sky's density integrals
    std::size_t skyVolumeBytes = 0;
    std::size_t aovBytes = 0; ///< memory of the frame's AOV buffers (0 when none is asked for)
    double integrateSeconds = 0.0;
    std::uint64_t lookups() const { return primarySamples + shadowSamples + secondSamples; }
};

struct ScatterVolumes; // core/integrators/march.h

/// The grids a `march` frame reads beside its volumes, each built only when the plan names it:
/// the light-attenuation volumes (toward the sun, then straight up and down for the column
/// sky), the densities at their voxel centres, the single-scattered sky, the diffusion solve
/// and the photon volume. Built by buildMarchGrids, which Renderer::render calls, so a consumer
/// of the grids (the GLSL pass, plugin/realtime) reads what the CPU frame reads. Move-only: the
/// photon volume points into lightVolumes.
struct MarchGrids {
    std::vector<LightVolume> lightVolumes;
    std::vector<float> rho; ///< densities at the light grid's voxel centres (when needed)
    bool toward = false;    ///< lightVolumes[0] is the density integral toward the sun
    bool column = false;    ///< the next two are the integrals up and down (column sky)
    bool hasSky = false, hasDiffusion = false, hasPhotons = false;
    SkyVolume sky;
    DiffusionVolume diffusion;
    PhotonVolume photons;

    MarchGrids() = default;
    MarchGrids(MarchGrids&&) = default;
    MarchGrids& operator=(MarchGrids&&) = default;
    MarchGrids(const MarchGrids&) = delete;
    MarchGrids& operator=(const MarchGrids&) = delete;

    const LightVolume* towardVolume() const { return toward ? &lightVolumes[0] : nullptr; }
    /// What MarchContext reads (null where not built).
    ScatterVolumes scatter() const;
};

/// Builds the march grids of frame `plan` of `scene` over the first volume of `vs` (the plan
/// names them only for one untransformed volume); `surfaces` (may be null) stop photons. Adds
/// timings and counters to `stats`. Stops early, the grids incomplete, once `cancel` is set.
MarchGrids buildMarchGrids(const SceneDesc& scene, const FramePlan& plan, const VolumeSet& vs,
                           const SurfaceQuery* surfaces, RenderStats& stats,
                           const std::atomic<bool>* cancel = nullptr);

struct RenderCallbacks {
    /// Called (from worker threads, serialised) after each finished tile.
    std::function<void(int tilesDone, int tilesTotal)> progress;
    /// When set to true, the frame stops within milliseconds and render() returns false: it is
    /// polled between tiles and inside them (step loops, tracking walks, sample loops, grid
    /// builds, diffusion iterations: core/cancel.h).
    const std::atomic<bool>* cancel = nullptr;
};

/// Owns a validated scene and what is shared across its frames (baked noise). What the host
/// loaded for a frame (grids, geometry: core/bindings.h) is passed per frame; the overloads
/// without bindings are for scenes with nothing to bind (procedural fields, no surfaces).
class Renderer {
  public:
    explicit Renderer(const SceneDesc& scene);

    const SceneDesc& scene() const { return scene_; }
    FramePlan plan(int frame, const FrameBindings& bindings, const AovSet& aovs = {}) const;
    FramePlan plan(int frame, const AovSet& aovs = {}) const;
    /// Renders the frame into fb (resized to the camera). Returns false if cancelled. With
    /// `grids`, the march grids the frame was rendered with are moved there (a consumer that
    /// needs both, as the GLSL pass's parity tests do, builds them once; for a plan rendered
    /// translated, plan.rebased, they are in the translated coordinates). Under a plan with
    /// secondShare > 0 its photons leave the sun's second scattering out (march took it): a GPU
    /// consumer renders with secondShare 0 or builds its grids with marchGrids.
    bool render(const FramePlan& plan, const FrameBindings& bindings, Framebuffer& fb,
                RenderStats& stats, const RenderCallbacks& cb = {}, MarchGrids* grids = nullptr);
    bool render(const FramePlan& plan, Framebuffer& fb, RenderStats& stats,
                const RenderCallbacks& cb = {});
    /// The field of a frame as the plan builds it (bakes noise on first use when planned).
    Field fieldFor(const FramePlan& plan, const FrameBindings& bindings,
                   double* bakeSeconds = nullptr, const std::atomic<bool>* cancel = nullptr);
    Field fieldFor(const FramePlan& plan, double* bakeSeconds = nullptr);
    /// Every volume of the frame with majorant grids, instances and the instance query; ray
    /// walks over it stop once `cancel` is set (core/cancel.h).
    VolumeSet volumesFor(const FramePlan& plan, const FrameBindings& bindings, RenderStats& stats,
                         const std::atomic<bool>* cancel = nullptr);
    VolumeSet volumesFor(const FramePlan& plan, RenderStats& stats);
    /// The march grids of a frame as render() builds them (volumesFor, then buildMarchGrids with
    /// the frame's surfaces and SDF solids), in the scene's own coordinates: not for a frame the
    /// plan renders translated (plan.rebased). For the GPU port: its photons carry the sun's
    /// second scattering too (plan.secondShare taken as 0), since its march does not take it.
    MarchGrids marchGrids(const FramePlan& plan, const FrameBindings& bindings, RenderStats& stats,
                          const std::atomic<bool>* cancel = nullptr);
    /// [field.advect]: what the simulation kept between frames holds now (its frames are the
    /// fields'; all 0 before the first frame or without advection): the plan's
    /// FramePlan::advectMemory is tested against it.
    AdvectMemory advectMemory();

  private:
    SceneDesc scene_;
    bool rebasedCopy_ = false; ///< this renderer already renders a translated frame
    std::mutex bakeMutex_;
    std::shared_ptr<const NoiseVolume> baseBake_, detailBake_;
    /// field.kind = "automaton": the simulation, kept between the frames of a sequence so that
    /// frame f + 1 costs only the steps after frame f's (made on first use)
    std::mutex automatonMutex_;
    std::unique_ptr<AutomatonSequence> automaton_;
    std::uint64_t automatonLastSteps_ = 0; ///< steps the last fieldFor computed
    /// [field.advect]: the simulation kept between frames, and what it was made from (the
    /// source grid and the velocity grid: a VDB sequence's next frame starts a new one)
    std::mutex advectMutex_;
    std::unique_ptr<AdvectedSequence> advect_;
    const void* advectSourceKey_ = nullptr;
    const void* advectVelocityKey_ = nullptr;
    FieldMotion advectWind_;
    std::uint64_t advectLastSteps_ = 0;
};

} // namespace nimbus
