/// @file cloud_depth.cpp
/// @brief measureCloudDepth (core/lighting/cloud_depth.h).
#include "core/lighting/cloud_depth.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <tbb/parallel_for.h>

namespace nimbus {

RayDensity integrateDensity(const Field& field, const Ray& ray, float t0, float t1, double step,
                            int maxSteps) {
    RayDensity r;
    r.steps = int(std::clamp(std::ceil((t1 - t0) / std::max(step, 1e-12)), 1.0,
                             double(std::max(maxSteps, 1))));
    r.dt = double(t1 - t0) / r.steps;
    for (int i = 0; i < r.steps; ++i) {
        const float rho = field.density(ray.at(float(t0 + (i + 0.5) * r.dt)));
        r.sum += rho;
        if (rho > 0.0f) {
            if (r.occupied == 0) r.first = i;
            r.last = i;
            ++r.occupied;
        }
    }
    return r;
}

CloudDepth measureCloudDepth(const Field& field, const Box& bounds, vec3 direction, float sigmaT,
                             float step, int raysPerSide, int maxSteps) {
    CloudDepth out;
    const float len = glm::length(direction);
    if (bounds.empty() || !(len > 0.0f) || raysPerSide < 1 || maxSteps < 1) return out;
    const vec3 d = direction / len;
    // a basis of the plane across the rays: u from the axis least aligned with d
    const vec3 a = std::abs(d.x) <= std::abs(d.y) && std::abs(d.x) <= std::abs(d.z)
                       ? vec3(1.0f, 0.0f, 0.0f)
                   : std::abs(d.y) <= std::abs(d.z) ? vec3(0.0f, 1.0f, 0.0f)
                                                    : vec3(0.0f, 0.0f, 1.0f);
    const vec3 u = glm::normalize(glm::cross(d, a));
    const vec3 v = glm::cross(d, u);
    const vec3 c = 0.5f * (bounds.lo + bounds.hi);
    float u0 = std::numeric_limits<float>::max(), u1 = -u0, v0 = u0, v1 = -u0;
    for (int k = 0; k < 8; ++k) {
        const vec3 p((k & 1) ? bounds.hi.x : bounds.lo.x, (k & 2) ? bounds.hi.y : bounds.lo.y,
                     (k & 4) ? bounds.hi.z : bounds.lo.z);
        const float pu = glm::dot(p - c, u), pv = glm::dot(p - c, v);
        u0 = std::min(u0, pu);
        u1 = std::max(u1, pu);
        v0 = std::min(v0, pv);
        v1 = std::max(v1, pv);
    }
    const int n = raysPerSide;
    const double du = double(u1 - u0) / n, dv = double(v1 - v0) / n;
    const float reach = glm::length(bounds.extent());
    // per lattice row: the density integrals of its rays that hit, their count, the occupied
    // length and the lookups (summed in row order afterwards: the same for any thread count)
    struct Row {
        double tau = 0.0, occupied = 0.0;
        int hits = 0;
        std::size_t lookups = 0;
        vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
    };
    std::vector<Row> rows(static_cast<size_t>(n));
    tbb::parallel_for(0, n, [&](int j) {
        Row& row = rows[size_t(j)];
        for (int i = 0; i < n; ++i) {
            const float su = u0 + float((i + 0.5) * du), sv = v0 + float((j + 0.5) * dv);
            const Ray r{c + su * u + sv * v - reach * d, d};
            float t0 = 0.0f, t1 = 0.0f;
            if (!intersectBox(r, bounds, 0.0f, 2.0f * reach, t0, t1) || !(t1 > t0)) continue;
            const RayDensity rd = integrateDensity(field, r, t0, t1, step, maxSteps);
            row.lookups += size_t(rd.steps);
            if (rd.sum > 0.0) {
                row.tau += rd.integral();
                row.occupied += rd.occupiedLength();
                ++row.hits;
                // the first and last samples with density bound this ray's part of the box
                const float grow = 0.5f * float(std::max({du, dv, rd.dt}));
                for (int k : {rd.first, rd.last}) {
                    const vec3 q = r.at(float(t0 + (k + 0.5) * rd.dt));
                    row.lo = glm::min(row.lo, q - grow);
                    row.hi = glm::max(row.hi, q + grow);
                }
            }
        }
    });
    double tau = 0.0, occupied = 0.0;
    vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
    for (const Row& row : rows) {
        tau += row.tau;
        occupied += row.occupied;
        out.hits += row.hits;
        out.lookups += row.lookups;
        lo = glm::min(lo, row.lo);
        hi = glm::max(hi, row.hi);
    }
    if (out.hits > 0) out.occupiedBox = Box{lo, hi}.within(bounds);
    out.rays = n * n;
    if (out.hits > 0) out.meanTau = double(sigmaT) * tau / out.hits;
    if (occupied > 0.0) out.meanExtinction = double(sigmaT) * tau / occupied;
    out.occupiedVolume = occupied * du * dv;
    return out;
}

} // namespace nimbus
