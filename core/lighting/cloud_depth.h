/// @file cloud_depth.h
/// @brief How thick a cloud is along a direction, measured once per frame for the plan
/// (render.multiple_scattering = "auto" chooses its model from it; core/plan.cpp).
///
/// Parallel rays along the direction cover the projection of the field's bounds on a square
/// lattice; each integrates the density at midpoints of equal steps. The figures are those of
/// the rays that meet density: their mean optical depth (the validation matrix's "thickness",
/// docs/accuracy.md, taken along the sun instead of the camera's rays) and the volume their
/// occupied steps cover.
#pragma once

#include <cstddef>

#include "core/fields/field.h"

namespace nimbus {

struct CloudDepth {
    double meanTau = 0.0;        ///< sigma_t x density integral, mean over the rays that hit
    double occupiedVolume = 0.0; ///< world volume of the steps with density > 0
    /// sigma_t x the mean density of the steps with density > 0 (over the rays that hit)
    double meanExtinction = 0.0;
    int rays = 0;            ///< rays cast
    int hits = 0;            ///< of those, rays that met density
    std::size_t lookups = 0; ///< density lookups made
    /// the box of the samples with density, each grown by half the larger of the lattice's
    /// spacing and the step, within the bounds measured (empty when no ray hit)
    Box occupiedBox;
    double hitFraction() const { return rays > 0 ? double(hits) / rays : 0.0; }
};

/// The density integral of `field` along `ray` from t0 to t1 by the midpoint rule, in
/// n = clamp(ceil((t1 - t0) / step), 1, maxSteps) equal steps of dt: sum x dt, and the length of
/// the steps whose sample holds density (occupied x dt). Shared by measureCloudDepth and the
/// validation matrix's thickness (plugin/cli/suite.cpp).
struct RayDensity {
    double sum = 0.0; ///< the densities at the steps' midpoints, added up
    int occupied = 0; ///< steps whose midpoint has density > 0
    int steps = 0;    ///< n
    int first = -1;   ///< the first step whose midpoint has density (-1: none)
    int last = -1;    ///< the last one
    double dt = 0.0;  ///< the step's length
    double integral() const { return sum * dt; }
    double occupiedLength() const { return occupied * dt; }
};
RayDensity integrateDensity(const Field& field, const Ray& ray, float t0, float t1, double step,
                            int maxSteps);

/// Measures `field` over `bounds` along `direction` (any length but 0) with `raysPerSide`^2
/// rays and steps of `step` world units, at most `maxSteps` per ray (longer rays take
/// longer steps); `sigmaT` is the extinction per unit density. TBB-parallel; the result does
/// not depend on the thread count.
CloudDepth measureCloudDepth(const Field& field, const Box& bounds, vec3 direction, float sigmaT,
                             float step, int raysPerSide = 32, int maxSteps = 256);

} // namespace nimbus
