#include "core/fields/cumulus.h"

#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

namespace nimbus {

namespace {

inline int wrapIndex(int i, int n) {
    int r = i % n;
    return r < 0 ? r + n : r;
}

/// The trilinear lookup of a periodic res^3 tile at u (voxel units), the node values from
/// at(x, y, z): float for one channel, vec4 for four (each interpolated apart).
template <class At> auto trilinear(int res, vec3 u, At&& at) {
    const float n = float(res);
    vec3 w = u - glm::floor(u / n) * n; // [0, res)
    vec3 f0 = glm::floor(w);
    vec3 f = w - f0;
    int x0 = wrapIndex(int(f0.x), res), y0 = wrapIndex(int(f0.y), res),
        z0 = wrapIndex(int(f0.z), res);
    int x1 = wrapIndex(x0 + 1, res), y1 = wrapIndex(y0 + 1, res), z1 = wrapIndex(z0 + 1, res);
    auto c00 = at(x0, y0, z0) + f.x * (at(x1, y0, z0) - at(x0, y0, z0));
    auto c10 = at(x0, y1, z0) + f.x * (at(x1, y1, z0) - at(x0, y1, z0));
    auto c01 = at(x0, y0, z1) + f.x * (at(x1, y0, z1) - at(x0, y0, z1));
    auto c11 = at(x0, y1, z1) + f.x * (at(x1, y1, z1) - at(x0, y1, z1));
    auto c0 = c00 + f.y * (c10 - c00);
    auto c1 = c01 + f.y * (c11 - c01);
    return c0 + f.z * (c1 - c0);
}

} // namespace

float NoiseVolume::sample(vec3 u) const {
    return trilinear(res, u,
                     [&](int x, int y, int z) { return values[(size_t(z) * res + y) * res + x]; });
}

vec4 NoiseVolume::sample4(vec3 u) const {
    return trilinear(res, u, [&](int x, int y, int z) {
        const std::uint8_t* c = &rgba[4 * ((size_t(z) * res + y) * res + x)];
        return vec4(float(c[0]), float(c[1]), float(c[2]), float(c[3])) / 255.0f;
    });
}

void NoiseVolume::rangeOver(vec3 lo, vec3 hi, vec4& lowest, vec4& highest) const {
    ivec3 a(glm::floor(lo)), b(glm::ceil(hi));
    b = glm::min(b, a + ivec3(res - 1)); // an axis wider than the tile: each node once
    std::uint8_t mn[4] = {255, 255, 255, 255}, mx[4] = {0, 0, 0, 0};
    for (int z = a.z; z <= b.z; ++z) {
        const int zz = wrapIndex(z, res);
        for (int y = a.y; y <= b.y; ++y) {
            const std::uint8_t* row = &rgba[4 * (size_t(zz) * res + wrapIndex(y, res)) * res];
            for (int x = a.x; x <= b.x; ++x) {
                const std::uint8_t* c = &row[4 * wrapIndex(x, res)];
                for (int k = 0; k < 4; ++k) {
                    mn[k] = std::min(mn[k], c[k]);
                    mx[k] = std::max(mx[k], c[k]);
                }
            }
        }
    }
    lowest = vec4(float(mn[0]), float(mn[1]), float(mn[2]), float(mn[3])) / 255.0f;
    highest = vec4(float(mx[0]), float(mx[1]), float(mx[2]), float(mx[3])) / 255.0f;
}

float NoiseVolume::maxOver(vec3 lo, vec3 hi) const {
    ivec3 a(glm::floor(lo)), b(glm::ceil(hi));
    // a box wider than the tile touches every node
    if (b.x - a.x >= res && b.y - a.y >= res && b.z - a.z >= res)
        return *std::max_element(values.begin(), values.end());
    b = glm::min(b, a + ivec3(res - 1));
    float m = 0.0f;
    for (int z = a.z; z <= b.z; ++z) {
        int zz = wrapIndex(z, res);
        for (int y = a.y; y <= b.y; ++y) {
            const float* row = &values[(size_t(zz) * res + wrapIndex(y, res)) * res];
            for (int x = a.x; x <= b.x; ++x) m = std::max(m, row[wrapIndex(x, res)]);
        }
    }
    return m;
}

kern::CumulusParams cumulusParams(const CumulusDesc& c, float time) {
    kern::CloudLayer L{};
    L.bottom = c.bounds.lo.y;
    L.top = c.bounds.hi.y;
    L.heightA = c.heightA;
    L.heightB = c.heightB;
    L.coverage = c.coverage;
    L.softness = c.softness;
    L.erosion = c.erosion;
    L.towerSpacing = c.towerSpacing;
    L.towerRadiusMin = c.towerRadiusMin;
    L.towerRadiusMax = c.towerRadiusMax;
    L.towerHeightMin = c.towerHeightMin;
    L.towerHeightMax = c.towerHeightMax;
    L.towerProbability = c.towerProbability;
    L.towerAnisotropy = c.towerAnisotropy;
    L.seed = c.seed;
    kern::CumulusParams P{};
    P.layer = L;
    P.density = c.density;
    P.basePeriod = c.basePeriod;
    P.baseLattice = c.baseLattice;
    P.baseOctaves = c.baseOctaves;
    P.detailPeriod = c.detailPeriod;
    P.detailLattice = c.detailLattice;
    P.detailOctaves = c.detailOctaves;
    P.baseOffset = c.wind * time;
    P.detailOffset = (c.wind + c.detailWind) * time;
    return P;
}

namespace {

template <class F>
std::shared_ptr<const NoiseVolume> bakeTile(int res, const std::atomic<bool>* cancel, F&& noise) {
    auto vol = std::make_shared<NoiseVolume>();
    vol->res = res;
    vol->values.resize(size_t(res) * res * res);
    tbb::parallel_for(0, res, [&](int z) {
        for (int y = 0; y < res; ++y)
            for (int x = 0;
                 x < res && !(x == 0 && cancel && cancel->load(std::memory_order_relaxed)); ++x)
                vol->values[(size_t(z) * res + y) * res + x] =
                    noise(vec3(float(x), float(y), float(z)) / float(res));
    });
    return vol;
}

/// The same for RGBA8 channels: each channel in [0, 1] rounded to the nearest k / 255.
template <class F>
std::shared_ptr<const NoiseVolume> bakeTileRgba(int res, const std::atomic<bool>* cancel,
                                                F&& channels) {
    auto vol = std::make_shared<NoiseVolume>();
    vol->res = res;
    vol->rgba.resize(4 * size_t(res) * res * res);
    tbb::parallel_for(0, res, [&](int z) {
        for (int y = 0; y < res; ++y)
            for (int x = 0;
                 x < res && !(x == 0 && cancel && cancel->load(std::memory_order_relaxed)); ++x) {
                const vec4 v = channels(vec3(float(x), float(y), float(z)) / float(res));
                std::uint8_t* c = &vol->rgba[4 * ((size_t(z) * res + y) * res + x)];
                for (int k = 0; k < 4; ++k)
                    c[k] = std::uint8_t(std::lround(std::clamp(v[k], 0.0f, 1.0f) * 255.0f));
            }
    });
    return vol;
}

} // namespace

std::shared_ptr<const NoiseVolume> bakeCumulusBase(const CumulusDesc& c,
                                                   const std::atomic<bool>* cancel) {
    const kern::CumulusParams P = cumulusParams(c, 0.0f);
    if (c.eval == NoiseEval::Rgba)
        return bakeTileRgba(c.baseBakeResolution, cancel,
                            [&](vec3 q) { return kern::cumulusBaseChannels(P, q); });
    return bakeTile(c.baseBakeResolution, cancel,
                    [&](vec3 q) { return kern::cumulusBaseNoise(P, q); });
}

std::shared_ptr<const NoiseVolume> bakeCumulusDetail(const CumulusDesc& c,
                                                     const std::atomic<bool>* cancel) {
    const kern::CumulusParams P = cumulusParams(c, 0.0f);
    if (c.eval == NoiseEval::Rgba)
        return bakeTileRgba(c.detailBakeResolution, cancel,
                            [&](vec3 q) { return kern::cumulusDetailChannels(P, q); });
    return bakeTile(c.detailBakeResolution, cancel,
                    [&](vec3 q) { return kern::cumulusDetailNoise(P, q); });
}

float CumulusField::density(vec3 p) const {
    if (!baseBake && !detailBake) return kern::cumulusDensity(params, p);
    // the kernel's three stages, the noises read from the baked tiles
    const float env = kern::cumulusEnvelope(params, p);
    if (kern::cloudShape(params.layer, env, 1.0f, 0.0f) <= 0.0f) return 0.0f;
    const vec3 qb = kern::cumulusBaseDomain(params, p);
    const float base =
        !baseBake ? kern::cumulusBaseNoise(params, qb)
        : baseBake->channels()
            ? kern::cumulusBaseFromChannels(baseBake->sample4(qb * float(baseBake->res)))
            : baseBake->sample(qb * float(baseBake->res));
    if (kern::cloudShape(params.layer, env, base, 0.0f) <= 0.0f) return 0.0f;
    const vec3 qd = kern::cumulusDetailDomain(params, p);
    const float detail = !detailBake ? kern::cumulusDetailNoise(params, qd)
                         : detailBake->channels()
                             ? kern::cumulusDetailFromChannels(
                                   params, detailBake->sample4(qd * float(detailBake->res)))
                             : detailBake->sample(qd * float(detailBake->res));
    return params.density * kern::cloudShape(params.layer, env, base, detail);
}

float CumulusField::majorant(const Box& c) const {
    const float envMax = kern::cumulusEnvelopeBound(params, c.lo, c.hi);
    if (kern::cloudShape(params.layer, envMax, 1.0f, 0.0f) <= 0.0f) return 0.0f;
    float baseMax = 1.0f;
    if (baseBake) {
        const float s = float(baseBake->res) / params.basePeriod;
        const vec3 lo = (c.lo - params.baseOffset) * s, hi = (c.hi - params.baseOffset) * s;
        if (baseBake->channels()) {
            // the combination rises with the Perlin channel and falls with the Worley ones
            vec4 mn, mx;
            baseBake->rangeOver(lo, hi, mn, mx);
            baseMax = kern::cumulusBaseFromChannels(vec4(mx.x, mn.y, mn.z, mn.w));
        } else {
            baseMax = baseBake->maxOver(lo, hi);
        }
    }
    return kern::cumulusDensityBound(params, envMax, baseMax);
}

} // namespace nimbus
