/// @file march.h
/// @brief The `march` integrator (version 1): single-scattering ray marching over majorant
/// segments with shadow marches toward the sun.
///
/// Per camera ray: jittered samples on a step schedule (fixed, or growing with distance),
/// only inside non-empty majorant segments; at each sample the sun's transmittance from a
/// shadow march (Beer-Lambert), the medium's phase function (core/phase.h), the Olajos in-scatter
/// or Schneider beer-powder term, and sky ambient; Hillaire's energy-conserving step integration;
/// early exit when transmittance < epsilon. Olajos 2016 ch. 3; Hillaire 2016; Schneider 2015.
///
/// Multiple scattering: Wrenninge's octaves (the short-range, forward part along the shadow
/// ray) and, with render.multiple_scattering = "grid", the fluence of the light scattered at
/// least once from a diffusion solve per frame (core/diffusion.h; Stam 1995), which also carries
/// all of the sky light: its P1 radiance (phi + 3 g F.w) / 4 pi is the in-scattered radiance.
/// Without the grid, the sky enters as an ambient term, occluded by height (v1) or by the
/// normalised openness of the vertical column (render.sky_occlusion = "column").
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/camera.h"
#include "core/image.h"
#include "core/light_volume.h"
#include "core/majorant.h"
#include "core/phase.h"
#include "core/render.h"
#include "core/sky.h"
#include "core/volumes.h"

namespace nimbus {

/// Sample positions along a ray as a function of a continuous step coordinate u: samples sit
/// at u = n + jitter. Fixed steps of dt0 up to distance tg = ceil(1 / growth) dt0, then steps that
/// grow geometrically (dt ~ growth * t). Closed form in both directions, so skipping a stretch of
/// empty space lands on exactly the samples a full march would have taken.
struct StepSchedule {
    double dt0 = 1.0, growth = 0.0, tg = 0.0, logG = 0.0;

    StepSchedule(double step, double grow) : dt0(step), growth(grow) {
        if (growth > 0.0) {
            // start growing at a whole step index, where growth * t >= dt0 already holds
            tg = std::ceil(1.0 / growth) * dt0;
            logG = std::log1p(growth);
        }
    }
    double u(double t) const {
        if (growth <= 0.0 || t <= tg) return t / dt0;
        return tg / dt0 + std::log(t / tg) / logG;
    }
    double t(double u) const {
        const double ug = growth > 0.0 ? tg / dt0 : 0.0;
        if (growth <= 0.0 || u <= ug) return u * dt0;
        return tg * std::exp((u - ug) * logG);
    }
};

/// Marches the non-empty majorant segments of a ray (written once, used by camera and shadow
/// rays). Step n covers [t(n), t(n+1)] clipped to [tIn, tOut], the ray's span inside the field;
/// its sample sits at the fraction `jitter` of the clipped step and is visited only if it lies
/// in a non-empty segment, so skipping changes no sample that can see density. The callback
/// gets (t, dt, n) and returns false to stop.
template <class Segments, class F>
void marchSegments(Segments& it, const StepSchedule& sched, double tIn, double tOut, float jitter,
                   F&& visit) {
    MajorantSegment seg;
    std::int64_t nNext = 0;
    while (it.next(seg)) {
        for (std::int64_t n = std::max(nNext, std::int64_t(std::floor(sched.u(seg.t0))));; ++n) {
            const double tA = std::max(sched.t(double(n)), tIn);
            const double tB = std::min(sched.t(double(n + 1)), tOut);
            if (tB <= tA) {
                if (tA >= tOut) return;
                continue;
            }
            const float ts = float(tA + double(jitter) * (tB - tA));
            if (ts < seg.t0) {
                nNext = n + 1;
                continue;
            }
            if (ts >= seg.t1) break;
            nNext = n + 1;
            if (!visit(ts, float(tB - tA), n)) return;
        }
    }
}

struct MarchCounters {
    std::uint64_t rays = 0, primarySamples = 0, shadowSamples = 0, nonFinite = 0;
};

/// Everything a pixel needs, precomputed once per frame.
class MarchContext {
  public:
    /// Share of the sky ambient left at the base of the layer (below, the ground is seen).
    static constexpr float kAmbientGround = 0.3f;

    MarchContext(const SceneDesc& scene, const FramePlan& plan, const VolumeSet& volumes,
                 const LightVolume* lightVolume = nullptr, ScatterVolumes scatter = {},
                 const SurfaceQuery* surfaces = nullptr);
    void renderPixel(int x, int y, Framebuffer& fb, MarchCounters& cnt) const;

    /// Density integral along the ray from p toward the sun (shadow march).
    float sunDensityIntegral(vec3 p, std::uint32_t rng, MarchCounters& cnt) const;
    /// Density integral toward the sun from p: light volume or shadow march; infinite when a
    /// surface blocks the sun.
    float sunOpticalDepth(vec3 p, std::uint32_t rng, MarchCounters& cnt) const;
    /// Radiance leaving a diffuse surface toward the camera.
    vec3 surfaceRadiance(const Ray& ray, const SurfaceHit& hit, std::uint32_t rng,
                         MarchCounters& cnt) const;
    /// Olajos in-scatter or Schneider powder multiplier on the sun term.
    float inScatterFactor(float rho, float tau) const;
    /// Sky radiance seen along direction d.
    vec3 skyRadiance(vec3 d) const;
    /// In-scattered sky radiance at p (isotropic) by the render.sky_occlusion model.
    vec3 skyInScatter(vec3 p) const;

  private:
    const SceneDesc& s_;
    const FramePlan& plan_;
    const VolumeSet& vols_;
    const LightVolume* lightVolume_; ///< when set, replaces the shadow marches
    ScatterVolumes volumes_;         ///< multiple-scattering and sky-occlusion grids
    const SurfaceQuery* surfaces_;   ///< null: no surfaces
    SkyIrradiance skyIrradiance_;
    Camera camera_;
    PhaseFunction phase_;
    StepSchedule primary_, shadow_;
    vec3 sigmaS_, sigmaT_; ///< per unit density, density scale folded in
    vec3 ambient_;         ///< sky ambient radiance at the top of the layer
    vec3 skyUp_, skyDown_; ///< mean sky radiance over the upper / lower hemisphere, x ambient
    float g_;              ///< mean cosine of the phase function
    vec3 sigmaTr_;         ///< transport extinction sigma_a + sigma_s (1 - g) per unit density
    vec3 kappa_;           ///< diffusion decay per transport optical depth, sqrt(3 (1 - albedo'))
    std::uint32_t frameKey_;
};

} // namespace nimbus
