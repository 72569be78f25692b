/// @file solid.cpp
/// @brief Sphere tracing, normals, soft shadows and ambient occlusion of SDF solids (solid.h).
#include "core/sdf/solid.h"

#include <algorithm>
#include <cmath>

#include "core/kernels/kernels.h"

namespace nimbus {

namespace {

/// Distance below which a sample counts as on the surface, relative to max(1, t).
constexpr float kHitEpsilon = 1e-4f;
constexpr int kBisections = 48; ///< at most; until the bracket is 1e-3 epsilon wide

float epsilonAt(float t) {
    return kHitEpsilon * std::max(1.0f, t);
}

/// The sphere-tracing step from a sample with distance d at p.
float stepFrom(const SdfSolid& s, vec3 p, float d, float t) {
    const float safe = s.skip ? s.skip(p) : d;
    return std::max({safe, s.shading.stepScale * d, 0.5f * epsilonAt(t)});
}

} // namespace

SdfSurfaces::SdfSurfaces(std::vector<SdfSolid> solids, const SurfaceQuery* other)
    : solids_(std::move(solids)), other_(other) {}

bool SdfSurfaces::trace(int i, const Ray& ray, float tmin, float tmax, float& tHit) const {
    const SdfSolid& s = solids_[std::size_t(i)];
    float t0 = 0.0f, t1 = 0.0f;
    if (!intersectBox(ray, s.box, tmin, std::min(tmax, s.shading.maxDistance), t0, t1))
        return false;
    auto f = [&](float t) { return s.distance(ray.at(t)); };
    // the bracket [out, in]: f(out) > 0 >= f(in); 16 bisections, the hit the outside end
    auto refine = [&](float out, float in) {
        for (int k = 0; k < kBisections && in - out > 1e-3f * epsilonAt(in); ++k) {
            const float mid = 0.5f * (out + in);
            (f(mid) > 0.0f ? out : in) = mid;
        }
        tHit = out;
        return true;
    };
    float t = t0, tPrev = t0;
    for (int n = 0; n < s.shading.maxSteps && t <= t1; ++n) {
        const vec3 p = ray.at(t);
        const float d = s.distance(p);
        if (!std::isfinite(d)) return false;
        if (d <= 0.0f) {
            if (n == 0) { // the ray starts inside (or on) the solid
                tHit = t;
                return true;
            }
            return refine(tPrev, t); // a step past the surface
        }
        const float eps = epsilonAt(t);
        if (d < eps) {
            // near the surface: confirm it with a point inside before counting a hit (a ray
            // grazing a silhouette within eps goes on)
            const float tIn = t + 2.0f * eps;
            if (f(tIn) <= 0.0f) return refine(t, tIn);
        }
        tPrev = t;
        t += stepFrom(s, p, d, t);
    }
    return false;
}

vec3 SdfSurfaces::normal(int i, vec3 p, float e) const {
    const SdfSolid& s = solids_[std::size_t(i)];
    vec3 g(0.0f);
    for (int k = 0; k < 4; ++k) {
        const vec3 v = kern::sdfTetraVertex(k);
        g += v * s.distance(p + e * v);
    }
    const float len = glm::length(g);
    return len > 0.0f && std::isfinite(len) ? g / len : vec3(0.0f, 1.0f, 0.0f);
}

float SdfSurfaces::softShadow(int i, const Ray& ray, float tmin, float tmax) const {
    const SdfSolid& s = solids_[std::size_t(i)];
    const float k = s.shading.softness;
    if (!(k > 0.0f)) {
        float t = 0.0f;
        return trace(i, ray, tmin, tmax, t) ? 0.0f : 1.0f;
    }
    tmax = std::min(tmax, s.shading.maxDistance);
    float res = 1.0f, ph = 1e20f, t = tmin, tPrev = tmin;
    for (int n = 0; n < s.shading.maxSteps && t < tmax; ++n) {
        const vec3 p = ray.at(t);
        const float h = s.distance(p);
        if (!std::isfinite(h)) break;
        if (h < epsilonAt(t)) return 0.0f; // the ray meets the solid: umbra
        res = std::min(res, s.shading.penumbra == Penumbra::Improved
                                ? kern::sdfPenumbraImproved(h, t, ph, t - tPrev, k)
                                : kern::sdfPenumbraClassic(h, t, k));
        if (res <= 0.0f) return 0.0f;
        ph = h;
        tPrev = t;
        t += stepFrom(s, p, h, t);
    }
    return res;
}

float SdfSurfaces::ambientOcclusion(int i, vec3 p, vec3 n) const {
    const SdfSolid& s = solids_[std::size_t(i)];
    const SolidShading& sh = s.shading;
    float occlusion = 0.0f;
    for (int k = 0; k < sh.aoSamples; ++k) {
        const float delta = kern::sdfAoDelta(k, sh.aoStep);
        occlusion += kern::sdfAoTerm(delta, s.distance(p + n * delta),
                                     kern::sdfAoWeight(k, sh.aoStep, sh.aoStrength));
    }
    return kern::sdfAoFinish(occlusion);
}

bool SdfSurfaces::intersect(const Ray& ray, float tmin, float tmax, SurfaceHit& hit) const {
    bool any = other_ && other_->intersect(ray, tmin, tmax, hit);
    float tBest = any ? hit.t : tmax;
    int best = -1;
    for (int i = 0; i < int(solids_.size()); ++i) {
        float t = 0.0f;
        if (trace(i, ray, tmin, tBest, t)) {
            tBest = t;
            best = i;
        }
    }
    if (best < 0) return any;
    const vec3 p = ray.at(tBest);
    vec3 n = normal(best, p, 5.0f * epsilonAt(tBest));
    const SolidShading& sh = solids_[std::size_t(best)].shading;
    hit = SurfaceHit{};
    hit.t = tBest;
    hit.albedo = sh.albedo;
    hit.ao = ambientOcclusion(best, p, n);
    hit.normal = glm::dot(n, ray.d) > 0.0f ? -n : n;
    return true;
}

bool SdfSurfaces::occluded(const Ray& ray, float tmin, float tmax) const {
    if (other_ && other_->occluded(ray, tmin, tmax)) return true;
    for (int i = 0; i < int(solids_.size()); ++i) {
        float t = 0.0f;
        if (trace(i, ray, tmin, tmax, t)) return true;
    }
    return false;
}

float SdfSurfaces::sunVisibility(const Ray& ray, float tmin, float tmax) const {
    float v = other_ ? other_->sunVisibility(ray, tmin, tmax) : 1.0f;
    for (int i = 0; i < int(solids_.size()) && v > 0.0f; ++i)
        v = std::min(v, softShadow(i, ray, tmin, tmax));
    return v;
}

} // namespace nimbus
