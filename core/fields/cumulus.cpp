#include "core/fields/cumulus.h"

#include <algorithm>
#include <cmath>
#include <vector>

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

/// One octave's lattice hashes (noise.glsl's latticeHash3 of every cell of the period), computed
/// once for a bake instead of 8 (Perlin) or 27 (Worley) times per node: the kernels' arithmetic
/// on the same values in the same order, so the baked nodes equal the kernels' bit for bit
/// (tests/test_kernels.cpp, NoiseBake). A period too large for a table (over 64^3 cells) hashes
/// as the kernels do.
class OctaveLattice {
  public:
    OctaveLattice(int period, kern::uint seed) : period_(period), seed_(seed) {
        const size_t n = size_t(period) * period * period;
        if (period <= 0 || n > (size_t(1) << 18)) return; // 64^3 cells, 6 MB
        hashes_.resize(n);
        features_.resize(n);
        for (int z = 0; z < period; ++z)
            for (int y = 0; y < period; ++y)
                for (int x = 0; x < period; ++x) {
                    const size_t i = (size_t(z) * period + y) * period + x;
                    hashes_[i] = kern::latticeHash3(ivec3(x, y, z), period, seed);
                    features_[i] = kern::hashToUnit3(hashes_[i]);
                }
    }
    bool tabled() const { return !hashes_.empty(); }
    glm::uvec3 hash(ivec3 c) const {
        if (!tabled()) return kern::latticeHash3(c, period_, seed_);
        return hashes_[index(wrap(c.x), wrap(c.y), wrap(c.z))];
    }
    /// hashToUnit3(hash) of the cell at wrapped coordinates (tabled() only)
    const vec3& feature(int x, int y, int z) const { return features_[index(x, y, z)]; }
    /// noise.glsl's wrapLattice, for the cells a node's lookups reach ([-1, period]) without
    /// a division
    int wrap(int a) const {
        if (a >= 0 && a < period_) return a;
        if (a == -1) return period_ - 1;
        if (a == period_) return 0;
        const int r = a % period_;
        return r < 0 ? r + period_ : r;
    }

  private:
    size_t index(int x, int y, int z) const { return (size_t(z) * period_ + y) * period_ + x; }
    int period_;
    kern::uint seed_;
    std::vector<glm::uvec3> hashes_;
    std::vector<vec3> features_;
};

/// The octaves of an fBm: period * 2^i and seed + 101 i (noise.glsl's perlinFbm, worleyFbm).
std::vector<OctaveLattice> octaveLattices(int period, int octaves, kern::uint seed) {
    std::vector<OctaveLattice> v;
    for (int i = 0; i < octaves; ++i, period *= 2)
        v.emplace_back(period, seed + kern::uint(i) * 101u);
    return v;
}

/// noise.glsl's perlinNoise, the corners' hashes from the table.
float perlinTabled(vec3 p, const OctaveLattice& t) {
    const vec3 pf = glm::floor(p);
    const ivec3 c = ivec3(int(pf.x), int(pf.y), int(pf.z));
    const vec3 f = p - pf;
    const vec3 u = kern::perlinFade(f);
    const auto corner = [&](int x, int y, int z) {
        return kern::perlinGrad(t.hash(c + ivec3(x, y, z)).x >> 7u,
                                f - vec3(float(x), float(y), float(z)));
    };
    const float n000 = corner(0, 0, 0), n100 = corner(1, 0, 0), n010 = corner(0, 1, 0),
                n110 = corner(1, 1, 0), n001 = corner(0, 0, 1), n101 = corner(1, 0, 1),
                n011 = corner(0, 1, 1), n111 = corner(1, 1, 1);
    const float x00 = glm::mix(n000, n100, u.x), x10 = glm::mix(n010, n110, u.x),
                x01 = glm::mix(n001, n101, u.x), x11 = glm::mix(n011, n111, u.x);
    return glm::mix(glm::mix(x00, x10, u.y), glm::mix(x01, x11, u.y), u.z);
}

/// noise.glsl's worleyNoise at offset f in its cell, feature(dx, dy, dz) the neighbour's point.
template <class Feature> float worleyFrom(vec3 f, Feature&& feature) {
    float d2 = 3.0f;
    for (int dz = -1; dz <= 1; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                const vec3 d = vec3(float(dx), float(dy), float(dz)) + feature(dx, dy, dz) - f;
                d2 = glm::min(d2, glm::dot(d, d));
            }
    return glm::clamp(1.0f - glm::sqrt(d2) * 0.57735026919f, 0.0f, 1.0f);
}

/// noise.glsl's worleyNoise, the feature points from the table (the 3 wrapped coordinates of
/// each axis computed once, not per neighbour), else hashed as the kernels hash them.
float worleyTabled(vec3 p, const OctaveLattice& t) {
    const vec3 pf = glm::floor(p);
    const ivec3 c = ivec3(int(pf.x), int(pf.y), int(pf.z));
    const vec3 f = p - pf;
    if (!t.tabled())
        return worleyFrom(f, [&](int dx, int dy, int dz) {
            return kern::hashToUnit3(t.hash(c + ivec3(dx, dy, dz)));
        });
    int w[3][3];
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k < 3; ++k) w[a][k] = t.wrap(c[a] + k - 1);
    return worleyFrom(f, [&](int dx, int dy, int dz) {
        return t.feature(w[0][dx + 1], w[1][dy + 1], w[2][dz + 1]);
    });
}

/// noise.glsl's perlinFbm / worleyFbm over tabled octaves (gain as given).
template <float (*Noise)(vec3, const OctaveLattice&)>
float fbmTabled(vec3 p, const std::vector<OctaveLattice>& octaves, float gain) {
    float sum = 0.0f;
    float norm = 0.0f;
    float amp = 1.0f;
    float freq = 1.0f;
    for (const OctaveLattice& t : octaves) {
        sum += amp * Noise(p * freq, t);
        norm += amp;
        amp *= gain;
        freq *= 2.0f;
    }
    return sum / norm;
}

} // namespace

std::shared_ptr<const NoiseVolume> bakeCumulusBase(const CumulusDesc& c,
                                                   const std::atomic<bool>* cancel) {
    const kern::CumulusParams P = cumulusParams(c, 0.0f);
    if (c.eval == NoiseEval::Rgba)
        return bakeTileRgba(c.baseBakeResolution, cancel,
                            [&](vec3 q) { return kern::cumulusBaseChannels(P, q); });
    // cloud.glsl's cumulusBaseNoise: perlinWorley at the base lattice
    const int L = P.baseLattice;
    const auto perlin = octaveLattices(L, P.baseOctaves, P.layer.seed);
    const auto worley = octaveLattices(L, 3, P.layer.seed + 7919u);
    return bakeTile(c.baseBakeResolution, cancel, [&](vec3 q) {
        const vec3 p = q * float(L);
        const float perlin01 = 0.5f + 0.5f * fbmTabled<perlinTabled>(p, perlin, 0.5f);
        return kern::perlinWorleyOf(perlin01, fbmTabled<worleyTabled>(p, worley, 0.5f));
    });
}

std::shared_ptr<const NoiseVolume> bakeCumulusDetail(const CumulusDesc& c,
                                                     const std::atomic<bool>* cancel) {
    const kern::CumulusParams P = cumulusParams(c, 0.0f);
    if (c.eval == NoiseEval::Rgba)
        return bakeTileRgba(c.detailBakeResolution, cancel,
                            [&](vec3 q) { return kern::cumulusDetailChannels(P, q); });
    // cloud.glsl's cumulusDetailNoise: worleyFbm at the detail lattice
    const auto worley =
        octaveLattices(P.detailLattice, P.detailOctaves, P.layer.seed + 0x9e3779b9u);
    return bakeTile(c.detailBakeResolution, cancel, [&](vec3 q) {
        return fbmTabled<worleyTabled>(q * float(P.detailLattice), worley, 0.5f);
    });
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
