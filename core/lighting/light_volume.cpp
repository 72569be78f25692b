#include "core/lighting/light_volume.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include <tbb/parallel_for.h>

#include "core/cancel.h"

namespace nimbus {

namespace {

/// 1 inside [0, n - 1] (voxel-centre units), falling linearly to 0 at the faces -0.5 and n - 0.5.
inline float rimFactor(float u, int n) {
    if (u < 0.0f) return std::max(0.0f, 1.0f + 2.0f * u);
    const float hi = float(n - 1);
    if (u > hi) return std::max(0.0f, 1.0f - 2.0f * (u - hi));
    return 1.0f;
}

} // namespace

/// Propagates the density integral toward sunDir slice by slice (see the header).
void propagateDensityIntegral(LightVolume& lv, const std::vector<float>& rho, vec3 sunDir,
                              const std::atomic<bool>* cancel) {
    lv.tau.assign(size_t(lv.res.x) * lv.res.y * lv.res.z, 0.0f);
    // dominant axis of the sun direction; slices ordered from the sun side
    int a = 0;
    for (int k = 1; k < 3; ++k)
        if (std::abs(sunDir[k]) > std::abs(sunDir[a])) a = k;
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    if (std::abs(sunDir[a]) < 1e-6f) return;    // degenerate: no direction
    const int step = sunDir[a] > 0.0f ? -1 : 1; // walk away from the sun
    const int first = sunDir[a] > 0.0f ? lv.res[a] - 1 : 0;
    const float l = lv.voxel[a] / std::abs(sunDir[a]); // path length between slice planes
    // lateral shift (in voxels) of q' relative to q in the previous slice
    const float db = sunDir[b] * l / lv.voxel[b], dc = sunDir[c] * l / lv.voxel[c];

    auto idx = [&](int ia, int ib, int ic) {
        ivec3 v;
        v[a] = ia;
        v[b] = ib;
        v[c] = ic;
        return voxelIndex(lv.res, v.x, v.y, v.z);
    };
    // first slice: light crossed half a voxel of the entry face to reach the centres
    for (int ic = 0; ic < lv.res[c]; ++ic)
        for (int ib = 0; ib < lv.res[b]; ++ib) {
            const size_t i = idx(first, ib, ic);
            lv.tau[i] = 0.5f * rho[i] * l;
        }
    const float hiB = float(lv.res[b]) - 0.5f, hiC = float(lv.res[c]) - 0.5f;
    for (int s = 1; s < lv.res[a]; ++s) {
        if (cancelRequested(cancel)) return;
        const int ia = first + step * s, prev = ia - step;
        tbb::parallel_for(0, lv.res[c], [&](int ic) {
            if (cancelRequested(cancel)) return;
            for (int ib = 0; ib < lv.res[b]; ++ib) {
                const size_t i = idx(ia, ib, ic);
                const float ub = float(ib) + db, uc = float(ic) + dc;
                // the light ray left the box through a side face within this step: only the
                // fraction f of the step inside the box carries density
                float f = 1.0f;
                if (ub < -0.5f) f = std::min(f, (-0.5f - float(ib)) / db);
                if (ub > hiB) f = std::min(f, (hiB - float(ib)) / db);
                if (uc < -0.5f) f = std::min(f, (-0.5f - float(ic)) / dc);
                if (uc > hiC) f = std::min(f, (hiC - float(ic)) / dc);
                if (f < 1.0f) {
                    lv.tau[i] = rho[i] * std::max(f, 0.0f) * l;
                    continue;
                }
                // inside: bilinear in the previous slice; in the half-voxel rim between the
                // outermost centres and the face, tau falls linearly to 0 at the face
                const float rim = rimFactor(ub, lv.res[b]) * rimFactor(uc, lv.res[c]);
                const float cb = std::clamp(ub, 0.0f, float(lv.res[b] - 1));
                const float cc = std::clamp(uc, 0.0f, float(lv.res[c] - 1));
                const int b0 = std::min(int(cb), lv.res[b] - 2),
                          c0 = std::min(int(cc), lv.res[c] - 2);
                const int b1 = b0 + 1, c1 = c0 + 1; // res >= 2 on every axis
                const float fb = cb - float(b0), fc = cc - float(c0);
                auto bil = [&](const std::vector<float>& v) {
                    return (1 - fc) *
                               ((1 - fb) * v[idx(prev, b0, c0)] + fb * v[idx(prev, b1, c0)]) +
                           fc * ((1 - fb) * v[idx(prev, b0, c1)] + fb * v[idx(prev, b1, c1)]);
                };
                lv.tau[i] = rim * bil(lv.tau) + 0.5f * (rho[i] + bil(rho)) * l;
            }
        });
    }
}

float LightVolume::sample(vec3 p) const {
    return sampleVoxelCentres(tau, bounds.lo, res, voxel, p);
}

std::vector<float> densityAtCentres(const Field& field, const Box& bounds, ivec3 res,
                                    const MajorantGrid* grid, std::size_t& lookups,
                                    const std::atomic<bool>* cancel) {
    const vec3 voxel = bounds.extent() / vec3(res);
    std::vector<float> rho(size_t(res.x) * res.y * res.z, 0.0f);
    std::atomic<size_t> count{0};
    tbb::parallel_for(0, res.z, [&](int z) {
        size_t local = 0;
        for (int y = 0; y < res.y; ++y) {
            if (cancelRequested(cancel)) break;
            for (int x = 0; x < res.x; ++x) {
                const vec3 p = bounds.lo + (vec3(x, y, z) + vec3(0.5f)) * voxel;
                if (grid) {
                    ivec3 c = glm::clamp(ivec3((p - grid->bounds.lo) / grid->cellSize), ivec3(0),
                                         grid->res - ivec3(1));
                    if (grid->at(c) <= 0.0f) continue;
                }
                rho[voxelIndex(res, x, y, z)] = field.density(p);
                ++local;
            }
        }
        count += local;
    });
    lookups += count;
    return rho;
}

ivec3 lightVolumeResolution(const Box& bounds, float cell) {
    const vec3 ext = bounds.extent();
    ivec3 res;
    for (int a = 0; a < 3; ++a) res[a] = std::max(2, int(std::ceil(ext[a] / cell)));
    return res;
}

LightVolume lightVolumeGrid(const Field& field, float cell) {
    LightVolume lv;
    lv.bounds = field.bounds();
    lv.res = lightVolumeResolution(lv.bounds, cell);
    lv.voxel = lv.bounds.extent() / vec3(lv.res);
    return lv;
}

LightVolume densityGrid(const Field& field, float cell, const MajorantGrid* grid,
                        std::vector<float>& rho, const std::atomic<bool>* cancel) {
    LightVolume lv = lightVolumeGrid(field, cell);
    rho = densityAtCentres(field, lv.bounds, lv.res, grid, lv.densityLookups, cancel);
    return lv;
}

LightVolume densityGridWithin(const Field& field, float cell, const Box& within,
                              const MajorantGrid* grid, std::vector<float>& rho,
                              const std::atomic<bool>* cancel) {
    LightVolume lv = lightVolumeGrid(field, cell);
    const Box whole = lv.bounds;
    const Box part = within.within(whole);
    if (!part.empty()) {
        const ivec3 lo =
            glm::clamp(ivec3(glm::floor((part.lo - whole.lo) / lv.voxel)) - 1, ivec3(0), lv.res);
        const ivec3 hi =
            glm::clamp(ivec3(glm::ceil((part.hi - whole.lo) / lv.voxel)) + 1, ivec3(0), lv.res);
        // at least 2 voxels an axis, as lightVolumeResolution gives
        const ivec3 n = glm::clamp(hi - lo, ivec3(2), lv.res);
        const ivec3 first = glm::min(lo, lv.res - n);
        lv.bounds = Box{whole.lo + vec3(first) * lv.voxel,
                        glm::min(whole.lo + vec3(first + n) * lv.voxel, whole.hi)};
        lv.res = n;
        lv.voxel = lv.bounds.extent() / vec3(lv.res);
    }
    rho = densityAtCentres(field, lv.bounds, lv.res, grid, lv.densityLookups, cancel);
    return lv;
}

std::vector<LightVolume> buildLightVolumes(const Field& field, const std::vector<vec3>& dirs,
                                           float cell, const MajorantGrid* grid,
                                           std::vector<float>* rhoOut,
                                           const std::atomic<bool>* cancel) {
    std::vector<float> rho;
    const LightVolume lv = densityGrid(field, cell, grid, rho, cancel);

    std::vector<LightVolume> out;
    for (const vec3& d : dirs) {
        out.push_back(lv);
        propagateDensityIntegral(out.back(), rho, d, cancel);
        if (out.size() > 1) out.back().densityLookups = 0; // counted once, on the first
    }
    if (rhoOut) *rhoOut = std::move(rho);
    return out;
}

LightVolume buildLightVolume(const Field& field, vec3 sunDir, float cell,
                             const MajorantGrid* grid) {
    return std::move(buildLightVolumes(field, {sunDir}, cell, grid).front());
}

} // namespace nimbus
