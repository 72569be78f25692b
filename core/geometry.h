/// @file geometry.h
/// @brief Rays and axis-aligned boxes in world space.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

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
inline float meanComponent(vec3 v) {
    return (v.x + v.y + v.z) * (1.0f / 3.0f);
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
    /// The part of this box inside `o` (empty() when they do not overlap).
    Box within(const Box& o) const { return Box{glm::max(lo, o.lo), glm::min(hi, o.hi)}; }
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

/// Index of voxel (x, y, z) of a grid of `res` voxels stored x fastest.
inline size_t voxelIndex(const ivec3& res, int x, int y, int z) {
    return (size_t(z) * res.y + y) * res.x + x;
}

/// Voxel q's neighbour across face f (0..5: -x, +x, -y, +y, -z, +z; axis f / 2, the + side
/// when f is odd) in `out`; false when it lies outside a grid of `res` voxels.
inline bool faceNeighbour(const ivec3& res, ivec3 q, int f, ivec3& out) {
    const int a = f / 2;
    q[a] += (f & 1) ? 1 : -1;
    out = q;
    return q[a] >= 0 && q[a] < res[a];
}

/// Trilinear interpolation of values at the voxel centres lo + (i + 0.5) voxel of a grid of
/// `res` voxels (x fastest), clamped to the outermost centres.
template <class T>
T sampleVoxelCentres(const std::vector<T>& v, vec3 lo, ivec3 res, vec3 voxel, vec3 p) {
    vec3 u = (p - lo) / voxel - vec3(0.5f);
    u = glm::clamp(u, vec3(0.0f), vec3(res - ivec3(1)));
    const ivec3 i0 = glm::min(ivec3(u), res - ivec3(1));
    const ivec3 i1 = glm::min(i0 + ivec3(1), res - ivec3(1));
    const vec3 f = u - vec3(i0);
    auto at = [&](int x, int y, int z) { return v[(size_t(z) * res.y + y) * res.x + x]; };
    const T c00 = glm::mix(at(i0.x, i0.y, i0.z), at(i1.x, i0.y, i0.z), f.x);
    const T c10 = glm::mix(at(i0.x, i1.y, i0.z), at(i1.x, i1.y, i0.z), f.x);
    const T c01 = glm::mix(at(i0.x, i0.y, i1.z), at(i1.x, i0.y, i1.z), f.x);
    const T c11 = glm::mix(at(i0.x, i1.y, i1.z), at(i1.x, i1.y, i1.z), f.x);
    return glm::mix(glm::mix(c00, c10, f.y), glm::mix(c01, c11, f.y), f.z);
}

} // namespace nimbus
