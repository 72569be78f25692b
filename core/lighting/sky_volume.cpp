#include "core/lighting/sky_volume.h"

#include "core/cancel.h"

#include <algorithm>

#include <tbb/parallel_for.h>

#include "core/kernels/kernels.h"
#include "core/lighting/light_volume.h"

namespace nimbus {

void SkyVolume::sample(vec3 p, float* out) const {
    const int K = count();
    // the corners and weights of sampleVoxelCentres (core/geometry.h), shared by the K values
    vec3 u = (p - bounds.lo) / voxel - vec3(0.5f);
    u = glm::clamp(u, vec3(0.0f), vec3(res - ivec3(1)));
    const ivec3 i0 = glm::min(ivec3(u), res - ivec3(1));
    const ivec3 i1 = glm::min(i0 + ivec3(1), res - ivec3(1));
    const vec3 f = u - vec3(i0);
    auto at = [&](int x, int y, int z) {
        return tau.data() + ((size_t(z) * res.y + y) * res.x + x) * size_t(K);
    };
    const float* c[8] = {at(i0.x, i0.y, i0.z), at(i1.x, i0.y, i0.z), at(i0.x, i1.y, i0.z),
                         at(i1.x, i1.y, i0.z), at(i0.x, i0.y, i1.z), at(i1.x, i0.y, i1.z),
                         at(i0.x, i1.y, i1.z), at(i1.x, i1.y, i1.z)};
    const float w[8] = {(1 - f.x) * (1 - f.y) * (1 - f.z),
                        f.x * (1 - f.y) * (1 - f.z),
                        (1 - f.x) * f.y * (1 - f.z),
                        f.x * f.y * (1 - f.z),
                        (1 - f.x) * (1 - f.y) * f.z,
                        f.x * (1 - f.y) * f.z,
                        (1 - f.x) * f.y * f.z,
                        f.x * f.y * f.z};
    for (int k = 0; k < K; ++k) {
        float s = 0.0f;
        for (int j = 0; j < 8; ++j) s += w[j] * c[j][k];
        out[k] = s;
    }
}

SkyVolume buildSkyVolume(const Field& field, int count, float cell, const MajorantGrid* grid,
                         const std::vector<float>* rho, const std::atomic<bool>* cancel) {
    count = std::clamp(count, 1, kMaxSkyDirections);
    LightVolume lv = lightVolumeGrid(field, cell);
    SkyVolume sv;
    sv.bounds = lv.bounds;
    sv.res = lv.res;
    sv.voxel = lv.voxel;
    std::vector<float> own;
    if (!rho) {
        own = densityAtCentres(field, lv.bounds, lv.res, grid, sv.densityLookups, cancel);
        rho = &own;
    }
    const size_t n = size_t(lv.res.x) * lv.res.y * lv.res.z;
    sv.tau.assign(n * size_t(count), 0.0f);
    for (int k = 0; k < count; ++k) {
        if (cancelRequested(cancel)) break;
        const vec3 d = kern::fibonacciDirection(k, count);
        sv.directions.push_back(d);
        propagateDensityIntegral(lv, *rho, d, cancel);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096),
                          [&](const tbb::blocked_range<size_t>& r) {
                              for (size_t i = r.begin(); i != r.end(); ++i)
                                  sv.tau[i * size_t(count) + size_t(k)] = lv.tau[i];
                          });
    }
    return sv;
}

} // namespace nimbus
