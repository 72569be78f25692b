#include "core/field.h"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cmath>
#include <limits>
#include <optional>

#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/SampleFromVoxels.h>
#include <tbb/parallel_for.h>

namespace nimbus {

namespace {

inline int wrapIndex(int i, int n) {
    int r = i % n;
    return r < 0 ? r + n : r;
}

} // namespace

float NoiseVolume::sample(vec3 u) const {
    const float n = float(res);
    vec3 w = u - glm::floor(u / n) * n; // [0, res)
    vec3 f0 = glm::floor(w);
    vec3 f = w - f0;
    int x0 = wrapIndex(int(f0.x), res), y0 = wrapIndex(int(f0.y), res),
        z0 = wrapIndex(int(f0.z), res);
    int x1 = wrapIndex(x0 + 1, res), y1 = wrapIndex(y0 + 1, res), z1 = wrapIndex(z0 + 1, res);
    auto at = [&](int x, int y, int z) { return values[(size_t(z) * res + y) * res + x]; };
    float c00 = at(x0, y0, z0) + f.x * (at(x1, y0, z0) - at(x0, y0, z0));
    float c10 = at(x0, y1, z0) + f.x * (at(x1, y1, z0) - at(x0, y1, z0));
    float c01 = at(x0, y0, z1) + f.x * (at(x1, y0, z1) - at(x0, y0, z1));
    float c11 = at(x0, y1, z1) + f.x * (at(x1, y1, z1) - at(x0, y1, z1));
    float c0 = c00 + f.y * (c10 - c00);
    float c1 = c01 + f.y * (c11 - c01);
    return c0 + f.z * (c1 - c0);
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

float cumulusBaseNoise(const CumulusDesc& c, vec3 q) {
    return kern::perlinWorley(q * float(c.baseLattice), c.baseLattice, c.baseOctaves, c.seed);
}

float cumulusDetailNoise(const CumulusDesc& c, vec3 q) {
    return kern::worleyFbm(q * float(c.detailLattice), c.detailLattice, c.detailOctaves, 0.5f,
                           c.seed + 0x9e3779b9u);
}

namespace {

std::shared_ptr<const NoiseVolume> bakeTile(int res, float (*fn)(const CumulusDesc&, vec3),
                                            const CumulusDesc& c) {
    auto vol = std::make_shared<NoiseVolume>();
    vol->res = res;
    vol->values.resize(size_t(res) * res * res);
    tbb::parallel_for(0, res, [&](int z) {
        for (int y = 0; y < res; ++y)
            for (int x = 0; x < res; ++x)
                vol->values[(size_t(z) * res + y) * res + x] =
                    fn(c, vec3(float(x), float(y), float(z)) / float(res));
    });
    return vol;
}

} // namespace

std::shared_ptr<const NoiseVolume> bakeCumulusBase(const CumulusDesc& c) {
    return bakeTile(c.baseBakeResolution, &cumulusBaseNoise, c);
}

std::shared_ptr<const NoiseVolume> bakeCumulusDetail(const CumulusDesc& c) {
    return bakeTile(c.detailBakeResolution, &cumulusDetailNoise, c);
}

kern::CloudLayer cloudLayerFrom(const CumulusDesc& c) {
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
    return L;
}

Field makeField(const FieldDesc& desc, float time, std::shared_ptr<const NoiseVolume> baseBake,
                std::shared_ptr<const NoiseVolume> detailBake) {
    Field f;
    f.kind = desc.kind;
    switch (desc.kind) {
    case FieldKind::Homogeneous:
        f.homogeneous = desc.homogeneous;
        f.box = desc.homogeneous.box;
        break;
    case FieldKind::Vdb: {
        static std::atomic<std::uint64_t> serials{0};
        f.vdb = desc.vdb;
        f.box = desc.vdb.bounds;
        f.serial = ++serials;
        break;
    }
    case FieldKind::Cumulus:
        f.cumulus = desc.cumulus;
        f.box = desc.cumulus.bounds;
        f.layer = cloudLayerFrom(desc.cumulus);
        f.baseOffset = desc.cumulus.wind * time;
        f.detailOffset = (desc.cumulus.wind + desc.cumulus.detailWind) * time;
        f.baseBake = std::move(baseBake);
        f.detailBake = std::move(detailBake);
        break;
    }
    return f;
}

namespace {

const nanovdb::FloatGrid* nanoGrid(const VdbFieldDesc& v) {
    return static_cast<const nanovdb::FloatGrid*>(v.nanoGrid);
}

/// World AABB of an index-space box through the grid's affine map.
Box worldBoxOf(const nanovdb::FloatGrid& g, vec3 lo, vec3 hi) {
    Box b{vec3(std::numeric_limits<float>::max()), vec3(-std::numeric_limits<float>::max())};
    for (int k = 0; k < 8; ++k) {
        const nanovdb::Vec3f c(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
        const nanovdb::Vec3f w = g.indexToWorldF(c);
        b.lo = glm::min(b.lo, vec3(w[0], w[1], w[2]));
        b.hi = glm::max(b.hi, vec3(w[0], w[1], w[2]));
    }
    return b;
}

} // namespace

bool Field::forEachDensityNodeImpl(void (*fn)(void*, const Box&, float), void* ctx) const {
    if (kind != FieldKind::Vdb) return false;
    const nanovdb::FloatGrid* g = nanoGrid(vdb);
    if (!g) return true;
    const auto& tree = g->tree();
    // trilinear sampling at index point x reads the voxels floor(x) .. floor(x) + 1: a node
    // covering voxels [o, o + n) influences index points in (o - 1, o + n)
    auto emit = [&](const nanovdb::Coord& o, int n, float m) {
        if (m <= 0.0f) return;
        const vec3 lo(float(o[0]) - 1.0f, float(o[1]) - 1.0f, float(o[2]) - 1.0f);
        fn(ctx, worldBoxOf(*g, lo, lo + vec3(float(n) + 1.0f)), m * vdb.density);
    };
    const auto* leaf = tree.getFirstLeaf();
    for (uint32_t i = 0; i < tree.nodeCount(0); ++i) emit(leaf[i].origin(), 8, leaf[i].maximum());
    const auto* lower = tree.getFirstLower();
    for (uint32_t i = 0; i < tree.nodeCount(1); ++i)
        if (!lower[i].data()->mValueMask.isOff()) emit(lower[i].origin(), 128, lower[i].maximum());
    const auto* upper = tree.getFirstUpper();
    for (uint32_t i = 0; i < tree.nodeCount(2); ++i)
        if (!upper[i].data()->mValueMask.isOff()) emit(upper[i].origin(), 4096, upper[i].maximum());
    return true;
}

float Field::density(vec3 p) const {
    switch (kind) {
    case FieldKind::Vdb: {
        const nanovdb::FloatGrid* g = nanoGrid(vdb);
        if (!g || !box.contains(p)) return 0.0f;
        const nanovdb::Vec3f x = g->worldToIndexF(nanovdb::Vec3f(p.x, p.y, p.z));
        // one accessor per thread and grid: successive lookups along a ray mostly fall in the
        // same leaf, and the accessor's cached node path skips the walk from the root
        // (measured: getValue was 42% of a frame with a fresh accessor per lookup)
        using Accessor = nanovdb::DefaultReadAccessor<float>;
        // keyed by the Field's serial, not the grid's address: a later frame's grid may be
        // allocated where a freed one was
        thread_local std::uint64_t cachedSerial = 0;
        thread_local std::optional<Accessor> acc;
        if (cachedSerial != serial) {
            acc.emplace(g->getAccessor());
            cachedSerial = serial;
        }
        auto sampler = nanovdb::createSampler<1>(*acc);
        return std::max(0.0f, sampler(x)) * vdb.density;
    }
    case FieldKind::Homogeneous:
        return box.contains(p) ? homogeneous.density : 0.0f;
    case FieldKind::Cumulus: {
        if (!box.contains(p)) return 0.0f;
        const float h = (p.y - layer.bottom) / (layer.top - layer.bottom);
        const vec3 pb = p - baseOffset;
        const float env = kern::towerEnvelope(layer, h, pb.x, pb.z);
        // the base noise is at most 1: nothing can survive the threshold here
        if (kern::cloudShape(layer, env, 1.0f, 0.0f) <= 0.0f) return 0.0f;
        const vec3 qb = pb / cumulus.basePeriod;
        const float base =
            baseBake ? baseBake->sample(qb * float(baseBake->res)) : cumulusBaseNoise(cumulus, qb);
        if (kern::cloudShape(layer, env, base, 0.0f) <= 0.0f) return 0.0f;
        const vec3 qd = (p - detailOffset) / cumulus.detailPeriod;
        const float detail = detailBake ? detailBake->sample(qd * float(detailBake->res))
                                        : cumulusDetailNoise(cumulus, qd);
        return cumulus.density * kern::cloudShape(layer, env, base, detail);
    }
    }
    return 0.0f;
}

float Field::majorant(const Box& b) const {
    Box c{glm::max(b.lo, box.lo), glm::min(b.hi, box.hi)};
    if (c.lo.x > c.hi.x || c.lo.y > c.hi.y || c.lo.z > c.hi.z) return 0.0f;
    switch (kind) {
    case FieldKind::Vdb: {
        float m = 0.0f;
        forEachDensityNode([&](const Box& n, float v) {
            if (n.lo.x <= c.hi.x && n.hi.x >= c.lo.x && n.lo.y <= c.hi.y && n.hi.y >= c.lo.y &&
                n.lo.z <= c.hi.z && n.hi.z >= c.lo.z)
                m = std::max(m, v);
        });
        return m;
    }
    case FieldKind::Homogeneous:
        return homogeneous.density;
    case FieldKind::Cumulus: {
        const float span = layer.top - layer.bottom;
        const float h0 = (c.lo.y - layer.bottom) / span, h1 = (c.hi.y - layer.bottom) / span;
        const vec3 lo = c.lo - baseOffset, hi = c.hi - baseOffset;
        const float envMax = kern::towerEnvelopeBound(layer, h0, h1, lo.x, hi.x, lo.z, hi.z);
        if (kern::cloudShape(layer, envMax, 1.0f, 0.0f) <= 0.0f) return 0.0f;
        float baseMax = 1.0f;
        if (baseBake) {
            const float s = float(baseBake->res) / cumulus.basePeriod;
            baseMax = baseBake->maxOver(lo * s, hi * s);
        }
        return cumulus.density * kern::cloudShape(layer, envMax, baseMax, 0.0f);
    }
    }
    return 0.0f;
}

} // namespace nimbus
