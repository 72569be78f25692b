/// @file photons.h
/// @brief The sun's multiply scattered light for `march`, by tracing photons: once per frame,
/// photons leave the sun, are tracked through the real density field (delta tracking on the
/// majorant segments, the same machinery as pathtrace) and scatter by the phase function until
/// they leave the volume; everything they travel after their first scattering is recorded on a
/// voxel grid as the light scattered toward the camera.
///
/// Estimator (track length by null collisions): along a photon's path the tentative collisions
/// of delta tracking fall at rate sigma_maj, so summing w / sigma_maj at each of them estimates
/// the path's length through a voxel. A voxel thus collects
///   S(x) = 1/V sum_i Phi w_i p(omega_i . omega_cam) / sigma_maj,i,
/// the cell average of the in-scattered radiance int p(omega . omega_o) L_ms(x, omega) d omega
/// of the light that has scattered at least once, omega_o the direction from the voxel centre to
/// the camera (fixed per voxel: the camera is far from most voxels, and a voxel sees it under a
/// small angle). Phi = E_sun A / N is each photon's flux through the sun-facing area A of the
/// bounds. No spherical-harmonic truncation: the phase function is evaluated exactly, so forward
/// peaks and the Mie table's features are kept. The first scattering is left to march, which
/// integrates single scattering exactly; march adds sigma_s rho S(x) to it.
///
/// Sums are kept in 64-bit fixed point per thread and added in any order to the same result:
/// the volume, and the frame, are bit-identical for a seed whatever the thread count.
#pragma once

#include <cstdint>
#include <vector>

#include "core/accel.h"
#include "core/geometry.h"
#include "core/light_volume.h"
#include "core/phase.h"
#include "core/volumes.h"

namespace nimbus {

struct PhotonParams {
    vec3 sigma_s{1.0f}, sigma_a{0.0f}; ///< per unit density, density scale folded in
    vec3 sunDirection{0.0f, 1.0f, 0.0f};
    vec3 sunIrradiance{0.0f};
    vec3 eye{0.0f};           ///< camera position
    std::int64_t photons = 0; ///< photons leaving the sun
    int maxDepth = 256;       ///< scattering events per photon at most (pathtrace's max_depth)
    std::uint32_t seed = 0;
};

struct PhotonVolume {
    Box bounds;
    ivec3 res{0};
    vec3 voxel{0.0f};
    /// In-scattered radiance toward the camera per unit phase-normalised scattering, at voxel
    /// centres (voxels without density: the mean of their recorded neighbours)
    std::vector<vec3> radiance;
    std::uint64_t lookups = 0; ///< density lookups spent (filling its density grid, tracking)

    /// Trilinear lookup at world point p.
    vec3 sample(vec3 p) const;
};

/// Traces p.photons photons through `volumes` (one untransformed volume: its grid is `geometry`,
/// the light-volume grid, with densities rho at its voxel centres, which mark the voxels that
/// record). Surfaces (may be null) stop photons. Returns early (volume left partial) when
/// `cancel` becomes true.
PhotonVolume tracePhotons(const VolumeSet& volumes, const PhaseFunction& phase,
                          const LightVolume& geometry, const std::vector<float>& rho,
                          const PhotonParams& p, const SurfaceQuery* surfaces = nullptr,
                          const std::atomic<bool>* cancel = nullptr);

} // namespace nimbus
