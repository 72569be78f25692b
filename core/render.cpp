#include "core/render.h"

#include "core/rebase.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <tbb/enumerable_thread_specific.h>

#include "core/integrators/march.h"
#include "core/integrators/pathtrace.h"
#include "core/lighting/diffusion.h"
#include "core/lighting/light_volume.h"
#include "core/lighting/photons.h"
#include "core/lighting/sky_volume.h"
#include "core/media/medium.h"
#include "core/media/mie.h"
#include "core/media/sky.h"
#include "core/sdf/solid.h"

namespace nimbus {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// march uses the majorant grid only when at least this share of its cells is empty.
constexpr double kSkipMinEmptyFraction = 0.5;

template <class Context>
bool renderTiles(const Context& ctx, const SceneDesc& s, Framebuffer& fb, RenderStats& stats,
                 const RenderCallbacks& cb);

/// The diffusion solve's medium and lights: the sky of each face direction as the current it
/// carries into the face (skyBoundaryRadiance, core/media/sky.h).
DiffusionParams diffusionParams(const SceneDesc& s, const FramePlan& plan, const Medium& m) {
    DiffusionParams p;
    p.sigma_s = m.sigma_s;
    p.sigma_a = m.sigma_a;
    p.g = m.g;
    // the scale of the sun's multiply scattered light; the solve is linear, so scaling its
    // source leaves the sky's part alone (which the diffusion gets right: white furnace)
    if (plan.shadows && !plan.photons) p.sunIrradiance = s.sun.irradiance * s.render.msStrength;
    p.sunDirection = s.sun.direction;
    p.forwardFraction = plan.forwardFraction;
    if (plan.ambient && !plan.photonSky) {
        const SkyFaces sky = skyBoundaryRadiance(s.sky);
        p.skyUp = sky.up;
        p.skyDown = sky.down;
        p.skySide = sky.side;
    }
    return p;
}

} // namespace

Renderer::Renderer(const SceneDesc& scene) : scene_(scene) {
    // the Mie table is computed once per process and parameter set, and only when used
    MediumDesc& m = scene_.medium;
    if (m.phase == PhaseKind::MieTable && !m.mieTable) {
        MieTableParams p;
        p.effectiveRadius = m.effectiveRadius;
        p.effectiveVariance = m.effectiveVariance;
        m.mieTable = sharedMieTable(p);
    }
}

FramePlan Renderer::plan(int frame, const FrameBindings& bindings, const AovSet& aovs) const {
    FramePlan p = planFrame(scene_, frame, bindings, aovs);
    if (rebasedCopy_) return p;
    Box bounds = scene_.field.homogeneous.box;
    if (scene_.field.kind == FieldKind::Vdb) bounds = bindings.grid(0).bounds;
    const double fine = std::min(double(p.step), double(maxComponent(bounds.extent())) / 64.0);
    const Rebase r = chooseRebase(scene_, bindings, fine);
    if (!r.active) {
        if (!r.blocked.empty())
            for (std::string& w : p.warnings)
                if (w.find("from the origin") != std::string::npos)
                    w += " (not translated automatically: the scene has " + r.blocked + ")";
        return p;
    }
    FramePlan q =
        planFrame(rebasedScene(scene_, r.origin), frame, rebasedBindings(bindings, r.origin), aovs);
    q.rebased = true;
    q.renderOrigin = r.origin;
    q.originDistance = r.distance;
    return q;
}

FramePlan Renderer::plan(int frame, const AovSet& aovs) const {
    return planFrame(scene_, frame, aovs);
}

Field Renderer::fieldFor(const FramePlan& plan, double* bakeSeconds) {
    return fieldFor(plan, FrameBindings{}, bakeSeconds);
}

VolumeSet Renderer::volumesFor(const FramePlan& plan, RenderStats& stats) {
    return volumesFor(plan, FrameBindings{}, stats);
}

bool Renderer::render(const FramePlan& plan, Framebuffer& fb, RenderStats& stats,
                      const RenderCallbacks& cb) {
    return render(plan, FrameBindings{}, fb, stats, cb);
}

AdvectMemory Renderer::advectMemory() {
    std::lock_guard<std::mutex> lock(advectMutex_);
    return advect_ ? advect_->memory() : AdvectMemory{};
}

Field Renderer::fieldFor(const FramePlan& plan, const FrameBindings& bindings, double* bakeSeconds,
                         const std::atomic<bool>* cancel) {
    if (bakeSeconds) *bakeSeconds = 0.0;
    if (scene_.field.advect.enabled) {
        std::lock_guard<std::mutex> lock(advectMutex_);
        const GridBinding& g = bindings.grid(0);
        std::uint64_t before = 0;
        bool keep =
            advect_ && advectSourceKey_ == g.grid && advectVelocityKey_ == bindings.velocity.get();
        if (advect_ && !keep && plan.refusal.empty() && plan.advected &&
            plan.advectRes == advect_->domain().res &&
            plan.advectBounds.lo == advect_->domain().bounds.lo) {
            // another binding: the same static VDB file read again for this frame, or the next
            // grid of a sequence; compared by content (the sequence keeps its own wind grid)
            const FieldMotion wind =
                advectWind(scene_.field.advect, bindings.velocity, bindings.velocityStaggered);
            keep = advect_->sameSource(makeAdvectSource(scene_.field, g), wind);
            if (keep) {
                advectSourceKey_ = g.grid;
                advectVelocityKey_ = bindings.velocity.get();
            }
        }
        if (keep) {
            before = advect_->stepsComputed();
        } else {
            // a new source (the first frame, or a VDB sequence's next grid): sampled at time 0
            // onto the domain the plan computed from the same bounds
            advect_.reset();
            if (!plan.refusal.empty() || !plan.advected) return emptyField();
            advectWind_ =
                advectWind(scene_.field.advect, bindings.velocity, bindings.velocityStaggered);
            const Field source = makeAdvectSource(scene_.field, g);
            AdvectDomain dom;
            dom.res = plan.advectRes;
            dom.frame = sim::GridFrame{plan.advectBounds.lo, plan.advectVoxel};
            dom.bounds = plan.advectBounds;
            advect_ = std::make_unique<AdvectedSequence>(scene_.field.advect, scene_.render.fps,
                                                         dom, source, advectWind_);
            advectSourceKey_ = g.grid;
            advectVelocityKey_ = bindings.velocity.get();
        }
        Field f = makeAdvectedField(scene_.field.advect, plan.time, *advect_, advectWind_, cancel);
        advectLastSteps_ = advect_->stepsComputed() - before;
        return f;
    }
    if (scene_.field.kind == FieldKind::Automaton) {
        std::lock_guard<std::mutex> lock(automatonMutex_);
        std::uint64_t before = 0;
        if (automaton_)
            before = automaton_->stepsComputed();
        else
            automaton_ = std::make_unique<AutomatonSequence>(scene_.field.automaton);
        Field f = makeField(scene_.field, plan.time, *automaton_);
        automatonLastSteps_ = automaton_->stepsComputed() - before;
        return f;
    }
    if (scene_.field.kind != FieldKind::Cumulus || !plan.bakeNoise)
        return makeField(scene_.field, plan.time, bindings.grid(0));
    {
        std::lock_guard<std::mutex> lock(bakeMutex_);
        if (!baseBake_) {
            auto t0 = std::chrono::steady_clock::now();
            baseBake_ = bakeCumulusBase(scene_.field.cumulus, cancel);
            detailBake_ = bakeCumulusDetail(scene_.field.cumulus, cancel);
            if (cancelRequested(cancel)) {
                // incomplete tiles: this frame is abandoned, and no later frame may reuse them
                const Field partial = makeField(scene_.field, plan.time, baseBake_, detailBake_);
                baseBake_.reset();
                detailBake_.reset();
                return partial;
            }
            if (bakeSeconds) *bakeSeconds = secondsSince(t0);
        }
    }
    return makeField(scene_.field, plan.time, baseBake_, detailBake_);
}

VolumeSet Renderer::volumesFor(const FramePlan& plan, const FrameBindings& bindings,
                               RenderStats& stats, const std::atomic<bool>* cancel) {
    const SceneDesc& s = scene_;
    VolumeSet vs;
    vs.cancel = cancel;
    const bool fieldPlaced = isPlaced(s, 0);
    // a [field] no instance places is never built (no noise baked, no grid read)
    const auto tField = std::chrono::steady_clock::now();
    vs.fields.push_back(fieldPlaced ? fieldFor(plan, bindings, &stats.bakeSeconds, cancel)
                                    : emptyField());
    if (fieldPlaced && s.field.kind == FieldKind::Automaton) {
        std::lock_guard<std::mutex> lock(automatonMutex_);
        stats.automatonSteps = automatonLastSteps_;
        stats.automatonSeconds = secondsSince(tField);
    }
    if (fieldPlaced && s.field.advect.enabled) {
        std::lock_guard<std::mutex> lock(advectMutex_);
        stats.advectSteps = advectLastSteps_;
        stats.advectSeconds = secondsSince(tField);
    }
    for (size_t i = 0; i < s.volumes.size(); ++i)
        vs.fields.push_back(makeField(s.volumes[i].field, plan.time, bindings.grid(int(i) + 1)));
    const auto t0 = std::chrono::steady_clock::now();
    vs.instances = makeInstances(vs.fields, s.instances);
    // motion blur: bounds and majorants over the shutter (core/tracking/motion_blur.h)
    if (plan.motionBlur) setShutter(vs, Shutter{plan.shutterOpen, plan.shutterClose});
    vs.bounds =
        Box{vec3(std::numeric_limits<float>::max()), vec3(-std::numeric_limits<float>::max())};
    for (const VolumeInstance& in : vs.instances) {
        vs.bounds.lo = glm::min(vs.bounds.lo, in.worldBounds.lo);
        vs.bounds.hi = glm::max(vs.bounds.hi, in.worldBounds.hi);
    }
    if (vs.instances.empty()) vs.bounds = Box{};
    const size_t n = vs.fields.size();
    vs.grids.resize(n);
    vs.useGrid.assign(n, 0);
    vs.wholeMajorant.resize(n);
    std::vector<char> instanced(n, 0);
    for (const VolumeInstance& in : vs.instances) instanced[size_t(in.volume)] = 1;
    vs.useCoarse = plan.skipEmpty && plan.instanced && !plan.hierarchical;
    vs.traceSdf.assign(n, 0);
    vs.traceSdf[0] = plan.sdfTrace && !vs.useCoarse && vs.fields[0].kind == FieldKind::Sdf &&
                     !vs.fields[0].bounds().empty() &&
                     !(vs.shutter.open() && vs.fields[0].motion.moving);
    double emptyCells = 0.0;
    // march's render.step_tau test reads each volume's grid at its camera steps (RayVolumes::
    // cellMajorant) whether or not it skips with it, so that skipping leaves the image as it is
    const bool stepGrids = s.render.integrator == Integrator::March && plan.stepTau > 0.0f;
    for (size_t i = 0; i < n; ++i) {
        const Field& f = vs.fields[i];
        vs.wholeMajorant[i] = sweptMajorant(f, vs.boundsOf(i), vs.shutter);
        if (!instanced[i] || (!stepGrids && (!plan.skipEmpty || vs.useCoarse))) continue;
        // each volume's grid in its own space; the plan's cell for `field`
        float cell = i == 0 ? plan.majorantCell : autoMajorantCell(s, vs.boundsOf(i), plan.step);
        // blurred: the swept bounds keep the plan's cap on the cells per axis
        if (i == 0 && vs.shutter.open())
            cell = std::max(cell, autoMajorantCell(s, vs.boundsOf(0), plan.step));
        // the path tracer's are tight (every null collision costs it a lookup); march only
        // skips empty space with its grid and steps by its own schedule
        vs.grids[i] = buildMajorantGrid(f, cell, 0.05f, cancel, vs.shutter,
                                        s.render.integrator == Integrator::PathTrace);
        stats.majorantCells += vs.grids[i].cellCount();
        const double empty = vs.grids[i].emptyFraction();
        emptyCells += empty * double(vs.grids[i].cellCount());
        // marching through a mostly full grid costs more in cell steps than it saves in
        // lookups (measured: smoke1, 37% empty cells, 1.9 s with the grid vs 1.2 s without);
        // the path tracer always wants the tighter majorants
        vs.useGrid[i] =
            plan.skipEmpty && !vs.useCoarse &&
            (s.render.integrator == Integrator::PathTrace || empty >= kSkipMinEmptyFraction);
        stats.majorantUsed = stats.majorantUsed || vs.useGrid[i];
    }
    if (vs.useCoarse) {
        vs.coarse = buildCoarseMajorantGrid(vs, autoMajorantCell(s, vs.bounds, plan.step));
        stats.majorantCells = vs.coarse.cellCount();
        emptyCells = vs.coarse.emptyFraction() * double(vs.coarse.cellCount());
        stats.majorantUsed = true;
    }
    if (stats.majorantCells) stats.majorantEmptyFraction = emptyCells / double(stats.majorantCells);
    if (!vs.single() && bindings.geometry) {
        std::vector<Box> boxes;
        boxes.reserve(vs.instances.size());
        for (const VolumeInstance& in : vs.instances) boxes.push_back(in.worldBounds);
        vs.query = bindings.geometry->instances(boxes);
    }
    stats.majorantSeconds = secondsSince(t0);
    return vs;
}

namespace {

/// The scene's SDF solids over `surfaces` (null when it has none).
std::unique_ptr<SdfSurfaces> solidsOver(const SceneDesc& s, const SurfaceQuery* surfaces) {
    if (s.solids.empty()) return nullptr;
    std::vector<SdfSolid> list;
    for (const SolidDesc& d : s.solids) list.push_back(solidFromTree(d.root, d.shading));
    return std::make_unique<SdfSurfaces>(std::move(list), surfaces);
}

} // namespace

ScatterVolumes MarchGrids::scatter() const {
    ScatterVolumes sv;
    if (column) {
        const std::size_t first = toward ? 1 : 0;
        sv.up = &lightVolumes[first];
        sv.down = &lightVolumes[first + 1];
    }
    if (hasSky) sv.sky = &sky;
    if (hasDiffusion) sv.diffusion = &diffusion;
    if (hasPhotons) sv.photons = &photons;
    return sv;
}

MarchGrids buildMarchGrids(const SceneDesc& s, const FramePlan& plan, const VolumeSet& vs,
                           const SurfaceQuery* surfaces, RenderStats& stats,
                           const std::atomic<bool>* cancel) {
    MarchGrids out;
    auto t0 = std::chrono::steady_clock::now();
    // the light-volume grids (attenuation, column sky, diffusion) cover one untransformed
    // volume: the plan names them only then
    const Field& field = vs.fields[0];
    const MajorantGrid* g = vs.useGrid[0] ? &vs.grids[0] : nullptr;
    // every light-attenuation volume the plan names, from one pass of density lookups;
    // nothing to light when the one volume is empty (an empty VDB frame)
    const bool any = !vs.instances.empty();
    const bool diffusion = plan.diffusion && any;
    const bool photons = plan.photons && any;
    out.toward = plan.sunDepthVolume && any;
    out.column = plan.columnVolumes && any;
    std::vector<vec3> dirs;
    if (out.toward) dirs.push_back(s.sun.direction);
    if (out.column) {
        dirs.push_back(vec3(0.0f, 1.0f, 0.0f));
        dirs.push_back(vec3(0.0f, -1.0f, 0.0f));
    }
    std::vector<LightVolume>& volumes = out.lightVolumes;
    std::vector<float>& rho = out.rho;
    const bool skyVolume = plan.skyVolume && any;
    // the sky volume shares the densities at the voxel centres when other volumes are built
    const bool needRho = (plan.densityGrid || (skyVolume && !dirs.empty())) && any;
    if (!dirs.empty() || needRho) {
        t0 = std::chrono::steady_clock::now();
        if (!dirs.empty()) {
            volumes = buildLightVolumes(field, dirs, plan.lightVolumeCell, g,
                                        needRho ? &rho : nullptr, cancel);
        } else {
            // the densities alone, on the grid's geometry: no density integral is needed
            volumes.push_back(densityGrid(field, plan.lightVolumeCell, g, rho, cancel));
        }
        stats.lightVolumeSeconds = secondsSince(t0);
        stats.lightVolumeLookups = volumes.front().densityLookups;
        stats.densityGridVoxels = rho.size();
        for (const LightVolume& v : volumes)
            if (!v.tau.empty()) {
                ++stats.lightVolumes;
                stats.lightVolumeVoxels += v.tau.size();
            }
    }
    const LightVolume* towardVolume = out.towardVolume();
    if (skyVolume) {
        t0 = std::chrono::steady_clock::now();
        out.sky = buildSkyVolume(field, plan.skyDirections, plan.lightVolumeCell, g,
                                 rho.empty() ? nullptr : &rho, cancel);
        out.hasSky = true;
        stats.skyVolumeSeconds = secondsSince(t0);
        stats.skyVolumeBytes = out.sky.bytes();
        stats.lightVolumeLookups += out.sky.densityLookups;
    }
    if (cancelRequested(cancel)) return out;
    const Medium medium = Medium::fromDesc(s.medium);
    // the photons' grid of their own (FramePlan::photonCell), its densities at its voxel
    // centres; the diffusion grid too where the plan puts the sky there. It covers the box of
    // the majorant cells with density, which holds every voxel photons record in: a small
    // cloud in wide bounds on fine voxels (daichi_smoke on a sixteenth of a cell) took 1.5 GB
    // over its bounds
    LightVolume own;
    std::vector<float> ownRho;
    if (photons && plan.photonsOwnGrid()) {
        const Box occupied =
            vs.grids[0].cellCount() ? vs.grids[0].occupiedBounds() : field.bounds();
        own = densityGridWithin(field, plan.photonCell, occupied, g, ownRho, cancel);
    }
    // photons first: with a hand-off they give the diffusion grid its source
    if (photons) {
        t0 = std::chrono::steady_clock::now();
        PhotonParams pp;
        pp.sigma_s = medium.sigma_s;
        pp.sigma_a = medium.sigma_a;
        pp.sunDirection = s.sun.direction;
        pp.sunIrradiance = plan.shadows ? s.sun.irradiance * s.render.msStrength : vec3(0.0f);
        pp.eye = s.camera.position;
        pp.photons = plan.photonCount;
        pp.maxDepth = s.render.maxDepth;
        pp.ownWalk = plan.photonOwnWalk;
        pp.similarAfter = plan.photonSimilarity;
        // march takes the sun's orders 2 .. secondDepth itself (plan.secondShare)
        if (plan.secondShare > 0.0f) pp.sunRecordFrom = plan.secondDepth;
        pp.seed = kern::pcg(frameSeedKey(s, plan) ^ kern::pcg(s.render.seed));
        if (plan.photonSky) pp.sky = s.sky;
        if (plan.photonBounces > 0 && diffusion) {
            // the higher orders go on in the diffusion grid (its source, below)
            pp.handOff = plan.photonBounces;
            pp.handOffGrid = &volumes.front();
        }
        if (s.render.photonSkin > 0.0f) {
            pp.sunTau = towardVolume;
            pp.skinK = s.render.photonSkin * maxComponent(pp.sigma_s + pp.sigma_a);
        }
        if (plan.photonsOwnGrid()) {
            out.photons = tracePhotons(vs, medium.phase, own, ownRho, pp, surfaces, cancel);
            out.photons.lookups += own.densityLookups;
            out.photons.bytes += double(ownRho.size() * sizeof(float));
        } else {
            out.photons =
                tracePhotons(vs, medium.phase, volumes.front(), rho, pp, surfaces, cancel);
        }
        out.hasPhotons = true;
        stats.photonSeconds = secondsSince(t0);
        stats.photonLookups = out.photons.lookups;
        stats.photonsTraced = out.photons.traced;
        stats.photonsFromSky = out.photons.skyTraced;
        stats.photonsHandedOff = out.photons.handedOff;
        stats.photonScatterings = out.photons.scatterings;
        stats.photonBytes = out.photons.bytes;
    }
    if (diffusion) {
        t0 = std::chrono::steady_clock::now();
        DiffusionParams dp = diffusionParams(s, plan, medium);
        dp.cancel = cancel;
        if (out.hasPhotons && !out.photons.source.empty()) dp.source = &out.photons.source;
        // the sky alone on a finer grid (FramePlan::diffusionCell; no sun source): the photons'
        // own, or one of its own where the photons' voxel is finer still
        if (plan.diffusionSharesPhotonGrid()) {
            out.diffusion = solveDiffusion(own, ownRho, {}, dp);
        } else if (plan.diffusionOnPhotonGrid()) {
            std::vector<float> skyRho;
            const LightVolume skyGrid = densityGrid(field, plan.diffusionCell, g, skyRho, cancel);
            out.diffusion = solveDiffusion(skyGrid, skyRho, {}, dp);
            out.diffusion.bytes += double(skyRho.size() * sizeof(float));
        } else {
            out.diffusion = solveDiffusion(
                volumes.front(), rho, towardVolume ? towardVolume->tau : std::vector<float>{}, dp);
        }
        out.hasDiffusion = true;
        stats.diffusionSeconds = secondsSince(t0);
        stats.diffusionIterations = out.diffusion.iterations;
        stats.diffusionResidual = out.diffusion.residual;
        stats.diffusionConverged = out.diffusion.converged;
        stats.diffusionBytes = out.diffusion.bytes;
    }
    return out;
}

MarchGrids Renderer::marchGrids(const FramePlan& plan, const FrameBindings& bindings,
                                RenderStats& stats, const std::atomic<bool>* cancel) {
    // in an arena of render.threads, as render() builds them
    const int threads =
        scene_.render.threads > 0 ? scene_.render.threads : tbb::task_arena::automatic;
    tbb::task_arena arena(threads);
    return arena.execute([&] {
        const VolumeSet vs = volumesFor(plan, bindings, stats, cancel);
        const SurfaceQuery* surfaces = bindings.geometry ? bindings.geometry->surfaces() : nullptr;
        std::unique_ptr<SdfSurfaces> solids = solidsOver(scene_, surfaces);
        if (solids) surfaces = solids.get();
        // for the GPU port, whose march does not take the sun's orders from the second itself:
        // the photons carry them (FramePlan::secondShare)
        FramePlan gpu = plan;
        gpu.secondShare = 0.0f;
        return buildMarchGrids(scene_, gpu, vs, surfaces, stats, cancel);
    });
}

bool Renderer::render(const FramePlan& plan, const FrameBindings& bindings, Framebuffer& fb,
                      RenderStats& stats, const RenderCallbacks& cb, MarchGrids* gridsOut) {
    if (plan.rebased && !rebasedCopy_) {
        // the frame far from the origin, rendered translated (core/rebase.h)
        Renderer near(rebasedScene(scene_, plan.renderOrigin));
        near.rebasedCopy_ = true;
        return near.render(plan, rebasedBindings(bindings, plan.renderOrigin), fb, stats, cb,
                           gridsOut);
    }
    const SceneDesc& s = scene_;
    const int threads = s.render.threads > 0 ? s.render.threads : tbb::task_arena::automatic;
    tbb::task_arena arena(threads);
    stats = RenderStats{};
    if (plan.msAuto) {
        stats.cloudDepth = plan.cloudTau; // (-1 when not measured)
        stats.absorptionDepth = plan.absorptionDepth;
    }
    bool completed = true;

    arena.execute([&] {
        VolumeSet vs = volumesFor(plan, bindings, stats, cb.cancel);
        // a cancel stops each stage early (its result incomplete) and skips the later ones
        auto cancelled = [&] { return cancelRequested(cb.cancel); };
        if (cancelled()) {
            completed = false;
            return;
        }
        const SurfaceQuery* surfaces = bindings.geometry ? bindings.geometry->surfaces() : nullptr;
        // SDF solids (core/sdf/solid.h): sphere traced here, over Embree's surfaces if any
        std::unique_ptr<SdfSurfaces> solids = solidsOver(s, surfaces);
        if (solids) surfaces = solids.get();
        MarchGrids grids = buildMarchGrids(s, plan, vs, surfaces, stats, cb.cancel);
        if (cancelled()) {
            completed = false;
            return;
        }
        const LightVolume* lv = plan.lightVolume ? grids.towardVolume() : nullptr;
        const LightVolume* gate = plan.gateVolume ? grids.towardVolume() : nullptr;
        const ScatterVolumes sv = grids.scatter();
        fb.resize(s.camera.width, s.camera.height, plan.aovs);
        stats.aovBytes = fb.aovBytes();
        const auto t0 = std::chrono::steady_clock::now();
        switch (s.render.integrator) {
        case Integrator::March:
            completed =
                renderTiles(MarchContext(s, plan, vs, lv, sv, surfaces, gate), s, fb, stats, cb);
            break;
        case Integrator::PathTrace:
            completed =
                renderTiles(PathContext(s, plan, vs, surfaces,
                                        plan.shadowRoulette ? grids.towardVolume() : nullptr),
                            s, fb, stats, cb);
            break;
        }
        stats.integrateSeconds = secondsSince(t0);
        if (gridsOut) *gridsOut = std::move(grids);
    });
    return completed;
}

namespace {

template <class Context>
bool renderTiles(const Context& ctx, const SceneDesc& s, Framebuffer& fb, RenderStats& stats,
                 const RenderCallbacks& cb) {
    const int ts = s.render.tileSize;
    const int tilesX = (fb.width + ts - 1) / ts, tilesY = (fb.height + ts - 1) / ts;
    const int tiles = tilesX * tilesY;
    std::atomic<std::uint64_t> rays{0}, prim{0}, shad{0}, second{0}, bad{0};
    std::atomic<int> done{0};
    std::mutex progressMutex;
    // per-thread working memory of the integrator, reused from tile to tile
    tbb::enumerable_thread_specific<typename Context::Scratch> scratch;

    tbb::parallel_for(
        tbb::blocked_range<int>(0, tiles, 1),
        [&](const tbb::blocked_range<int>& r) {
            for (int tile = r.begin(); tile != r.end(); ++tile) {
                if (cancelRequested(cb.cancel)) return;
                const int x0 = (tile % tilesX) * ts, y0 = (tile / tilesX) * ts;
                RayCounters cnt;
                typename Context::Scratch& local = scratch.local();
                for (int y = y0; y < std::min(y0 + ts, fb.height); ++y) {
                    if (cancelRequested(cb.cancel)) return; // a slow row: core/cancel.h
                    for (int x = x0; x < std::min(x0 + ts, fb.width); ++x)
                        ctx.renderPixel(x, y, fb, cnt, local);
                }
                rays += cnt.rays;
                prim += cnt.primarySamples;
                shad += cnt.shadowSamples;
                second += cnt.secondSamples;
                bad += cnt.nonFinite;
                const int d = ++done;
                if (cb.progress) {
                    std::lock_guard<std::mutex> lock(progressMutex);
                    cb.progress(d, tiles);
                }
            }
        },
        tbb::simple_partitioner());
    stats.rays = rays;
    stats.primarySamples = prim;
    stats.shadowSamples = shad;
    stats.secondSamples = second;
    stats.nonFinite = bad;
    return done.load() == tiles;
}

} // namespace

} // namespace nimbus
