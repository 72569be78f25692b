/// @file solid.h
/// @brief Opaque SDF solids as a SurfaceQuery (Thomann 2020, ch. 3): sphere tracing with the
/// "traditional" bisection refinement of the hit, tetrahedral normals, soft sun shadows from the
/// penumbra estimate k h / t (or Quilez's improved variant) and ambient occlusion from the
/// distance field. Implemented in core/ (no Embree): a scene with only solids never starts it;
/// with Embree's surfaces (ground, meshes) both are combined here.
///
/// Sphere tracing: from t, step by max(skip(p), stepScale * distance(p)) where skip is a step
/// that provably never passes the surface (for a 1-Lipschitz field the distance itself; for a
/// displaced SDF tree the undisplaced bound minus the displacement amplitude). A sample with
/// distance < hitEpsilon * max(1, t) ends the march; a sample with a negative distance (a step
/// past the surface: only possible with stepScale * distance > skip) is bracketed with the
/// previous one. Either way the bracket [t_out, t_in] (distance > 0 at t_out, <= 0 at t_in) is
/// refined by bisection to 1e-3 hitEpsilon, and the hit is the outside end (the surface never lies
/// before it on the ray, so a shading point there is never inside the solid).
///
/// @code
///   SdfSolid s;
///   s.distance = [](vec3 p) { return glm::length(p) - 1.0f; };
///   SdfSurfaces surfaces({s}, nullptr);
///   SurfaceHit hit;
///   surfaces.intersect(Ray{vec3(0, 0, -5), vec3(0, 0, 1)}, 0.0f, 1e30f, hit); // hit.t = 4
/// @endcode
#pragma once

#include <functional>
#include <vector>

#include "core/accel.h"
#include "core/sdf/sdf.h"

namespace nimbus {

enum class Penumbra { Classic, Improved }; ///< sdfPenumbraClassic / sdfPenumbraImproved

/// How a solid is shaded (scene-file rows in plugin/io/scene/params_solid.cpp).
struct SolidShading {
    vec3 albedo{0.5f};
    float softness = 16.0f; ///< k of the penumbra estimate k h / t; 0: hard shadows
    Penumbra penumbra = Penumbra::Classic;
    int aoSamples = 5;   ///< 0: no ambient occlusion
    float aoStep = 0.2f; ///< spacing of the samples along the normal (scene units)
    float aoStrength = 1.0f;
    float stepScale = 1.0f;   ///< sphere-tracing step as a fraction of the distance (<= 1)
    float maxDistance = 1e5f; ///< rays and shadow rays stop after this far
    int maxSteps = 512;       ///< a ray with more steps counts as a miss
};

/// One solid: its distance function and shading.
struct SdfSolid {
    std::function<float(vec3)> distance; ///< signed distance (or a bound of it)
    std::function<float(vec3)> skip;     ///< safe step; empty: the distance
    Box box{vec3(-1e30f), vec3(1e30f)};  ///< holds the solid's surface (may be unbounded)
    SolidShading shading;
};

/// A solid from a tree of SDF nodes: its distance, the safe step of a displaced tree
/// (SdfTree::skipDistance) and its support box (solid_tree.cpp). Throws std::invalid_argument
/// as flattenSdf does.
SdfSolid solidFromTree(const SdfNodeDesc& root, const SolidShading& shading);

/// The solids (and optionally Embree's surfaces, @p other) as one SurfaceQuery.
class SdfSurfaces : public SurfaceQuery {
  public:
    SdfSurfaces(std::vector<SdfSolid> solids, const SurfaceQuery* other);

    bool intersect(const Ray& ray, float tmin, float tmax, SurfaceHit& hit) const override;
    bool occluded(const Ray& ray, float tmin, float tmax) const override;
    /// The smallest penumbra estimate of the solids times the other surfaces' visibility.
    float sunVisibility(const Ray& ray, float tmin, float tmax) const override;

    // --- the pieces, per solid (tests, measurements)
    /// Sphere-traces solid @p i: the first t in (tmin, tmax) on its surface.
    bool trace(int i, const Ray& ray, float tmin, float tmax, float& t) const;
    /// Unit outward normal at p (tetrahedral differences with offset e).
    vec3 normal(int i, vec3 p, float e) const;
    /// Soft-shadow visibility in [0, 1] along the ray (0: the ray meets the solid).
    float softShadow(int i, const Ray& ray, float tmin, float tmax) const;
    /// Ambient occlusion in [0, 1] at p with unit normal n.
    float ambientOcclusion(int i, vec3 p, vec3 n) const;

    const std::vector<SdfSolid>& solids() const { return solids_; }

  private:
    std::vector<SdfSolid> solids_;
    const SurfaceQuery* other_;
};

} // namespace nimbus
