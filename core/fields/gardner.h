/// @file gardner.h
/// @brief Clouds of Gardner's textured ellipsoids (Gardner 1985, "Visual simulation of clouds";
/// Elinas & Stuerzlinger 2000, "Real-time rendering of 3D clouds"), evaluated in 3D as a density
/// field: the math is core/kernels/gardner.glsl; this holds the ellipsoids, builds the scattered
/// cumulus and bounds the density per box (0 for boxes that touch no ellipsoid, so the majorant
/// grid skips the space between them).
///
/// Where ellipsoids overlap the field takes the larger of their densities (a union: the cloud
/// is no denser where two ellipsoids meet than inside either).
#pragma once

#include <memory>
#include <vector>

#include "core/kernels/kernels.h"
#include "core/scene.h"

namespace nimbus {

/// One ellipsoid with every parameter resolved (the cloud's defaults filled in).
struct GardnerEllipsoidSpec {
    vec3 center{0.0f};
    vec3 radii{1.0f};
    vec3 rotate{0.0f}; ///< degrees about x, then y, then z (R = Rz Ry Rx)
    GardnerShapeDesc shape;
};

/// The ellipsoids of a cloud: the listed ones with the cloud's defaults filled in, then, when
/// the scatter is enabled, the scattered cumulus (gardnerScatter).
std::vector<GardnerEllipsoidSpec> gardnerEllipsoids(const GardnerDesc& d);

/// A cumulus of `count` ellipsoids, deterministic per seed: about a fifth large flattened body
/// ellipsoids standing on the flat base at `center`, a sixth wide flat ones along the base, and
/// the rest smaller ellipsoids heaped on top and on the sides of earlier ones (each on the
/// upper part of a parent's surface, 0.45-0.7 of its size), all inside the box of `extent`
/// above `center`. The texture's offset is moved by a seed-dependent amount, so two seeds give
/// two textures.
std::vector<GardnerEllipsoidSpec> gardnerScatter(const GardnerScatterDesc& s,
                                                 const GardnerShapeDesc& shape);

/// The world box of one ellipsoid.
Box gardnerEllipsoidBox(const GardnerEllipsoidSpec& e);
/// The kernel form of one ellipsoid (its local-from-world rows) and of its texture.
kern::GardnerEllipsoid gardnerKernelEllipsoid(const GardnerEllipsoidSpec& e);
kern::GardnerTexture gardnerKernelTexture(const GardnerTextureDesc& t);

/// The ellipsoids of a cloud, ready to evaluate.
struct GardnerCloud {
    std::vector<kern::GardnerEllipsoid> ellipsoids;
    std::vector<Box> boxes;                     ///< world box of each ellipsoid
    std::vector<int> textureOf;                 ///< per ellipsoid: index into textures
    std::vector<kern::GardnerTexture> textures; ///< the distinct textures
    Box bounds;                                 ///< union of the boxes
};

std::shared_ptr<const GardnerCloud> makeGardnerCloud(const std::vector<GardnerEllipsoidSpec>& e);
/// The union of the ellipsoids' boxes (empty box without ellipsoids).
Box gardnerBounds(const GardnerDesc& d);

struct GardnerField {
    std::shared_ptr<const GardnerCloud> cloud;

    /// The largest density of the ellipsoids holding p (0 outside all of them).
    float density(vec3 p) const;
    /// Upper bound of the density over the box b: the largest bound of the ellipsoids whose
    /// boxes meet it (gardnerEllipsoidBound with the texture's bound over b); 0 when none does.
    float majorant(const Box& b) const;
};

} // namespace nimbus
