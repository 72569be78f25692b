#include "core/rebase.h"

#include <algorithm>
#include <cmath>

#include "core/fields/grid.h"

namespace nimbus {

namespace {

vec3 moved(vec3 p, glm::dvec3 origin) {
    return vec3(glm::dvec3(p) - origin);
}

} // namespace

Rebase chooseRebase(const SceneDesc& s, const FrameBindings& b, double fineLength) {
    Rebase r;
    Box bounds;
    if (s.field.kind == FieldKind::Vdb)
        bounds = b.grid(0).bounds;
    else if (s.field.kind == FieldKind::Homogeneous)
        bounds = s.field.homogeneous.box;
    else
        return r; // procedural fields: their noise lives at world positions (see the header)
    if (bounds.empty()) return r;
    double far = 0.0;
    for (int a = 0; a < 3; ++a)
        far = std::max({far, std::abs(double(bounds.lo[a])), std::abs(double(bounds.hi[a])),
                        std::abs(double(s.camera.position[a]))});
    r.distance = far;
    if (!(fineLength > 0.0) || far * std::ldexp(1.0, -23) <= 1e-3 * fineLength) return r;
    if (!s.volumes.empty() || !s.instances.empty())
        r.blocked = "[[volume]] or [[instance]] entries";
    else if (s.ground.enabled || !s.meshes.empty() || !s.solids.empty() || b.geometry)
        r.blocked = "surfaces (ground, meshes or solids)";
    else if (s.field.advect.enabled)
        r.blocked = "[field.advect] (its domain and winds are in world coordinates)";
    if (!r.blocked.empty()) return r;
    r.active = true;
    r.origin = 0.5 * (glm::dvec3(bounds.lo) + glm::dvec3(bounds.hi));
    return r;
}

SceneDesc rebasedScene(const SceneDesc& s, glm::dvec3 origin) {
    SceneDesc r = s;
    r.camera.position = moved(s.camera.position, origin);
    r.camera.lookAt = moved(s.camera.lookAt, origin);
    Box& box = r.field.homogeneous.box;
    box.lo = moved(box.lo, origin);
    box.hi = moved(box.hi, origin);
    return r;
}

FrameBindings rebasedBindings(const FrameBindings& b, glm::dvec3 origin) {
    FrameBindings r = b;
    for (GridBinding& g : r.grids) g = shiftedGrid(g, origin);
    return r;
}

} // namespace nimbus
