/// @file sky_volume.h
/// @brief Single-scattered sky light for `march` (render.sky_scattering = "single"): the
/// integral, its two estimators, and the precomputed volume of the second.
///
/// The sky light scattered once toward the camera at a point x of a ray of direction d is
///
///     S_sky(x) = integral over the sphere of L_sky(w) p(d . w) T(x, w) dw,
///
/// T(x, w) = exp(-sigma_t tau(x, w)) the transmittance from x out of the volume along w.
/// pathtrace with render.max_depth = 1 computes the same integral without approximation
/// (tests/test_march_sky.cpp compares them).
///
/// - render.sky_shadow = "march" (MarchContext::skySingleScatterMarched): at every sample, K
///   directions drawn from the phase function around d, stratified (a 2D Fibonacci lattice,
///   fibonacciPoint in core/kernels/lighting.glsl, shifted at random per sample), each with a
///   shadow march: S = 1/K sum_k L_sky(w_k) T(x, w_k) (eval / pdf = 1). Unbiased; its noise
///   falls as 1 / sqrt(K) and averages over the samples of a ray.
/// - render.sky_shadow = "volume" (this file): K fixed directions w_k of a Fibonacci lattice on
///   the sphere (equal areas, fibonacciDirection), and
///
///       S = sum_k W_k(d) exp(-sigma_t tau_k(x)),
///       W_k(d) = L_sky(w_k) p(d . w_k) / sum_j p(d . w_j),
///
///   the phase weights normalised per channel so that an unoccluded uniform sky returns exactly
///   its radiance (the lattice alone integrates a forward-peaked phase function with an error
///   that depends on how d falls between the directions). W_k depends on the ray only (once
///   per camera ray); tau_k(x) is read trilinearly from this volume, where each voxel holds the
///   K density integrals side by side. Each tau_k is propagated slice by slice along w_k from
///   the densities at the voxel centres (propagateDensityIntegral, light_volume.h, after
///   Fizimayer 2008). No noise, but the trilinear tau blurs the cloud's skin, which is where
///   single-scattered light comes from: the error grows with the voxel against the mean free
///   path (a box: 3.4% at 0.15 of it, 48% at 1.2; docs/accuracy.md). Surfaces do not occlude
///   these directions.
#pragma once

#include <cstddef>
#include <vector>

#include "core/fields/field.h"
#include "core/tracking/majorant.h"

namespace nimbus {

/// Directions a sky volume may hold at most (the per-ray weights live on the stack).
constexpr int kMaxSkyDirections = 256;

struct SkyVolume {
    Box bounds;
    ivec3 res{0};
    vec3 voxel{0.0f};
    std::vector<vec3> directions; ///< unit vectors toward the sky, w_k
    /// density integral toward each direction at the voxel centres: directions.size() values
    /// per voxel side by side, voxels x fastest
    std::vector<float> tau;
    std::size_t densityLookups = 0;

    int count() const { return int(directions.size()); }
    std::size_t bytes() const { return tau.size() * sizeof(float); }
    /// Trilinear lookup (clamped to the outermost centres, as LightVolume::sample) of the K
    /// density integrals at world point p into out[0, K).
    void sample(vec3 p, float* out) const;
};

/// Builds the volume over field.bounds() with voxels of about `cell` world units and `count`
/// directions (fibonacciDirection). `rho`, when given, holds the densities at the voxel centres
/// of that grid (shared with the light volumes built from the same cell); otherwise they are
/// looked up here, skipping cells the majorant grid (if given) proves empty. TBB-parallel.
/// Stops early (incomplete) once `cancel` is set.
SkyVolume buildSkyVolume(const Field& field, int count, float cell,
                         const MajorantGrid* grid = nullptr,
                         const std::vector<float>* rho = nullptr,
                         const std::atomic<bool>* cancel = nullptr);

} // namespace nimbus
