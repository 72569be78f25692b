#include "core/sim/automaton.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace nimbus::sim {

namespace {

std::uint64_t fmix64(std::uint64_t k) {
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdULL;
    k ^= k >> 33;
    k *= 0xc4ceb9fe1a85ec53ULL;
    k ^= k >> 33;
    return k;
}

std::uint64_t stepKey(std::uint64_t seed, std::uint64_t step) {
    return fmix64(fmix64(seed + 0x9E3779B97F4A7C15ULL) ^ (step * 0xD6E8FEB86659FD93ULL + 1));
}

/// Uniform in [0, 1) from the ellipsoid stream: (seed, step, k, j).
float controlUniform(std::uint64_t seed, std::uint64_t step, std::uint64_t k, std::uint64_t j) {
    const std::uint64_t h =
        fmix64(stepKey(seed ^ 0xA5A5A5A55A5A5A5AULL, step) ^ fmix64(k * 64 + j + 1));
    return float(h >> 40) * (1.0f / 16777216.0f);
}

} // namespace

CellBits::CellBits(ivec3 r) : res(r), wordsPerRow((r.x + 63) / 64) {
    const size_t n = size_t(wordsPerRow) * size_t(r.y) * size_t(r.z);
    hum.assign(n, 0);
    act.assign(n, 0);
    cld.assign(n, 0);
}

std::uint64_t CellBits::validMask(int w) const {
    if (w < wordsPerRow - 1) return ~std::uint64_t(0);
    const int rem = res.x - 64 * (wordsPerRow - 1);
    return rem >= 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << rem) - 1;
}

std::uint64_t countBits(const std::vector<std::uint64_t>& f) {
    std::uint64_t n = 0;
    for (std::uint64_t w : f) n += std::uint64_t(std::popcount(w));
    return n;
}

double columnCover(const CellBits& b) {
    if (b.res.x <= 0 || b.res.z <= 0) return 0.0;
    std::uint64_t n = 0;
    for (int z = 0; z < b.res.z; ++z)
        for (int w = 0; w < b.wordsPerRow; ++w) {
            std::uint64_t any = 0;
            for (int y = 0; y < b.res.y; ++y) any |= b.cld[b.rowWord(y, z) + w];
            n += std::uint64_t(std::popcount(any));
        }
    return double(n) / (double(b.res.x) * double(b.res.z));
}

vec3 currentRadii(const RegionEllipsoid& e, float shrinkTime) {
    const float left = e.lifetime - e.age;
    if (shrinkTime <= 0.0f || left >= shrinkTime) return e.radii;
    return e.radii * std::max(0.0f, left / shrinkTime);
}

std::uint64_t cellHash(std::uint64_t seed, std::uint64_t step, std::uint64_t cell) {
    return fmix64(stepKey(seed, step) ^ (cell * 0x9E3779B97F4A7C15ULL));
}

std::uint32_t probabilityThreshold(float p) {
    if (!(p > 0.0f)) return 0;
    if (p >= 1.0f) return 1u << 21;
    return std::uint32_t(std::lround(double(p) * double(1u << 21)));
}

void growthStep(CellBits& b, std::vector<std::uint64_t>& scratch) {
    scratch = b.act; // the old act: every neighbourhood reads it
    const std::vector<std::uint64_t>& A = scratch;
    const int W = b.wordsPerRow, ny = b.res.y, nz = b.res.z;
    const std::uint64_t lastMask = b.validMask(W - 1);
    tbb::parallel_for(tbb::blocked_range<int>(0, nz), [&](const tbb::blocked_range<int>& r) {
        for (int z = r.begin(); z < r.end(); ++z)
            for (int y = 0; y < ny; ++y) {
                const size_t row = b.rowWord(y, z);
                // rows of the neighbours (null: outside the grid)
                const std::uint64_t* nb[7];
                int k = 0;
                if (y > 0) nb[k++] = &A[b.rowWord(y - 1, z)];
                if (y + 1 < ny) nb[k++] = &A[b.rowWord(y + 1, z)];
                if (y > 1) nb[k++] = &A[b.rowWord(y - 2, z)]; // 2 below only
                if (z > 0) nb[k++] = &A[b.rowWord(y, z - 1)];
                if (z + 1 < nz) nb[k++] = &A[b.rowWord(y, z + 1)];
                if (z > 1) nb[k++] = &A[b.rowWord(y, z - 2)];
                if (z + 2 < nz) nb[k++] = &A[b.rowWord(y, z + 2)];
                const std::uint64_t* a = &A[row];
                for (int w = 0; w < W; ++w) {
                    const std::uint64_t c = a[w];
                    const std::uint64_t prev = w > 0 ? a[w - 1] : 0;
                    const std::uint64_t next = w + 1 < W ? a[w + 1] : 0;
                    // bit i of (c << 1) | (prev >> 63) is the act of x - 1, and so on
                    std::uint64_t f = (c << 1) | (prev >> 63);
                    f |= (c >> 1) | (next << 63);
                    f |= (c << 2) | (prev >> 62);
                    f |= (c >> 2) | (next << 62);
                    for (int i = 0; i < k; ++i) f |= nb[i][w];
                    const std::uint64_t h = b.hum[row + w];
                    b.hum[row + w] = h & ~c;
                    b.cld[row + w] |= c;
                    std::uint64_t na = ~c & h & f;
                    if (w == W - 1) na &= lastMask;
                    b.act[row + w] = na;
                }
            }
    });
}

void regionWeights(const std::vector<RegionEllipsoid>& ellipsoids, float shrinkTime,
                   RegionWeights& out) {
    const ivec3 res = out.res;
    const int W = (res.x + 63) / 64;
    const size_t cells = size_t(res.x) * res.y * res.z;
    out.w.assign(cells, 0);
    out.inside.assign(size_t(W) * res.y * res.z, 0);
    struct Box {
        vec3 c, r, inv;
        ivec3 lo, hi;
    };
    std::vector<Box> boxes;
    for (const RegionEllipsoid& e : ellipsoids) {
        const vec3 r = currentRadii(e, shrinkTime);
        if (!(r.x > 0.0f && r.y > 0.0f && r.z > 0.0f)) continue;
        // cell (x, y, z) has its centre at (x + 0.5, y + 0.5, z + 0.5)
        const ivec3 lo = glm::max(ivec3(glm::floor(e.centre - r - 0.5f)), ivec3(0));
        const ivec3 hi = glm::min(ivec3(glm::ceil(e.centre + r - 0.5f)), res - 1);
        if (lo.x > hi.x || lo.y > hi.y || lo.z > hi.z) continue;
        boxes.push_back({e.centre, r, 1.0f / r, lo, hi});
    }
    tbb::parallel_for(tbb::blocked_range<int>(0, res.z), [&](const tbb::blocked_range<int>& rz) {
        for (const Box& bx : boxes) {
            const int z0 = std::max(bx.lo.z, rz.begin()), z1 = std::min(bx.hi.z, rz.end() - 1);
            for (int z = z0; z <= z1; ++z) {
                const float dz = (float(z) + 0.5f - bx.c.z) * bx.inv.z;
                for (int y = bx.lo.y; y <= bx.hi.y; ++y) {
                    const float dy = (float(y) + 0.5f - bx.c.y) * bx.inv.y;
                    const float dyz = dy * dy + dz * dz;
                    if (dyz >= 1.0f) continue;
                    // the cells of this row inside the ellipsoid (one more on each side for
                    // rounding; the falloff is 0 there)
                    const float half = bx.r.x * std::sqrt(1.0f - dyz);
                    const int x0 = std::max(bx.lo.x, int(std::floor(bx.c.x - half - 0.5f)));
                    const int x1 = std::min(bx.hi.x, int(std::ceil(bx.c.x + half - 0.5f)));
                    std::uint16_t* row = &out.w[out.index(0, y, z)];
                    std::uint64_t* bits = &out.inside[(size_t(z) * res.y + y) * W];
                    if (x0 > x1) continue;
                    const float ox = 0.5f - bx.c.x;
                    for (int x = x0; x <= x1; ++x) {
                        // regionFalloff without a float comparison (GCC vectorises this):
                        // t |t| is (1 - d2)^2 inside and negative outside, clamped as an int
                        const float dx = (float(x) + ox) * bx.inv.x;
                        const float t = 1.0f - (dx * dx + dyz);
                        int q = int(t * std::fabs(t) * 65535.0f + 0.5f);
                        q = q > 0 ? q : 0;
                        const int o = row[x];
                        row[x] = std::uint16_t(o > q ? o : q);
                    }
                    // `inside` may flag a few cells of weight 0 at the ends: they draw numbers
                    // that change nothing (every probability there is 0, extinction is pExt)
                    for (int wd = x0 >> 6; wd <= x1 >> 6; ++wd) {
                        const int a = std::max(x0, wd * 64) - wd * 64;
                        const int e = std::min(x1, wd * 64 + 63) - wd * 64;
                        const std::uint64_t hiMask =
                            e == 63 ? ~std::uint64_t(0) : (std::uint64_t(1) << (e + 1)) - 1;
                        bits[wd] |= hiMask & ~((std::uint64_t(1) << a) - 1);
                    }
                }
            }
        }
    });
}

void stochasticStep(CellBits& b, const RegionWeights& rw, const AutomatonParams& p,
                    std::uint64_t step) {
    const std::uint32_t tHum = probabilityThreshold(p.pHum), tAct = probabilityThreshold(p.pAct),
                        tExt = probabilityThreshold(p.pExt);
    const std::uint64_t key = stepKey(p.seed, step);
    const int W = b.wordsPerRow, nx = b.res.x, ny = b.res.y;
    tbb::parallel_for(tbb::blocked_range<int>(0, b.res.z), [&](const tbb::blocked_range<int>& r) {
        for (int z = r.begin(); z < r.end(); ++z)
            for (int y = 0; y < ny; ++y) {
                const size_t row = b.rowWord(y, z);
                const size_t cellRow = (size_t(z) * ny + y) * size_t(nx);
                for (int w = 0; w < W; ++w) {
                    const std::uint64_t cld = b.cld[row + w];
                    // cells with weight 0 and no cloud draw nothing (every probability is 0)
                    std::uint64_t todo = rw.inside[row + w] | (tExt ? cld : 0);
                    if (!todo) continue;
                    std::uint64_t hm = 0, am = 0, em = 0;
                    while (todo) {
                        const int i = std::countr_zero(todo);
                        todo &= todo - 1;
                        const size_t cell = cellRow + size_t(w) * 64 + size_t(i);
                        const std::uint64_t h = fmix64(key ^ (cell * 0x9E3779B97F4A7C15ULL));
                        const std::uint32_t q = rw.w[cell];
                        const std::uint64_t bit = std::uint64_t(1) << i;
                        if ((cld & bit) && fires(uniformExt(h), tExt, 65535u - q)) em |= bit;
                        if (fires(uniformHum(h), tHum, q)) hm |= bit;
                        if (fires(uniformAct(h), tAct, q)) am |= bit;
                    }
                    b.cld[row + w] = cld & ~em;
                    b.hum[row + w] |= hm;
                    b.act[row + w] |= am;
                }
            }
    });
}

namespace {

constexpr std::uint64_t kSpawnStream = 1, kInitStream = 2;

RegionEllipsoid spawnEllipsoid(const AutomatonParams& p, std::uint64_t step, std::uint64_t k,
                               std::uint64_t stream, bool randomAge) {
    auto u = [&](int j) { return controlUniform(p.seed, step, stream * 4096 + k, j); };
    RegionEllipsoid e;
    const float m = p.regionMargin;
    e.centre.x = -m + u(0) * (float(p.res.x) + 2.0f * m);
    e.centre.z = -m + u(1) * (float(p.res.z) + 2.0f * m);
    e.centre.y = float(p.res.y) * (p.layerLo + u(2) * (p.layerHi - p.layerLo));
    const float size = std::max(1.0f, p.sizeMean + p.sizeVar * (2.0f * u(3) - 1.0f));
    const float aspect = 0.75f + 0.5f * u(4); // x/z elongation
    e.radii = vec3(size * aspect, std::max(1.0f, size * p.heightRatio), size / aspect);
    e.lifetime = std::max(p.dt, p.lifeMean + p.lifeVar * (2.0f * u(5) - 1.0f));
    e.age = randomAge ? u(6) * e.lifetime : 0.0f;
    return e;
}

bool insideRegion(const AutomatonParams& p, const RegionEllipsoid& e) {
    const float m = p.regionMargin;
    return e.centre.x >= -m && e.centre.x <= float(p.res.x) + m && e.centre.z >= -m &&
           e.centre.z <= float(p.res.z) + m;
}

/// Seconds of life left before an ellipsoid starts shrinking (<= 0: shrinking).
float beforeShrink(const AutomatonParams& p, const RegionEllipsoid& e) {
    return e.lifetime - p.shrinkTime - e.age;
}

} // namespace

AutomatonState initialState(const AutomatonParams& p) {
    AutomatonState s;
    s.bits = CellBits(p.res);
    if (p.initial == InitialCells::Full)
        for (int z = 0; z < p.res.z; ++z)
            for (int y = 0; y < p.res.y; ++y)
                for (int w = 0; w < s.bits.wordsPerRow; ++w)
                    s.bits.cld[s.bits.rowWord(y, z) + w] = s.bits.validMask(w);
    s.targetCount = std::clamp(p.cloudDensity, p.minEllipsoids, p.maxEllipsoids);
    for (int k = 0; k < s.targetCount; ++k)
        s.ellipsoids.push_back(spawnEllipsoid(p, 0, std::uint64_t(k), kInitStream, true));
    s.cover = columnCover(s.bits);
    return s;
}

void updateEllipsoids(AutomatonState& s, const AutomatonParams& p) {
    const std::uint64_t n = s.step;                // the step just completed
    const double t = double(n - 1) * double(p.dt); // the start of the step just completed
    for (RegionEllipsoid& e : s.ellipsoids) {
        const vec3 v = p.motion ? p.motion(e.centre, t, p.motionUser) : p.wind;
        e.centre += v * p.dt;
        e.age += p.dt;
    }
    std::erase_if(s.ellipsoids, [&](const RegionEllipsoid& e) {
        return e.age >= e.lifetime || !insideRegion(p, e);
    });
    // density adaptation: one change of the count per adaptPeriod steps at most
    if (n >= s.lastAdapt + std::uint64_t(std::max(1, p.adaptPeriod))) {
        int t = s.targetCount;
        if (s.cover < double(p.targetCover - p.coverTolerance)) ++t;
        if (s.cover > double(p.targetCover + p.coverTolerance)) --t;
        t = std::clamp(t, p.minEllipsoids, p.maxEllipsoids);
        if (t != s.targetCount) {
            s.targetCount = t;
            s.lastAdapt = n;
        }
    }
    // hold the count of ellipsoids not yet shrinking at targetCount
    int live = 0;
    for (const RegionEllipsoid& e : s.ellipsoids) live += beforeShrink(p, e) > 0.0f;
    while (live > s.targetCount) { // retire the one with the most life left: it starts shrinking
        RegionEllipsoid* best = nullptr;
        for (RegionEllipsoid& e : s.ellipsoids)
            if (beforeShrink(p, e) > 0.0f && (!best || beforeShrink(p, e) > beforeShrink(p, *best)))
                best = &e;
        best->lifetime = best->age + p.shrinkTime;
        --live;
    }
    for (std::uint64_t k = 0; live < s.targetCount; ++k, ++live)
        s.ellipsoids.push_back(spawnEllipsoid(p, n, k, kSpawnStream, false));
}

void step(AutomatonState& s, const AutomatonParams& p, Workspace& ws) {
    growthStep(s.bits, ws.act);
    ws.weights.res = p.res;
    regionWeights(s.ellipsoids, p.shrinkTime, ws.weights);
    stochasticStep(s.bits, ws.weights, p, s.step);
    ++s.step;
    s.cover = columnCover(s.bits);
    updateEllipsoids(s, p);
}

AutomatonState stateAtStep(const AutomatonParams& p, std::uint64_t n,
                           const AutomatonState& checkpoint) {
    AutomatonState s = checkpoint;
    Workspace ws;
    while (s.step < n) step(s, p, ws);
    return s;
}

AutomatonState stateAtStep(const AutomatonParams& p, std::uint64_t n) {
    return stateAtStep(p, n, initialState(p));
}

const char* validate(const AutomatonParams& p) {
    if (p.res.x < 1 || p.res.y < 1 || p.res.z < 1) return "res: every size must be >= 1";
    if (double(p.res.x) * p.res.y * p.res.z > 4.0e9) return "res: more than 4e9 cells";
    if (!(p.dt > 0.0f) || !std::isfinite(p.dt)) return "dt must be finite and > 0";
    if (!std::isfinite(p.wind.x) || !std::isfinite(p.wind.y) || !std::isfinite(p.wind.z))
        return "wind must be finite";
    for (float q : {p.pHum, p.pAct, p.pExt})
        if (!(q >= 0.0f && q <= 1.0f)) return "pHum, pAct and pExt must lie in [0, 1]";
    if (p.minEllipsoids < 0 || p.maxEllipsoids < p.minEllipsoids || p.maxEllipsoids > 100000)
        return "need 0 <= minEllipsoids <= maxEllipsoids <= 100000";
    if (p.cloudDensity < 0) return "cloudDensity must be >= 0";
    if (!(p.targetCover >= 0.0f && p.targetCover <= 1.0f) || !(p.coverTolerance >= 0.0f))
        return "targetCover must lie in [0, 1], coverTolerance >= 0";
    if (!(p.sizeMean > 0.0f) || !(p.sizeVar >= 0.0f) || !std::isfinite(p.sizeMean + p.sizeVar))
        return "sizeMean must be > 0, sizeVar >= 0 (finite)";
    if (!(p.heightRatio > 0.0f) || !std::isfinite(p.heightRatio)) return "heightRatio must be > 0";
    if (!(p.lifeMean > 0.0f) || !(p.lifeVar >= 0.0f) || !std::isfinite(p.lifeMean + p.lifeVar))
        return "lifeMean must be > 0, lifeVar >= 0 (finite)";
    if (!(p.shrinkTime >= 0.0f) || !std::isfinite(p.shrinkTime)) return "shrinkTime must be >= 0";
    if (!(p.regionMargin >= 0.0f) || !std::isfinite(p.regionMargin))
        return "regionMargin must be >= 0";
    if (!(p.layerLo >= 0.0f && p.layerLo <= p.layerHi && p.layerHi <= 1.0f))
        return "need 0 <= layerLo <= layerHi <= 1";
    return "";
}

void smoothDensity(const CellBits& b, DensityGrid& out, std::vector<std::uint8_t>& scratch) {
    const int nx = b.res.x, ny = b.res.y, nz = b.res.z, W = b.wordsPerRow;
    const size_t slice = size_t(nx) * ny;
    out.res = b.res;
    out.v.resize(slice * nz);
    scratch.resize(slice * nz);
    // which slices hold no cloud: their (x, y) pass is all zeros
    std::vector<std::uint8_t> sliceEmpty(static_cast<size_t>(nz));
    for (int z = 0; z < nz; ++z) {
        std::uint64_t any = 0;
        const std::uint64_t* c = &b.cld[b.rowWord(0, z)];
        for (size_t i = 0; i < size_t(W) * ny; ++i) any |= c[i];
        sliceEmpty[z] = any == 0;
    }
    // the x pass 8 cells at a time: 10 bits (x - 1 .. x + 8) -> 8 bytes b(x-1) + 2 b(x) + b(x+1)
    static const std::vector<std::uint64_t> table = [] {
        std::vector<std::uint64_t> t(1024);
        for (unsigned i = 0; i < 1024; ++i)
            for (unsigned k = 0; k < 8; ++k) {
                const unsigned v = ((i >> k) & 1) + 2 * ((i >> (k + 1)) & 1) + ((i >> (k + 2)) & 1);
                t[i] |= std::uint64_t(v) << (8 * k);
            }
        return t;
    }();
    const size_t stride = size_t(W) * 64; // x-pass rows padded to whole words
    // pass 1 (per z slice): x then y, into scratch as 0..16
    tbb::parallel_for(tbb::blocked_range<int>(0, nz), [&](const tbb::blocked_range<int>& r) {
        std::vector<std::uint8_t> xs(stride * (ny + 1), 0); // the last row: zeros (outside)
        const std::uint8_t* zero = &xs[stride * ny];
        for (int z = r.begin(); z < r.end(); ++z) {
            std::uint8_t* s = &scratch[slice * z];
            if (sliceEmpty[z]) {
                std::memset(s, 0, slice);
                continue;
            }
            for (int y = 0; y < ny; ++y) {
                const std::uint64_t* c = &b.cld[b.rowWord(y, z)];
                std::uint8_t* o = &xs[size_t(y) * stride];
                bool rowEmpty = true;
                for (int w = 0; w < W; ++w) rowEmpty &= c[w] == 0;
                if (rowEmpty) {
                    std::memset(o, 0, size_t(nx));
                    continue;
                }
                for (int w = 0; w < W; ++w) {
                    const std::uint64_t v = c[w];
                    const std::uint64_t left = w > 0 ? c[w - 1] >> 63 : 0;
                    const std::uint64_t right = w + 1 < W ? c[w + 1] & 1 : 0;
                    // bit 0: x - 1, bits 1..64: the word, bit 65: x + 64 (as two halves)
                    for (int k = 0; k < 8; ++k) {
                        const std::uint64_t lo = k == 0 ? left : (v >> (8 * k - 1)) & 1;
                        const std::uint64_t hi = k == 7 ? right : (v >> (8 * k + 8)) & 1;
                        const std::uint64_t idx = lo | (((v >> (8 * k)) & 0xFF) << 1) | (hi << 9);
                        std::memcpy(o + size_t(w) * 64 + size_t(k) * 8, &table[idx], 8);
                    }
                }
            }
            for (int y = 0; y < ny; ++y) {
                const std::uint8_t* m = &xs[size_t(y) * stride];
                const std::uint8_t* d = y > 0 ? &xs[size_t(y - 1) * stride] : zero;
                const std::uint8_t* u = y + 1 < ny ? &xs[size_t(y + 1) * stride] : zero;
                std::uint8_t* o = s + size_t(y) * nx;
                const int n = nx; // a local bound: the byte stores may alias the captured one
                for (int x = 0; x < n; ++x) o[x] = std::uint8_t(2 * m[x] + d[x] + u[x]);
            }
        }
    });
    // pass 2: z, into floats k / 64
    tbb::parallel_for(tbb::blocked_range<int>(0, nz), [&](const tbb::blocked_range<int>& r) {
        std::vector<std::uint8_t> zeros(slice, 0);
        for (int z = r.begin(); z < r.end(); ++z) {
            float* o = &out.v[slice * z];
            const bool de = z == 0 || sliceEmpty[z - 1], ue = z + 1 == nz || sliceEmpty[z + 1];
            if (sliceEmpty[z] && de && ue) {
                std::fill(o, o + slice, 0.0f);
                continue;
            }
            const std::uint8_t* m = &scratch[slice * z];
            const std::uint8_t* d = z > 0 ? &scratch[slice * (z - 1)] : zeros.data();
            const std::uint8_t* u = z + 1 < nz ? &scratch[slice * (z + 1)] : zeros.data();
            for (size_t i = 0; i < slice; ++i)
                o[i] = float(2 * m[i] + d[i] + u[i]) * (1.0f / 64.0f);
        }
    });
}

void lerpDensity(const DensityGrid& a, const DensityGrid& b, float s, DensityGrid& out) {
    out.res = a.res;
    out.v.resize(a.v.size());
    const size_t n = a.v.size();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1 << 16),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i < r.end(); ++i)
                              out.v[i] = a.v[i] + s * (b.v[i] - a.v[i]);
                      });
}

void blockMaxima(const DensityGrid& d, int block, int apron, BlockMaxima& out) {
    block = std::max(1, block);
    apron = std::max(0, apron);
    out.block = block;
    out.res = blockMaximaRes(d.res, block);
    out.v.assign(size_t(out.res.x) * out.res.y * out.res.z, 0.0f);
    tbb::parallel_for(tbb::blocked_range<int>(0, out.res.z), [&](const tbb::blocked_range<int>& r) {
        std::vector<float> rowMax(size_t(d.res.x));
        for (int bz = r.begin(); bz < r.end(); ++bz)
            for (int by = 0; by < out.res.y; ++by) {
                const int z0 = std::max(0, bz * block - apron),
                          z1 = std::min(d.res.z, (bz + 1) * block + apron);
                const int y0 = std::max(0, by * block - apron),
                          y1 = std::min(d.res.y, (by + 1) * block + apron);
                std::fill(rowMax.begin(), rowMax.end(), 0.0f);
                for (int z = z0; z < z1; ++z)
                    for (int y = y0; y < y1; ++y) {
                        const float* row = &d.v[(size_t(z) * d.res.y + y) * d.res.x];
                        for (int x = 0; x < d.res.x; ++x) rowMax[x] = std::max(rowMax[x], row[x]);
                    }
                float* o = &out.v[(size_t(bz) * out.res.y + by) * out.res.x];
                for (int bx = 0; bx < out.res.x; ++bx) {
                    const int x0 = std::max(0, bx * block - apron),
                              x1 = std::min(d.res.x, (bx + 1) * block + apron);
                    float m = 0.0f;
                    for (int x = x0; x < x1; ++x) m = std::max(m, rowMax[x]);
                    o[bx] = m;
                }
            }
    });
}

Simulation::Simulation(const AutomatonParams& p, std::uint64_t checkpointEvery)
    : p_(p), state_(initialState(p)), checkpointEvery_(checkpointEvery) {
    checkpoints_.push_back(state_);
}

void Simulation::advanceTo(std::uint64_t n) {
    if (n == 0) n = 1;
    if (state_.step == n && havePrev_) return;
    if (state_.step > n - 1) { // back in time: from the last checkpoint at or before n - 1
        size_t k = checkpointEvery_ ? size_t((n - 1) / checkpointEvery_) : 0;
        k = std::min(k, checkpoints_.size() - 1);
        state_ = checkpoints_[k];
        havePrev_ = false;
    }
    bool curValid = havePrev_; // cur_ holds state_.step's grid
    while (state_.step < n) {
        if (state_.step + 1 == n) {
            if (curValid)
                std::swap(prev_, cur_);
            else
                smoothDensity(state_.bits, prev_, smoothScratch_);
        }
        step(state_, p_, ws_);
        curValid = false;
        if (checkpointEvery_ && state_.step % checkpointEvery_ == 0 &&
            state_.step / checkpointEvery_ == checkpoints_.size())
            checkpoints_.push_back(state_);
    }
    smoothDensity(state_.bits, cur_, smoothScratch_);
    havePrev_ = true;
}

void Simulation::densityAt(double t, DensityGrid& out) {
    const double u = std::max(0.0, t) / double(p_.dt);
    const auto n0 = std::uint64_t(std::floor(u));
    advanceTo(n0 + 1);
    lerpDensity(prev_, cur_, float(u - double(n0)), out);
}

} // namespace nimbus::sim
