/// @file march.h
/// @brief The `march` integrator (version 1): single-scattering ray marching over majorant
/// segments with shadow marches toward the sun.
///
/// Per camera ray: jittered samples on a step schedule (fixed, or growing with distance),
/// only inside non-empty majorant segments; at each sample the sun's transmittance from a
/// shadow march (Beer-Lambert), the medium's phase function (core/media/phase.h), the Olajos
/// in-scatter or Schneider beer-powder term, and sky ambient; Hillaire's energy-conserving step
/// integration; early exit when transmittance < epsilon. Olajos 2016 ch. 3; Hillaire 2016;
/// Schneider 2015.
///
/// Multiple scattering: Wrenninge's octaves (the short-range, forward part along the shadow
/// ray) and, with render.multiple_scattering = "grid", the fluence of the light scattered at
/// least once from a diffusion solve per frame (core/lighting/diffusion.h; Stam 1995), which also
/// carries all of the sky light: its P1 radiance (phi + 3 g F.w) / 4 pi is the in-scattered
/// radiance. Without the grid, the sky enters as an ambient term, occluded by height (v1) or by the
/// normalised openness of the vertical column (render.sky_occlusion = "column"), or scattered
/// once (render.sky_scattering = "single": core/lighting/sky_volume.h).
#pragma once

#include <cstdint>
#include <vector>

#include "core/accel.h"
#include "core/camera.h"
#include "core/image.h"
#include "core/integrators/counters.h"
#include "core/lighting/light_volume.h"
#include "core/media/medium.h"
#include "core/media/sky.h"
#include "core/plan.h"
#include "core/tracking/step_schedule.h"
#include "core/tracking/volumes.h"

namespace nimbus {

struct DiffusionVolume; // core/lighting/diffusion.h
struct PhotonVolume;    // core/lighting/photons.h
struct SkyVolume;       // core/lighting/sky_volume.h

/// What march's multiple-scattering and sky terms read (null when unused): the density
/// integrals straight up and straight down (the vertical column above and below a sample) and
/// the diffusion solve.
struct ScatterVolumes {
    const LightVolume* up = nullptr;
    const LightVolume* down = nullptr;
    const DiffusionVolume* diffusion = nullptr; ///< sun and sky multiple scattering
    const PhotonVolume* photons = nullptr;      ///< the sun's multiple scattering (photons)
    const SkyVolume* sky = nullptr;             ///< the sky scattered once
};

/// Everything a pixel needs, precomputed once per frame.
class MarchContext {
  public:
    /// Share of the sky ambient left at the base of the layer (below, the ground is seen).
    static constexpr float kAmbientGround = 0.3f;

    /// Per-thread working memory: the ray walks of a camera ray and of its shadow rays, reused
    /// from pixel to pixel (no allocation per ray).
    struct Scratch {
        RayVolumes primary, shadow;
        std::vector<vec3> skyWeights; ///< the single-scattered sky's W_k of the current ray
    };

    MarchContext(const SceneDesc& scene, const FramePlan& plan, const VolumeSet& volumes,
                 const LightVolume* lightVolume = nullptr, ScatterVolumes scatter = {},
                 const SurfaceQuery* surfaces = nullptr, const LightVolume* gateVolume = nullptr);
    void renderPixel(int x, int y, Framebuffer& fb, RayCounters& cnt, Scratch& scratch) const;

    /// What one camera ray returns: radiance, transmittance, alpha and depth (0: none).
    struct Sample {
        vec3 L, T;
        float alpha, depth;
    };
    /// Marches one camera ray; `key` seeds its shadow rays, `jitter` places its samples.
    Sample traceRay(const Ray& ray, std::uint32_t key, float jitter, RayCounters& cnt,
                    Scratch& scratch) const;

    /// Density integral along the ray from p toward direction w (shadow march), stopped once
    /// the transmittance is below 1e-5 in every channel. `rhoP`: the density at p where the
    /// caller knows it (render.step_tau's test of the first step looks at it), else negative.
    /// With `tStop`, the march also stops where the integral reaches `stopAt` (the density
    /// taken constant over the step or sub-step it falls in) and stores the distance from p
    /// there; `tStop` is left as it was where the integral stays below `stopAt`.
    float densityIntegral(vec3 p, vec3 w, std::uint32_t rng, RayCounters& cnt, RayVolumes& rv,
                          float rhoP = -1.0f, float stopAt = -1.0f, float* tStop = nullptr) const;
    /// The sun's light scattered 2 to plan.secondDepth times, in-scattered at p toward a camera
    /// ray of direction d: one path's estimate (unbiased for the march's density integral), per
    /// unit phase-normalised scattering (render.photon_second_share, photon_march_depth)
    vec3 secondSun(vec3 p, vec3 d, std::uint32_t rng, RayCounters& cnt, RayVolumes& rv) const;
    /// Density integral along the ray from p toward the sun (shadow march).
    float sunDensityIntegral(vec3 p, std::uint32_t rng, RayCounters& cnt, RayVolumes& rv,
                             float rhoP = -1.0f) const;
    /// Density integral toward the sun from p: light volume or shadow march; infinite when a
    /// surface blocks the sun.
    float sunOpticalDepth(vec3 p, std::uint32_t rng, RayCounters& cnt, RayVolumes& rv,
                          float rhoP = -1.0f) const;
    /// Radiance leaving a diffuse surface toward the camera.
    vec3 surfaceRadiance(const Ray& ray, const SurfaceHit& hit, std::uint32_t rng, RayCounters& cnt,
                         RayVolumes& rv) const;
    /// In-scattered sky radiance at p (isotropic) by the render.sky_occlusion model.
    vec3 skyInScatter(vec3 p) const;
    /// The weights W_k(d) of the single-scattered sky for a ray of direction d (sky_volume.h):
    /// the sky radiance toward each direction times the phase function, normalised per channel.
    void skyWeights(vec3 d, vec3* W) const;
    /// The single-scattered sky at p for the weights of its ray (fixed directions, volume).
    vec3 skySingleScatter(vec3 p, const vec3* W) const;
    /// The single-scattered sky at p seen along direction d, a shadow march toward each of the
    /// directions turned by a random rotation drawn from `rng`.
    vec3 skySingleScatterMarched(vec3 p, vec3 d, std::uint32_t rng, RayCounters& cnt,
                                 RayVolumes& rv, float rhoP = -1.0f) const;

  private:
    /// The density bound render.step_tau's test takes for a camera ray's step of length dt
    /// sampled at t (at the fraction `jitter` of it): the largest majorant-grid cell bound at
    /// its ends and its sample (RayVolumes::cellMajorant; 0 where no grid is built).
    float stepMajorant(RayVolumes& rv, float t, float dt, float jitter) const;

    const SceneDesc& s_;
    const FramePlan& plan_;
    const VolumeSet& vols_;
    const LightVolume* lightVolume_; ///< when set, replaces the shadow marches
    /// when set (plan.gateVolume), the octave gate's line integral is read from it
    const LightVolume* gateVolume_;
    ScatterVolumes volumes_;       ///< multiple-scattering and sky-occlusion grids
    const SurfaceQuery* surfaces_; ///< null: no surfaces
    SkyIrradiance skyIrradiance_;
    Camera camera_;
    Medium medium_;
    StepSchedule primary_, shadow_;
    SkyMeans sky_; ///< mean sky radiance over the sphere and hemispheres, x ambient
    /// sigma_t - f sigma_s: the extinction of the sun's and the camera's beams with the forward
    /// peak kept in them (f = plan.forwardFraction; sigma_t when it is 0)
    vec3 sigmaTForward_;
    float sigmaTMax_;  ///< the medium's largest extinction per unit density (render.step_tau)
    float sigmaTMean_; ///< its mean over the channels (where a step's light is looked at)
    std::vector<vec3> skyDirs_; ///< single-scattered sky: the directions (fibonacciDirection)
    std::vector<vec3> skyL_;    ///< the sky radiance toward each of them, x ambient
    vec3 kappa_; ///< diffusion decay per transport optical depth, sqrt(3 (1 - albedo'))
    std::uint32_t frameKey_;
};

} // namespace nimbus
