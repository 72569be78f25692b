/// @file geometry.h
/// @brief Rays and axis-aligned boxes in world space.
#pragma once

#include <algorithm>
#include <glm/glm.hpp>

namespace nimbus {

using glm::ivec3;
using glm::vec2;
using glm::vec3;
using glm::vec4;

inline float maxComponent(vec3 v) {
    return std::max(v.x, std::max(v.y, v.z));
}
inline float minComponent(vec3 v) {
    return std::min(v.x, std::min(v.y, v.z));
}

struct Ray {
    vec3 o;
    vec3 d; ///< unit direction
    vec3 at(float t) const { return o + t * d; }
};

struct Box {
    vec3 lo{0.0f};
    vec3 hi{0.0f};
    bool empty() const { return !(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z); }
    vec3 extent() const { return hi - lo; }
    bool contains(vec3 p) const {
        return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y &&
               p.z <= hi.z;
    }
};

/// Slab test; returns false when the ray misses. On a hit [t0, t1] is clipped to [tmin, tmax].
inline bool intersectBox(const Ray& r, const Box& b, float tmin, float tmax, float& t0, float& t1) {
    t0 = tmin;
    t1 = tmax;
    if (b.empty()) return false;
    for (int a = 0; a < 3; ++a) {
        float inv = 1.0f / r.d[a];
        float tn = (b.lo[a] - r.o[a]) * inv;
        float tf = (b.hi[a] - r.o[a]) * inv;
        if (tn > tf) std::swap(tn, tf);
        // NaN-safe when the direction component is 0 and the origin is on a slab plane
        t0 = tn > t0 ? tn : t0;
        t1 = tf < t1 ? tf : t1;
        if (t0 > t1) return false;
    }
    return true;
}

} // namespace nimbus
