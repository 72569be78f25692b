#include "core/fields/grid.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <new>
#include <optional>
#include <type_traits>

#include <nanovdb/NanoVDB.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace nimbus {

namespace {

const nanovdb::FloatGrid* nanoGrid(const void* g) {
    return static_cast<const nanovdb::FloatGrid*>(g);
}

/// World AABB of an index-space box through the grid's affine map, moved by -shift. Unshifted:
/// the map's float arithmetic (as before shifts existed); shifted: in double, then rounded.
Box worldBoxOf(const nanovdb::FloatGrid& g, vec3 lo, vec3 hi, glm::dvec3 shift) {
    Box b{vec3(std::numeric_limits<float>::max()), vec3(-std::numeric_limits<float>::max())};
    const bool shifted = shift != glm::dvec3(0.0);
    for (int k = 0; k < 8; ++k) {
        const nanovdb::Vec3f c(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
        vec3 p;
        if (shifted) {
            const nanovdb::Vec3d w = g.indexToWorld(nanovdb::Vec3d(c[0], c[1], c[2]));
            for (int a = 0; a < 3; ++a) p[a] = float(w[a] - shift[a]);
        } else {
            const nanovdb::Vec3f w = g.indexToWorldF(c);
            p = vec3(w[0], w[1], w[2]);
        }
        b.lo = glm::min(b.lo, p);
        b.hi = glm::max(b.hi, p);
    }
    if (shifted) {
        // one float ulp outward: the rounding of the shifted corners must not clip the support
        b.lo = glm::vec3(std::nextafter(b.lo.x, -INFINITY), std::nextafter(b.lo.y, -INFINITY),
                         std::nextafter(b.lo.z, -INFINITY));
        b.hi = glm::vec3(std::nextafter(b.hi.x, INFINITY), std::nextafter(b.hi.y, INFINITY),
                         std::nextafter(b.hi.z, INFINITY));
    }
    return b;
}

/// World point p (moved by the field's origin) to g's index space by its inverse map, as
/// NanoVDB's worldToIndexF but with plain multiply-adds: its fmaf is a call into libm on
/// baseline x86-64, 6 per lookup, measured 2.3% of a coarse-step VDB frame.
vec3 indexOf(const nanovdb::FloatGrid& g, vec3 origin, vec3 p) {
    const float* m = g.map().mInvMatF;
    const float d0 = p.x - origin.x, d1 = p.y - origin.y, d2 = p.z - origin.z;
    return vec3(d0 * m[0] + d1 * m[1] + d2 * m[2], d0 * m[3] + d1 * m[4] + d2 * m[5],
                d0 * m[6] + d1 * m[7] + d2 * m[8]);
}

/// The dense copy of g's voxels over its index box grown by kPad on every side; null when the
/// box is empty or holds more than kDenseVoxelsMax. The host's bounds reach half a voxel plus a
/// voxel diagonal beyond that box, so with cubic, axis-aligned voxels every stencil of a point
/// inside them lies in the copy; elsewhere (the corners of a rotated grid's bounds, the short
/// axes of elongated voxels) lookups beyond it read the tree, where there is only background.
std::shared_ptr<const DenseVoxels> denseCopy(const nanovdb::FloatGrid& g) {
    constexpr std::int32_t kPad = 3;
    const auto& ib = g.indexBBox();
    if (ib.empty()) return nullptr;
    auto d = std::make_shared<DenseVoxels>();
    std::int64_t count = 1;
    for (int a = 0; a < 3; ++a) {
        const std::int64_t n = std::int64_t(ib.max()[a]) - ib.min()[a] + 1 + 2 * kPad;
        if (n > kDenseVoxelsMax) return nullptr;
        count *= n;
        if (count > kDenseVoxelsMax) return nullptr;
        d->lo[a] = ib.min()[a] - kPad;
        d->size[a] = std::int32_t(n);
    }
    d->values.resize(size_t(count));
    const std::int64_t sx = std::int64_t(d->size[1]) * d->size[2];
    tbb::parallel_for(tbb::blocked_range<std::int32_t>(0, d->size[0]),
                      [&](const tbb::blocked_range<std::int32_t>& r) {
                          auto acc = g.getAccessor();
                          for (std::int32_t i = r.begin(); i != r.end(); ++i) {
                              float* out = d->values.data() + i * sx;
                              for (std::int32_t j = 0; j < d->size[1]; ++j)
                                  for (std::int32_t k = 0; k < d->size[2]; ++k)
                                      *out++ = acc.getValue(
                                          nanovdb::Coord(d->lo[0] + i, d->lo[1] + j, d->lo[2] + k));
                          }
                      });
    return d;
}

/// The 2x2x2 stencil whose first value is at `o`, in an array laid out x-major and z fastest
/// with strides dx (x) and dy (y): c[a][b][d] = voxel (i + a, j + b, k + d).
void stencilAt(const float* o, std::int64_t dx, std::int64_t dy, float c[2][2][2]) {
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
            for (int d = 0; d < 2; ++d) c[a][b][d] = o[a * dx + b * dy + d];
}

/// The stencil at ijk from the dense copy `dv`; false when dv is null or does not hold it.
bool denseStencil(const DenseVoxels* dv, const nanovdb::Coord& ijk, float c[2][2][2]) {
    if (!dv) return false;
    const std::int64_t i = std::int64_t(ijk[0]) - dv->lo[0], j = std::int64_t(ijk[1]) - dv->lo[1],
                       k = std::int64_t(ijk[2]) - dv->lo[2];
    if (i < 0 || j < 0 || k < 0 || i + 1 >= dv->size[0] || j + 1 >= dv->size[1] ||
        k + 1 >= dv->size[2])
        return false;
    const std::int64_t dy = dv->size[2], dx = std::int64_t(dv->size[1]) * dy;
    stencilAt(dv->values.data() + i * dx + j * dy + k, dx, dy, c);
    return true;
}

/// The stencil at ijk from the tree of `g` (its field's `serial`) through a per-thread accessor.
void treeStencil(const nanovdb::FloatGrid& g, std::uint64_t serial, const nanovdb::Coord& ijk,
                 float c[2][2][2]) {
    // one accessor per thread and grid: successive lookups along a ray mostly fall in the
    // same leaf, and the accessor's cached node path skips the walk from the root
    // (measured: getValue was 42% of a frame with a fresh accessor per lookup)
    using Accessor = nanovdb::DefaultReadAccessor<float>;
    using Leaf = nanovdb::NanoLeaf<float>;
    // keyed by the field's serial, not the grid's address: a later frame's grid may be
    // allocated where a freed one was. One trivially constructed thread_local: in a shared
    // library each thread_local access is a __tls_get_addr call, and one with a constructor
    // adds a call to its initialiser on every access (perf: 3.8% of a coarse-step VDB frame
    // in __tls_get_addr with two variables, 7.7% with one std::optional in a struct)
    static_assert(std::is_trivially_destructible_v<Accessor>);
    struct Cache {
        std::uint64_t serial; ///< 0: none (serials start at 1)
        alignas(Accessor) unsigned char storage[sizeof(Accessor)];
    };
    static thread_local Cache cache;
    if (cache.serial != serial) {
        new (cache.storage) Accessor(g.getAccessor());
        cache.serial = serial;
    }
    const Accessor* acc = std::launder(reinterpret_cast<const Accessor*>(cache.storage));
    // when the 2x2x2 stencil lies in one leaf (343 of its 512 corners) it is read from the leaf
    // the first lookup cached, instead of seven more accessor lookups (getValue was 27% of a
    // thick-cloud pathtrace frame)
    const float first = acc->getValue(ijk);
    constexpr int32_t kMask = int32_t(Leaf::DIM - 1);
    const Leaf* leaf = acc->getNode<Leaf>();
    if ((ijk[0] & kMask) != kMask && (ijk[1] & kMask) != kMask && (ijk[2] & kMask) != kMask &&
        leaf && leaf->origin() == (ijk & ~kMask)) {
        stencilAt(leaf->data()->mValues + Leaf::CoordToOffset(ijk), Leaf::DIM * Leaf::DIM,
                  Leaf::DIM, c);
        return;
    }
    for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
            for (int d = 0; d < 2; ++d)
                c[a][b][d] = a | b | d ? acc->getValue(ijk.offsetBy(a, b, d)) : first;
}

} // namespace

vec3 gridVoxelSize(const GridBinding& b) {
    if (!b.grid) return vec3(0.0f);
    // the lengths of the map's columns, in double: differences of world positions in float
    // vanish far from the origin (1e7 units out a float resolves 1 unit, more than a voxel)
    const double* m = nanoGrid(b.grid)->map().mMatD;
    vec3 size;
    for (int a = 0; a < 3; ++a)
        size[a] = float(std::sqrt(m[a] * m[a] + m[3 + a] * m[3 + a] + m[6 + a] * m[6 + a]));
    return size;
}

GridField makeGridField(const VdbFieldDesc& v, const GridBinding& b) {
    static std::atomic<std::uint64_t> serials{0};
    GridField f;
    f.grid = b.grid;
    f.scale = v.density;
    f.serial = ++serials;
    f.shift = b.shift;
    if (const nanovdb::FloatGrid* g = nanoGrid(b.grid)) {
        const nanovdb::Map& map = g->map();
        for (int a = 0; a < 3; ++a)
            f.origin[a] =
                f.shift == glm::dvec3(0.0) ? map.mVecF[a] : float(map.mVecD[a] - f.shift[a]);
        f.dense = denseCopy(*g);
    }
    return f;
}

GridBinding shiftedGrid(const GridBinding& b, glm::dvec3 shift) {
    GridBinding r = b;
    r.shift = b.shift + shift;
    const nanovdb::FloatGrid* g = nanoGrid(b.grid);
    if (!g) return r;
    // the host's bounds (plugin/vdb/vdb_reader.cpp, vdb_field.cpp): the active voxels' index
    // box grown by half a voxel through the map, padded by the length of a voxel's diagonal;
    // here in double up to the shift, then rounded outward
    const auto& ib = g->indexBBox();
    if (ib.empty()) return r;
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (int k = 0; k < 8; ++k) {
        nanovdb::Vec3d ijk;
        for (int a = 0; a < 3; ++a) ijk[a] = (k >> a) & 1 ? ib.max()[a] + 0.5 : ib.min()[a] - 0.5;
        const nanovdb::Vec3d w = g->indexToWorld(ijk);
        lo = glm::min(lo, glm::dvec3(w[0], w[1], w[2]));
        hi = glm::max(hi, glm::dvec3(w[0], w[1], w[2]));
    }
    const nanovdb::Vec3d v = g->voxelSize();
    const double pad = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int a = 0; a < 3; ++a) {
        r.bounds.lo[a] = std::nextafter(float(lo[a] - pad - r.shift[a]), -INFINITY);
        r.bounds.hi[a] = std::nextafter(float(hi[a] + pad - r.shift[a]), INFINITY);
    }
    return r;
}

void GridField::forEachDensityNode(void (*fn)(void*, const Box&, float), void* ctx) const {
    const nanovdb::FloatGrid* g = nanoGrid(grid);
    if (!g) return;
    const auto& tree = g->tree();
    // trilinear sampling at index point x reads the voxels floor(x) .. floor(x) + 1: a node
    // covering voxels [o, o + n) influences index points in (o - 1, o + n)
    auto emit = [&](const nanovdb::Coord& o, int n, float m) {
        if (m <= 0.0f) return;
        const vec3 lo(float(o[0]) - 1.0f, float(o[1]) - 1.0f, float(o[2]) - 1.0f);
        fn(ctx, worldBoxOf(*g, lo, lo + vec3(float(n) + 1.0f), shift), m * scale);
    };
    const auto* leaf = tree.getFirstLeaf();
    for (uint32_t i = 0; i < tree.nodeCount(0); ++i) emit(leaf[i].origin(), 8, leaf[i].maximum());
    const auto* lower = tree.getFirstLower();
    for (uint32_t i = 0; i < tree.nodeCount(1); ++i)
        if (!lower[i].data()->mValueMask.isOff()) emit(lower[i].origin(), 128, lower[i].maximum());
    const auto* upper = tree.getFirstUpper();
    for (uint32_t i = 0; i < tree.nodeCount(2); ++i)
        if (!upper[i].data()->mValueMask.isOff()) emit(upper[i].origin(), 4096, upper[i].maximum());
}

float GridField::density(vec3 p) const {
    const nanovdb::FloatGrid* g = nanoGrid(grid);
    if (!g) return 0.0f;
    const vec3 x = indexOf(*g, origin, p);
    // trilinear over the voxels floor(x) .. floor(x) + 1, the same arithmetic as NanoVDB's
    // SampleFromVoxels<1> (results bit-identical to it)
    const float fx = std::floor(x[0]), fy = std::floor(x[1]), fz = std::floor(x[2]);
    const float u = x[0] - fx, v = x[1] - fy, w = x[2] - fz;
    const nanovdb::Coord ijk{int32_t(fx), int32_t(fy), int32_t(fz)};
    float c[2][2][2];
    // the dense copy where it holds the stencil (the tree's path was 41% of a dragon march
    // frame, 34% of a thick pathtrace), else the tree
    if (!denseStencil(dense.get(), ijk, c)) treeStencil(*g, serial, ijk, c);
    auto lerp = [](float a, float b, float t) { return a + t * (b - a); };
    const float value =
        lerp(lerp(lerp(c[0][0][0], c[0][0][1], w), lerp(c[0][1][0], c[0][1][1], w), v),
             lerp(lerp(c[1][0][0], c[1][0][1], w), lerp(c[1][1][0], c[1][1][1], w), v), u);
    return std::max(0.0f, value) * scale;
}

float GridField::majorant(const Box& c) const {
    float m = 0.0f;
    auto visit = [&](const Box& n, float v) {
        if (n.lo.x <= c.hi.x && n.hi.x >= c.lo.x && n.lo.y <= c.hi.y && n.hi.y >= c.lo.y &&
            n.lo.z <= c.hi.z && n.hi.z >= c.lo.z)
            m = std::max(m, v);
    };
    forEachDensityNode(
        [](void* ctx, const Box& b, float v) { (*static_cast<decltype(visit)*>(ctx))(b, v); },
        &visit);
    return m;
}

bool GridField::voxelMajorant(const Box& b, float& m) const {
    const nanovdb::FloatGrid* g = nanoGrid(grid);
    const DenseVoxels* dv = dense.get();
    if (!g || !dv || !(scale >= 0.0f)) return false;
    // the box's corners to index space as density() maps them; the stencils of the index
    // points in their bounds read the voxels floor(x) .. floor(x) + 1, here widened by a
    // thousandth of a voxel for the map's rounding
    vec3 ilo(std::numeric_limits<float>::max()), ihi(-std::numeric_limits<float>::max());
    for (int k = 0; k < 8; ++k) {
        const vec3 x = indexOf(
            *g, origin,
            vec3(k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y, k & 4 ? b.hi.z : b.lo.z));
        ilo = glm::min(ilo, x);
        ihi = glm::max(ihi, x);
    }
    std::int64_t c0[3], c1[3];
    bool outside = false; // stencils reaching past the copy read the background there
    for (int a = 0; a < 3; ++a) {
        if (!(ilo[a] > -2e9f && ihi[a] < 2e9f)) return false; // beyond the index range
        const std::int64_t i0 = std::int64_t(std::floor(ilo[a] - 1e-3f));
        const std::int64_t i1 = std::int64_t(std::floor(ihi[a] + 1e-3f)) + 1;
        c0[a] = std::max<std::int64_t>(i0, dv->lo[a]);
        c1[a] = std::min<std::int64_t>(i1, std::int64_t(dv->lo[a]) + dv->size[a] - 1);
        outside = outside || c0[a] != i0 || c1[a] != i1 || c0[a] > c1[a];
    }
    float vmax = outside ? g->tree().background() : -std::numeric_limits<float>::max();
    if (c0[0] <= c1[0] && c0[1] <= c1[1] && c0[2] <= c1[2]) {
        const std::int64_t dy = dv->size[2], dx = std::int64_t(dv->size[1]) * dy;
        for (std::int64_t i = c0[0]; i <= c1[0]; ++i)
            for (std::int64_t j = c0[1]; j <= c1[1]; ++j) {
                const float* row = dv->values.data() + (i - dv->lo[0]) * dx + (j - dv->lo[1]) * dy;
                for (std::int64_t k = c0[2] - dv->lo[2]; k <= c1[2] - dv->lo[2]; ++k)
                    vmax = std::max(vmax, row[k]);
            }
    }
    m = std::max(0.0f, vmax) * scale; // density() clamps the interpolated value at 0
    return true;
}

} // namespace nimbus
