/// @file pathtrace.h
/// @brief The `pathtrace` integrator: the unbiased reference against which `march` reports its
/// error.
///
/// Delta tracking (Woodcock) for real collisions over the majorant segments of majorant.h, driven
/// by a randomly chosen hero channel and combined over channels by spectral MIS (Miller et al.
/// 2019), so chromatic coefficients stay unbiased and low-variance under a max-channel majorant;
/// ratio tracking (Novák et al. 2014) for shadow rays; next-event estimation toward the sun (a
/// delta light) and the sky (uniform sphere sampling, combined with phase sampling by the balance
/// heuristic); multiple scattering to render.maxDepth with Russian roulette from render.rrDepth;
/// render.spp samples per pixel, each a counter-based random stream, so images are deterministic
/// per seed whatever the thread count. Structure after pbrt-v4's VolPathIntegrator (Pharr, Jakob &
/// Humphreys), which writes tracking once over a majorant iterator.
#pragma once

#include <cstdint>

#include "core/accel.h"
#include "core/camera.h"
#include "core/image.h"
#include "core/integrators/counters.h"
#include "core/lighting/light_volume.h"
#include "core/media/medium.h"
#include "core/plan.h"
#include "core/sampler.h"
#include "core/tracking/volumes.h"

namespace nimbus {

class PathContext {
  public:
    /// Per-thread working memory: the ray walk of every tracked ray, reused from ray to ray
    /// (no allocation per ray).
    struct Scratch {
        RayVolumes rv;
    };

    /// `sunDepth`: the density integral toward the sun over volume 0, in world space (the
    /// plan's shadow roulette, which it names for one untransformed volume only; null: every
    /// sun shadow ray is traced).
    PathContext(const SceneDesc& scene, const FramePlan& plan, const VolumeSet& volumes,
                const SurfaceQuery* surfaces = nullptr, const LightVolume* sunDepth = nullptr);
    void renderPixel(int x, int y, Framebuffer& fb, RayCounters& cnt, Scratch& scratch) const;

    /// Ratio-tracking estimate of the transmittance from p along d up to tmax (volumes only).
    vec3 transmittance(vec3 p, vec3 d, Sampler& rng, RayCounters& cnt, Scratch& scratch,
                       float tmax = 3.4e38f) const;
    /// Transmittance toward a light: 0 when a surface blocks the way, else ratio tracking.
    vec3 visibility(vec3 p, vec3 d, Sampler& rng, RayCounters& cnt, Scratch& scratch) const;

    /// One path from the camera through pixel position (px, py); returns radiance, the
    /// ratio-tracked transmittance of the camera ray in T and the sample's alpha.
    vec3 tracePath(const Ray& cameraRay, Sampler& rng, vec3& T, float& alpha, float& depth,
                   RayCounters& cnt, Scratch& scratch) const;

  private:
    enum class Event { Escaped, Scattered, Absorbed };
    /// Tentative collisions along the ray within the volumes up to tmax (core/tracking/
    /// tracking.h): visit(t, density, sigma_maj) returns false to stop. Returns true when the ray
    /// left the field.
    template <class F>
    bool sampleCollisions(const Ray& ray, float tmax, Sampler& rng, RayVolumes& rv,
                          F&& visit) const;
    /// Delta tracking from ray.o along ray.d driven by channel `hero`; multiplies the path
    /// throughput f and the per-channel path pdf p by the events taken. On Scattered, t is the
    /// collision distance.
    /// The probability of tracing the sun's shadow ray from p: 1 where the sun-depth volume
    /// (read a voxel closer to the sun) leaves a transmittance of 0.1 or more; below, in
    /// proportion to it, never under kMinShadowProbability.
    float sunShadowProbability(vec3 p) const;
    /// A direction toward the sun: its centre for a point sun, else uniform in the solid angle
    /// of its disc (multiply what it lights by sunWeight_).
    vec3 sunDirection(Sampler& rng) const;
    Event track(const Ray& ray, float tmax, Sampler& rng, int hero, vec3& f, vec3& p, float& t,
                RayCounters& cnt, Scratch& scratch) const;

    const SceneDesc& s_;
    const FramePlan& plan_;
    const VolumeSet& vols_;
    const SurfaceQuery* surfaces_;
    Camera camera_;
    Medium medium_;
    const LightVolume* sunDepth_;
    float sigmaTMin_; ///< smallest channel of sigma_t
    /// cos of the sun disc's angular radius (1: a point sun), and the irradiance weight of a
    /// direction sampled in it: (solid angle) / (pi sin^2 alpha) = 2 / (1 + cos alpha), so that
    /// a surface facing the sun receives exactly the sun's irradiance
    float sunCosMax_ = 1.0f;
    float sunWeight_ = 1.0f;
    std::uint32_t frameKey_;
};

} // namespace nimbus
