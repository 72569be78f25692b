/// @file accel.h
/// @brief Ray queries the integrators ask of the host: which volume instances a ray crosses,
/// and where it meets opaque surfaces.
///
/// core/ knows no ray-tracing library: plugin/geom implements these with Embree (instance boxes
/// as user geometry, the ground and OBJ meshes as triangles). core/ has a linear-scan instance
/// query of its own (volumes.h) for scenes without geometry and few instances, so a scene that
/// needs no Embree never starts it.
#pragma once

#include <memory>
#include <vector>

#include "core/geometry.h"

namespace nimbus {

/// The ray's parameter interval inside one instance's world box.
struct InstanceHit {
    int instance;
    float t0, t1;
};

/// Finds the instance boxes a ray crosses.
class InstanceQuery {
  public:
    virtual ~InstanceQuery() = default;
    /// Appends every instance whose box the ray crosses within [tmin, tmax] (any order).
    virtual void find(const Ray& ray, float tmin, float tmax,
                      std::vector<InstanceHit>& out) const = 0;
};

struct SurfaceHit {
    float t = 0.0f;
    vec3 normal{0.0f, 1.0f, 0.0f}; ///< unit, facing the ray's origin
    vec3 albedo{0.5f};
    bool holdout = false;
    float ao = 1.0f; ///< ambient occlusion of the sky light (SDF solids; 1 elsewhere)
};

/// Opaque surfaces.
class SurfaceQuery {
  public:
    virtual ~SurfaceQuery() = default;
    /// Nearest surface on the ray within (tmin, tmax).
    virtual bool intersect(const Ray& ray, float tmin, float tmax, SurfaceHit& hit) const = 0;
    /// Whether any surface lies on the ray within (tmin, tmax).
    virtual bool occluded(const Ray& ray, float tmin, float tmax) const = 0;
    /// Share of the sun's light arriving along the ray within (tmin, tmax), in [0, 1]: 0 or 1
    /// for hard surfaces; SDF solids give a soft penumbra estimate (core/sdf/solid.h).
    virtual float sunVisibility(const Ray& ray, float tmin, float tmax) const {
        return occluded(ray, tmin, tmax) ? 0.0f : 1.0f;
    }
};

/// What the host builds per frame: an instance query over the frame's instance boxes.
class GeometryBackend {
  public:
    virtual ~GeometryBackend() = default;
    virtual std::unique_ptr<InstanceQuery> instances(const std::vector<Box>& boxes) const = 0;
    /// The scene's surfaces; null when it has none.
    virtual const SurfaceQuery* surfaces() const = 0;
};

} // namespace nimbus
