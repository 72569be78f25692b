/// @file sdf_cloud.h
/// @brief A cloud sculpted from signed distance functions (Thomann 2020, ch. 3-4): an SdfTree
/// (core/sdf/sdf.h) whose distance d gives the density
///   density(p) = scale * sdfDensityFromDistance(d(p), w) = scale * smoothstep(0, w, -d(p)),
/// 0 outside the surface, `scale` deeper inside than the falloff width w, a smoothstep between.
/// The noise displacement of the tree erodes the surface.
///
/// Bounds: d(p) >= bound(p) - A (A the tree's displacementBound) and bound is 1-Lipschitz, so
/// over a ball of radius r about p, d >= bound(p) - r - A, and since the density does not
/// increase with d, density <= scale * sdfDensityFromDistance(bound(p) - r - A, w). That is
/// majorantBall(); majorant(box) takes the ball around the box (centre, half-diagonal), so a box
/// farther than A from every surface gets 0. The empty space before the support (d < 0) is
/// skipped by sphere tracing with the same bound (core/tracking/majorant.h, traced segments).
#pragma once

#include <memory>

#include "core/scene.h"

namespace nimbus {

struct SdfCloudField {
    std::shared_ptr<const SdfTree> tree;
    float scale = 1.0f;   ///< density deep inside
    float falloff = 0.0f; ///< w, world units
    float margin = 0.0f;  ///< subtracted from every bound: float rounding of the tree's values

    float density(vec3 p) const;
    /// Upper bound of the density over the ball of radius r about p, given bound(p) = u.
    float majorantBall(float u, float r) const;
    float majorant(const Box& b) const;
    /// Sphere-tracing step from p: every q closer than this has density 0 (<= 0: none).
    float skip(vec3 p, float& u) const;
};

/// The field of an SDF description and its bounds (the support box of the tree at level 0,
/// empty when the tree is empty). Throws std::invalid_argument for a tree flattenSdf refuses or
/// an unbounded support (a plane not intersected away).
SdfCloudField makeSdfCloudField(const SdfFieldDesc& desc, Box& bounds);
/// The bounds makeSdfCloudField would give; an empty box where it would throw.
Box sdfCloudBounds(const SdfFieldDesc& desc);

} // namespace nimbus
