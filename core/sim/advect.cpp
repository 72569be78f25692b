#include "core/sim/advect.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include <immintrin.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace nimbus::sim {

namespace {

/// a + t (b - a): exactly a when a == b (a uniform field stays bit-exact through a lookup).
inline float lerp(float a, float b, float t) {
    return a + t * (b - a);
}

bool finite3(vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

/// The trilinear stencil of index position q in a velocity grid: the lower and upper sample of
/// each axis and the weight of the upper, clamped to the samples (nearest edge outside).
[[gnu::always_inline]] inline void gridCorner(float x, int n, int& i0, int& i1, float& f) {
    x = x > 0.0f ? x : 0.0f; // also maps NaN to 0
    x = std::min(x, float(n - 1));
    i0 = int(x);
    f = x - float(i0);
    i1 = std::min(i0 + 1, n - 1);
}

[[gnu::always_inline]] inline void trilinearCorners(const VelocityGrid& g, vec3 q, int i0[3],
                                                    int i1[3], float f[3]) {
    for (int a = 0; a < 3; ++a) gridCorner(q[a], g.res[a], i0[a], i1[a], f[a]);
}

/// Component c of a velocity grid, trilinear, at grid index position q (sample k at q = k),
/// clamped to the samples (nearest edge outside).
[[gnu::always_inline]] inline float gridComponent(const VelocityGrid& g, int c, vec3 q) {
    int i0[3], i1[3];
    float f[3];
    trilinearCorners(g, q, i0, i1, f);
    auto at = [&](int x, int y, int z) { return g.v[g.index(x, y, z)][c]; };
    const float c00 = lerp(at(i0[0], i0[1], i0[2]), at(i1[0], i0[1], i0[2]), f[0]);
    const float c10 = lerp(at(i0[0], i1[1], i0[2]), at(i1[0], i1[1], i0[2]), f[0]);
    const float c01 = lerp(at(i0[0], i0[1], i1[2]), at(i1[0], i0[1], i1[2]), f[0]);
    const float c11 = lerp(at(i0[0], i1[1], i1[2]), at(i1[0], i1[1], i1[2]), f[0]);
    return lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2]);
}

/// All three components of a centred grid at once (one set of indices and weights).
[[gnu::always_inline]] inline vec3 gridVector(const VelocityGrid& g, vec3 q) {
    int i0[3], i1[3];
    float f[3];
    trilinearCorners(g, q, i0, i1, f);
    auto at = [&](int x, int y, int z) { return g.v[g.index(x, y, z)]; };
    auto lerp3 = [](vec3 a, vec3 b, float t) {
        return vec3(lerp(a.x, b.x, t), lerp(a.y, b.y, t), lerp(a.z, b.z, t));
    };
    const vec3 c00 = lerp3(at(i0[0], i0[1], i0[2]), at(i1[0], i0[1], i0[2]), f[0]);
    const vec3 c10 = lerp3(at(i0[0], i1[1], i0[2]), at(i1[0], i1[1], i0[2]), f[0]);
    const vec3 c01 = lerp3(at(i0[0], i0[1], i1[2]), at(i1[0], i0[1], i1[2]), f[0]);
    const vec3 c11 = lerp3(at(i0[0], i1[1], i1[2]), at(i1[0], i1[1], i1[2]), f[0]);
    return lerp3(lerp3(c00, c10, f[1]), lerp3(c01, c11, f[1]), f[2]);
}

[[gnu::always_inline]] inline vec3 layered(const std::vector<WindLayer>& L, float y) {
    if (y <= L.front().altitude) return L.front().wind;
    if (y >= L.back().altitude) return L.back().wind;
    size_t k = 1;
    while (L[k].altitude < y) ++k;
    const WindLayer& a = L[k - 1];
    const WindLayer& b = L[k];
    const float t = (y - a.altitude) / (b.altitude - a.altitude);
    return vec3(lerp(a.wind.x, b.wind.x, t), lerp(a.wind.y, b.wind.y, t),
                lerp(a.wind.z, b.wind.z, t));
}

/// The velocity in density-grid cells per second at a density-grid index position p.
struct Sampler {
    const VelocityField& f;
    vec3 origin; ///< density grid frame
    float h, invH;
    vec3 gOff; ///< grid index position = p * gScale + gOff (cell-corner convention)
    float gScale = 1.0f;

    Sampler(const VelocityField& field, const GridFrame& frame)
        : f(field), origin(frame.origin), h(frame.voxelSize), invH(1.0f / frame.voxelSize) {
        if (f.grid) {
            gScale = h / f.grid->frame.voxelSize;
            gOff = (origin - f.grid->frame.origin) / f.grid->frame.voxelSize;
        }
    }

    [[gnu::always_inline]] vec3 operator()(vec3 p) const {
        switch (f.kind) {
        case VelocityKind::Uniform:
            return f.uniform * invH;
        case VelocityKind::Layered:
            return layered(f.layers, origin.y + p.y * h) * invH;
        case VelocityKind::Centred:
            return centredAt(*f.grid, p * gScale + gOff, invH);
        case VelocityKind::Staggered:
            return staggeredAt(*f.grid, p * gScale + gOff, invH);
        }
        return vec3(0.0f);
    }

    /// A centred grid's velocity (cells / s) at grid position q = p * gScale + gOff.
    [[gnu::always_inline]] static vec3 centredAt(const VelocityGrid& g, vec3 q, float invH) {
        return gridVector(g, q - 0.5f) * invH;
    }
    /// A staggered grid's, likewise.
    [[gnu::always_inline]] static vec3 staggeredAt(const VelocityGrid& g, vec3 q, float invH) {
        return vec3(gridComponent(g, 0, vec3(q.x, q.y - 0.5f, q.z - 0.5f)),
                    gridComponent(g, 1, vec3(q.x - 0.5f, q.y, q.z - 0.5f)),
                    gridComponent(g, 2, vec3(q.x - 0.5f, q.y - 0.5f, q.z))) *
               invH;
    }
};

/// A velocity grid of kind K (Centred or Staggered) as a Sampler reads it, without the switch on
/// the kind: the same float operations, so the same bits.
template <VelocityKind K> struct GridSampler {
    const VelocityGrid& g;
    vec3 gOff;
    float gScale, invH;
    /// Staggered: component c's plane in VelocityField::planes, or null (no planes)
    const float* plane[3] = {};

    explicit GridSampler(const Sampler& s)
        : g(*s.f.grid), gOff(s.gOff), gScale(s.gScale), invH(s.invH) {
        if (s.f.planes)
            for (int c = 0; c < 3; ++c) plane[c] = s.f.planes->data() + c * g.v.size();
    }

    [[gnu::always_inline]] vec3 operator()(vec3 p) const {
        if constexpr (K == VelocityKind::Centred)
            return Sampler::centredAt(g, p * gScale + gOff, invH);
        else
            return Sampler::staggeredAt(g, p * gScale + gOff, invH);
    }
};

/// The velocity at the cell centres of one row (y, z) of the density grid, from a velocity grid
/// of kind K: the grid position's y and z, hence their corners and weights and the four rows of
/// the grid read, are the same for every cell of the row; only x is computed per cell. The float
/// operations are GridSampler's (gridCorner, then the lerps in x, y, z order, then * invH): the
/// same bits.
template <VelocityKind K> struct GridRowVelocity {
    /// per component (Centred: all three alike): the four rows (y0, z0), (y1, z0), (y0, z1),
    /// (y1, z1) of the grid and the y and z weights
    struct Comp {
        const vec3* r[4];
        float fy, fz;
    };
    Comp c[3];
    /// Staggered with planes: component k's four rows in its plane, as c[k].r
    const float* pr[3][4] = {};
    const GridSampler<K>& s;
    int nx;

    GridRowVelocity(const GridSampler<K>& sampler, int y, int z) : s(sampler), nx(s.g.res.x) {
        // the y and z of p * gScale + gOff for p = the row's cell centres
        const float qy = (float(y) + 0.5f) * s.gScale + s.gOff.y;
        const float qz = (float(z) + 0.5f) * s.gScale + s.gOff.z;
        for (int k = 0; k < 3; ++k) {
            // Centred: every component at q - 1/2; Staggered: component k at q on its own axis
            const bool centred = K == VelocityKind::Centred;
            const float ey = centred || k != 1 ? qy - 0.5f : qy;
            const float ez = centred || k != 2 ? qz - 0.5f : qz;
            int y0, y1, z0, z1;
            gridCorner(ey, s.g.res.y, y0, y1, c[k].fy);
            gridCorner(ez, s.g.res.z, z0, z1, c[k].fz);
            const vec3* v = s.g.v.data();
            c[k].r[0] = v + s.g.index(0, y0, z0);
            c[k].r[1] = v + s.g.index(0, y1, z0);
            c[k].r[2] = v + s.g.index(0, y0, z1);
            c[k].r[3] = v + s.g.index(0, y1, z1);
            if (s.plane[k])
                for (int row = 0; row < 4; ++row) pr[k][row] = s.plane[k] + size_t(c[k].r[row] - v);
        }
    }

    /// The velocity (cells / s) at the centre of cell x of the row: GridSampler(p), same bits.
    [[gnu::always_inline]] vec3 operator()(int x) const {
        const float qx = (float(x) + 0.5f) * s.gScale + s.gOff.x;
        if constexpr (K == VelocityKind::Centred) {
            const Comp& k = c[0];
            int x0, x1;
            float fx;
            gridCorner(qx - 0.5f, nx, x0, x1, fx);
            auto lerp3 = [](vec3 a, vec3 b, float t) {
                return vec3(lerp(a.x, b.x, t), lerp(a.y, b.y, t), lerp(a.z, b.z, t));
            };
            const vec3 c00 = lerp3(k.r[0][x0], k.r[0][x1], fx);
            const vec3 c10 = lerp3(k.r[1][x0], k.r[1][x1], fx);
            const vec3 c01 = lerp3(k.r[2][x0], k.r[2][x1], fx);
            const vec3 c11 = lerp3(k.r[3][x0], k.r[3][x1], fx);
            return lerp3(lerp3(c00, c10, k.fy), lerp3(c01, c11, k.fy), k.fz) * s.invH;
        } else {
            vec3 u;
            int x0[2], x1[2];
            float fx[2];
            gridCorner(qx, nx, x0[0], x1[0], fx[0]);
            gridCorner(qx - 0.5f, nx, x0[1], x1[1], fx[1]);
            for (int a = 0; a < 3; ++a) {
                const Comp& k = c[a];
                const int w = a == 0 ? 0 : 1;
                const float c00 = lerp(k.r[0][x0[w]][a], k.r[0][x1[w]][a], fx[w]);
                const float c10 = lerp(k.r[1][x0[w]][a], k.r[1][x1[w]][a], fx[w]);
                const float c01 = lerp(k.r[2][x0[w]][a], k.r[2][x1[w]][a], fx[w]);
                const float c11 = lerp(k.r[3][x0[w]][a], k.r[3][x1[w]][a], fx[w]);
                u[a] = lerp(lerp(c00, c10, k.fy), lerp(c01, c11, k.fy), k.fz);
            }
            return u * s.invH;
        }
    }
};

/// Position after following the velocity for time dt (negative: the backtrace) from p in n
/// substeps; u0 is the velocity at p.
template <class U>
[[gnu::always_inline]] inline vec3 trace(const U& u, vec3 p, vec3 u0, float dt, int n,
                                         Backtrace bt) {
    const float s = dt / float(n);
    for (int k = 0; k < n; ++k) {
        const vec3 k1 = k == 0 ? u0 : u(p);
        switch (bt) {
        case Backtrace::Euler:
            p += s * k1;
            break;
        case Backtrace::RK2: {
            const vec3 k2 = u(p + (0.5f * s) * k1);
            p += s * k2;
            break;
        }
        case Backtrace::RK3: {
            const vec3 k2 = u(p + (0.5f * s) * k1);
            const vec3 k3 = u(p + (0.75f * s) * k2);
            p += s * ((2.0f / 9.0f) * k1 + (3.0f / 9.0f) * k2 + (4.0f / 9.0f) * k3);
            break;
        }
        }
    }
    return p;
}

/// Whether one substep traces the characteristic exactly: a uniform wind, or a layered wind
/// without vertical components (the altitude, hence the velocity, is constant along the path).
bool exactInOneSubstep(const VelocityField& f) {
    if (f.kind == VelocityKind::Uniform) return true;
    if (f.kind != VelocityKind::Layered) return false;
    for (const WindLayer& l : f.layers)
        if (l.wind.y != 0.0f) return false;
    return true;
}

int substeps(bool exact, const AdvectParams& ap, float cfl) {
    if (exact || !(ap.traceCfl > 0.0f)) return 1;
    const float n = std::ceil(cfl / ap.traceCfl);
    if (!(n > 1.0f)) return 1;
    return n >= float(ap.maxTraceSubsteps) ? std::max(1, ap.maxTraceSubsteps) : int(n);
}

struct Axis {
    int i0, i1;
    float f;
    bool in0, in1;
};

[[gnu::always_inline]] inline Axis axis(float q, int n, Boundary b) {
    Axis a;
    switch (b) {
    case Boundary::Periodic: {
        if (!std::isfinite(q)) q = 0.0f;
        const float fn = float(n);
        q -= fn * std::floor(q / fn);
        int i = int(std::floor(q));
        a.f = q - float(i);
        if (i >= n) i -= n;
        if (i < 0) i += n;
        a.i0 = i;
        a.i1 = i + 1 == n ? 0 : i + 1;
        a.in0 = a.in1 = true;
        return a;
    }
    case Boundary::Clamp: {
        q = q > 0.0f ? q : 0.0f; // NaN -> 0
        q = std::min(q, float(n - 1));
        a.i0 = int(q);
        a.f = q - float(a.i0);
        a.i1 = std::min(a.i0 + 1, n - 1);
        a.in0 = a.in1 = true;
        return a;
    }
    case Boundary::Zero:
    default: {
        q = q > -2.0f ? q : -2.0f; // NaN -> outside
        q = std::min(q, float(n + 1));
        const float fl = std::floor(q);
        a.i0 = int(fl);
        a.i1 = a.i0 + 1;
        a.f = q - fl;
        a.in0 = a.i0 >= 0 && a.i0 < n;
        a.in1 = a.i1 >= 0 && a.i1 < n;
        return a;
    }
    }
}

} // namespace

VelocityField uniformWind(vec3 wind) {
    VelocityField f;
    f.kind = VelocityKind::Uniform;
    f.uniform = wind;
    return f;
}

VelocityField layeredWind(std::vector<WindLayer> layers) {
    VelocityField f;
    f.kind = VelocityKind::Layered;
    f.layers = std::move(layers);
    return f;
}

VelocityField centredGrid(const VelocityGrid& g) {
    VelocityField f;
    f.kind = VelocityKind::Centred;
    f.grid = &g;
    return f;
}

VelocityField staggeredGrid(const VelocityGrid& g, bool planes) {
    VelocityField f = centredGrid(g);
    f.kind = VelocityKind::Staggered;
    return planes ? withPlanes(std::move(f)) : f;
}

VelocityField withPlanes(VelocityField f) {
    if (f.kind != VelocityKind::Staggered || !f.grid || f.planes) return f;
    const VelocityGrid& g = *f.grid;
    const size_t n = g.v.size();
    auto planes = std::make_shared<std::vector<float>>(3 * n);
    float* px = planes->data();
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 65536),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t i = r.begin(); i < r.end(); ++i) {
                              px[i] = g.v[i].x;
                              px[n + i] = g.v[i].y;
                              px[2 * n + i] = g.v[i].z;
                          }
                      });
    f.planes = std::move(planes);
    return f;
}

const char* validate(const VelocityField& v) {
    switch (v.kind) {
    case VelocityKind::Uniform:
        return finite3(v.uniform) ? "" : "uniform wind must be finite";
    case VelocityKind::Layered:
        if (v.layers.empty()) return "layered wind needs at least one layer";
        for (size_t k = 0; k < v.layers.size(); ++k) {
            if (!std::isfinite(v.layers[k].altitude) || !finite3(v.layers[k].wind))
                return "layered wind: altitudes and winds must be finite";
            if (k > 0 && !(v.layers[k].altitude > v.layers[k - 1].altitude))
                return "layered wind: altitudes must be strictly increasing";
        }
        return "";
    case VelocityKind::Centred:
    case VelocityKind::Staggered: {
        const VelocityGrid* g = v.grid;
        if (!g) return "velocity grid missing";
        if (g->res.x < 1 || g->res.y < 1 || g->res.z < 1)
            return "velocity grid: every size must be >= 1";
        if (g->v.size() != size_t(g->res.x) * g->res.y * g->res.z)
            return "velocity grid: v must hold res.x * res.y * res.z entries";
        if (!(g->frame.voxelSize > 0.0f) || !std::isfinite(g->frame.voxelSize) ||
            !finite3(g->frame.origin))
            return "velocity grid: voxel size must be finite and > 0, origin finite";
        for (const vec3& w : g->v)
            if (!finite3(w)) return "velocity grid: non-finite velocity";
        if (v.planes && v.planes->size() != 3 * g->v.size())
            return "velocity grid: its planes do not hold 3 floats per entry (the grid was "
                   "resized after staggeredGrid())";
        return "";
    }
    }
    return "unknown velocity kind";
}

vec3 velocityAt(const VelocityField& v, vec3 p) {
    // index space of a unit grid at the origin: p itself
    const Sampler s(v, GridFrame{vec3(0.0f), 1.0f});
    return s(p);
}

namespace {

[[gnu::always_inline]] inline float sampleDensityImpl(const DensityGrid& d, vec3 p, Boundary b,
                                                      float* lo, float* hi) {
    const Axis ax = axis(p.x - 0.5f, d.res.x, b), ay = axis(p.y - 0.5f, d.res.y, b),
               az = axis(p.z - 0.5f, d.res.z, b);
    auto at = [&](int x, bool vx, int y, bool vy, int z, bool vz) {
        return vx && vy && vz ? d.at(x, y, z) : 0.0f;
    };
    const float v000 = at(ax.i0, ax.in0, ay.i0, ay.in0, az.i0, az.in0);
    const float v100 = at(ax.i1, ax.in1, ay.i0, ay.in0, az.i0, az.in0);
    const float v010 = at(ax.i0, ax.in0, ay.i1, ay.in1, az.i0, az.in0);
    const float v110 = at(ax.i1, ax.in1, ay.i1, ay.in1, az.i0, az.in0);
    const float v001 = at(ax.i0, ax.in0, ay.i0, ay.in0, az.i1, az.in1);
    const float v101 = at(ax.i1, ax.in1, ay.i0, ay.in0, az.i1, az.in1);
    const float v011 = at(ax.i0, ax.in0, ay.i1, ay.in1, az.i1, az.in1);
    const float v111 = at(ax.i1, ax.in1, ay.i1, ay.in1, az.i1, az.in1);
    if (lo)
        *lo = std::min(std::min(std::min(v000, v100), std::min(v010, v110)),
                       std::min(std::min(v001, v101), std::min(v011, v111)));
    if (hi)
        *hi = std::max(std::max(std::max(v000, v100), std::max(v010, v110)),
                       std::max(std::max(v001, v101), std::max(v011, v111)));
    const float c0 = lerp(lerp(v000, v100, ax.f), lerp(v010, v110, ax.f), ay.f);
    const float c1 = lerp(lerp(v001, v101, ax.f), lerp(v011, v111, ax.f), ay.f);
    return lerp(c0, c1, az.f);
}

/// A row of cells (fixed y, z) under an exact wind (uniform, or layered without vertical
/// components): the velocity, hence the displacement, is the same for every cell of the row, so
/// the y and z stencils of the lookup are computed once per row and only x per cell. The float
/// operations are those of trace() and sampleDensityImpl(): the results are the same bits.
struct RowLookup {
    const float* row[4]; ///< (y0, z0), (y1, z0), (y0, z1), (y1, z1); null: outside
    float fy, fz;
    float sx; ///< s * u.x: the x displacement of trace() (p.x + s * k2.x)
    int nx;
    Boundary b;

    RowLookup(const DensityGrid& d, int y, int z, vec3 u0, float s, Boundary bnd)
        : sx(s * u0.x), nx(d.res.x), b(bnd) {
        // p.y is unchanged by the trace (k.y = 0), p.z moves by s * u.z
        const float py = float(y) + 0.5f;
        const float pz = float(z) + 0.5f + s * u0.z;
        const Axis ay = axis(py - 0.5f, d.res.y, b), az = axis(pz - 0.5f, d.res.z, b);
        fy = ay.f;
        fz = az.f;
        auto at = [&](int yi, bool vy, int zi, bool vz) -> const float* {
            return vy && vz ? &d.v[(size_t(zi) * d.res.y + yi) * nx] : nullptr;
        };
        row[0] = at(ay.i0, ay.in0, az.i0, az.in0);
        row[1] = at(ay.i1, ay.in1, az.i0, az.in0);
        row[2] = at(ay.i0, ay.in0, az.i1, az.in1);
        row[3] = at(ay.i1, ay.in1, az.i1, az.in1);
    }

    /// The 8 samples of the lookup at x (v[k]: bit 0 x, bit 1 y, bit 2 z) and its x weight.
    [[gnu::always_inline]] void samples(int x, float v[8], float& fx) const {
        const float px = float(x) + 0.5f + sx;
        const Axis ax = axis(px - 0.5f, nx, b);
        auto at = [&](int k, int i, bool vi) { return vi && row[k] ? row[k][i] : 0.0f; };
        for (int k = 0; k < 4; ++k) {
            v[2 * k] = at(k, ax.i0, ax.in0);
            v[2 * k + 1] = at(k, ax.i1, ax.in1);
        }
        fx = ax.f;
    }

    /// The min and max of the 8 samples operator() reads at x (the MacCormack limiter's range).
    [[gnu::always_inline]] static void minMax(const float v[8], float& lo, float& hi) {
        lo = std::min(std::min(std::min(v[0], v[1]), std::min(v[2], v[3])),
                      std::min(std::min(v[4], v[5]), std::min(v[6], v[7])));
        hi = std::max(std::max(std::max(v[0], v[1]), std::max(v[2], v[3])),
                      std::max(std::max(v[4], v[5]), std::max(v[6], v[7])));
    }

    [[gnu::always_inline]] void range(int x, float& lo, float& hi) const {
        float v[8], fx;
        samples(x, v, fx);
        minMax(v, lo, hi);
    }

    [[gnu::always_inline]] float operator()(int x) const {
        float v[8], fx;
        samples(x, v, fx);
        const float v000 = v[0], v100 = v[1], v010 = v[2], v110 = v[3];
        const float v001 = v[4], v101 = v[5], v011 = v[6], v111 = v[7];
        const float c0 = lerp(lerp(v000, v100, fx), lerp(v010, v110, fx), fy);
        const float c1 = lerp(lerp(v001, v101, fx), lerp(v011, v111, fx), fy);
        return lerp(c0, c1, fz);
    }
};

// --- the grid kernel's 8-cell blocks (AVX2, chosen at run time) ---
//
// Eight cells of a row at once, lane for lane the float operations of the scalar grid kernel
// (GridRowVelocity, trace() with one RK2 substep, sampleDensityImpl() with the zero boundary):
// IEEE add, sub, mul, div and sqrt round the same in a lane as in a scalar register, the clamps
// and std::min / std::max keep their operand order (min_ps(b, a) is std::min(a, b), NaN and
// signed zeros included), floor is exact, and no FMA is enabled (a + t (b - a) is not
// contracted). The same bits, tested against the per-cell path
// (AdvectGridKernel.SameBitsAsThePerCellPathOnRandomVelocityGrids). A block whose cells need
// more than one trace substep is left to the scalar kernel.

// (clang ignores GCC's target pragma: its own attribute pragma gives every function of the region,
// lambdas included, the target)
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

struct Vec8 {
    __m256 x, y, z;
};

[[gnu::always_inline]] inline __m256 lerp8(__m256 a, __m256 b, __m256 t) {
    return _mm256_add_ps(a, _mm256_mul_ps(t, _mm256_sub_ps(b, a)));
}

/// The trilinear blend of the scalar lookups: in x (v000 with v100, ...), then y, then z.
[[gnu::always_inline]] inline __m256 trilerp8(__m256 v000, __m256 v100, __m256 v010, __m256 v110,
                                              __m256 v001, __m256 v101, __m256 v011, __m256 v111,
                                              __m256 fx, __m256 fy, __m256 fz) {
    return lerp8(lerp8(lerp8(v000, v100, fx), lerp8(v010, v110, fx), fy),
                 lerp8(lerp8(v001, v101, fx), lerp8(v011, v111, fx), fy), fz);
}

/// gridCorner() in 8 lanes.
[[gnu::always_inline]] inline void gridCorner8(__m256 x, int n, __m256i& i0, __m256i& i1,
                                               __m256& f) {
    x = _mm256_and_ps(_mm256_cmp_ps(x, _mm256_setzero_ps(), _CMP_GT_OQ), x); // NaN, <= 0 -> +0
    x = _mm256_min_ps(_mm256_set1_ps(float(n - 1)), x);                      // std::min(x, n-1)
    i0 = _mm256_cvttps_epi32(x);
    f = _mm256_sub_ps(x, _mm256_cvtepi32_ps(i0));
    i1 = _mm256_min_epi32(_mm256_add_epi32(i0, _mm256_set1_epi32(1)), _mm256_set1_epi32(n - 1));
}

/// All ones in the lanes of @p v that hold lane 0's value.
[[gnu::always_inline]] inline __m256i sameLanes(__m256i v) {
    return _mm256_cmpeq_epi32(v, _mm256_permutevar8x32_epi32(v, _mm256_setzero_si256()));
}

/// All ones in lane k where @p i0 is lane 0's value + k and @p i1 is @p i0 + 1 (8 consecutive
/// corners along x, their upper neighbours unclamped); *first = lane 0's value.
[[gnu::always_inline]] inline __m256i consecutiveLanes(__m256i i0, __m256i i1, int* first) {
    *first = _mm_cvtsi128_si32(_mm256_castsi256_si128(i0));
    const __m256i want0 =
        _mm256_add_epi32(_mm256_set1_epi32(*first), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    const __m256i want1 = _mm256_add_epi32(want0, _mm256_set1_epi32(1));
    return _mm256_and_si256(_mm256_cmpeq_epi32(i0, want0), _mm256_cmpeq_epi32(i1, want1));
}

/// Whether every lane of @p m is all ones.
[[gnu::always_inline]] inline bool allLanes(__m256i m) {
    return _mm256_movemask_epi8(m) == -1;
}

/// Component a of a Vec8.
[[gnu::always_inline]] inline __m256 comp(const Vec8& v, int a) {
    return a == 0 ? v.x : a == 1 ? v.y : v.z;
}

/// The 8 consecutive vec3 entries from p as three channels (an AoS to SoA shuffle).
[[gnu::always_inline]] inline Vec8 channels8(const vec3* p) {
    const float* f = &p->x;
    const __m256 m0 = _mm256_loadu_ps(f), m1 = _mm256_loadu_ps(f + 8), m2 = _mm256_loadu_ps(f + 16);
    // x_i = f[3 i]: lanes f0 f9 f18 f3 f12 f21 f6 f15
    const __m256 x =
        _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(m0, m1, 0x92), m2, 0x24),
                                 _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
    // y_i = f[3 i + 1]: lanes f16 f1 f10 f19 f4 f13 f22 f7
    const __m256 y =
        _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(m0, m1, 0x24), m2, 0x49),
                                 _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6));
    // z_i = f[3 i + 2]: lanes f8 f17 f2 f11 f20 f5 f14 f23
    const __m256 z =
        _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(m0, m1, 0x49), m2, 0x92),
                                 _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
    return {x, y, z};
}

/// The corners and weights of a trilinear grid lookup at grid positions q (gridCorner() per
/// axis) and, where they are 8 consecutive entries of one row per (y, z) corner (a smooth
/// velocity near the block), those four rows at lane 0's x0; else row[0] is null.
struct GridCorners8 {
    __m256i x0, x1, y0, y1, z0, z1;
    __m256 fx, fy, fz;
    const vec3* row[4]; ///< (y0, z0), (y1, z0), (y0, z1), (y1, z1)
};

[[gnu::always_inline]] inline GridCorners8 gridCorners8(const VelocityGrid& g, __m256 qx, __m256 qy,
                                                        __m256 qz) {
    GridCorners8 k;
    gridCorner8(qx, g.res.x, k.x0, k.x1, k.fx);
    gridCorner8(qy, g.res.y, k.y0, k.y1, k.fy);
    gridCorner8(qz, g.res.z, k.z0, k.z1, k.fz);
    int first = 0;
    k.row[0] = nullptr;
    // (y1 = min(y0 + 1, n - 1) is the same in every lane where y0 is, z1 likewise)
    if (allLanes(_mm256_and_si256(_mm256_and_si256(sameLanes(k.y0), sameLanes(k.z0)),
                                  consecutiveLanes(k.x0, k.x1, &first)))) {
        const int ya = _mm_cvtsi128_si32(_mm256_castsi256_si128(k.y0));
        const int yb = _mm_cvtsi128_si32(_mm256_castsi256_si128(k.y1));
        const int za = _mm_cvtsi128_si32(_mm256_castsi256_si128(k.z0));
        const int zb = _mm_cvtsi128_si32(_mm256_castsi256_si128(k.z1));
        const vec3* v = g.v.data();
        k.row[0] = v + g.index(first, ya, za);
        k.row[1] = v + g.index(first, yb, za);
        k.row[2] = v + g.index(first, ya, zb);
        k.row[3] = v + g.index(first, yb, zb);
    }
    return k;
}

/// gridComponent() in 8 lanes from corners whose rows are not consecutive: gathers.
[[gnu::always_inline]] inline __m256 gatherComponent8(const VelocityGrid& g, const GridCorners8& k,
                                                      int c) {
    const __m256i rx = _mm256_set1_epi32(g.res.x), ry = _mm256_set1_epi32(g.res.y);
    const __m256i three = _mm256_set1_epi32(3), cc = _mm256_set1_epi32(c);
    // float offset of (0, y, z), component c: 3 ((z ny + y) nx) + c
    auto rowOf = [&](__m256i y, __m256i z) {
        return _mm256_add_epi32(
            _mm256_mullo_epi32(
                _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(z, ry), y), rx), three),
            cc);
    };
    const float* base = &g.v.data()->x;
    const __m256i x03 = _mm256_mullo_epi32(k.x0, three), x13 = _mm256_mullo_epi32(k.x1, three);
    auto at = [&](__m256i row, __m256i x3) {
        return _mm256_i32gather_ps(base, _mm256_add_epi32(row, x3), 4);
    };
    const __m256i r00 = rowOf(k.y0, k.z0), r10 = rowOf(k.y1, k.z0), r01 = rowOf(k.y0, k.z1),
                  r11 = rowOf(k.y1, k.z1);
    return trilerp8(at(r00, x03), at(r00, x13), at(r10, x03), at(r10, x13), at(r01, x03),
                    at(r01, x13), at(r11, x03), at(r11, x13), k.fx, k.fy, k.fz);
}

/// The trilinear blend of the three components at corners in consecutive rows
/// (GridCorners8::row), in gridVector()'s order (x, then y, then z). The values at x1 = x0 + 1
/// are those at x0 moved by one lane and the row's 9th entry (the same values as 8 entries
/// loaded from x0 + 1); the rows are blended as they are read, so that few registers stay live.
[[gnu::always_inline]] inline Vec8 rowsTrilerp8(const GridCorners8& k) {
    const __m256i next = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 0);
    __m256 zr[2][3]; // the y blends of the z0 rows (0, 1) and the z1 rows (2, 3)
    for (int z = 0; z < 2; ++z) {
        __m256 xr[2][3]; // the x blends of rows (y0, z) and (y1, z)
        for (int y = 0; y < 2; ++y) {
            const vec3* row = k.row[2 * z + y];
            const Vec8 lo = channels8(row);
            for (int c = 0; c < 3; ++c) {
                const __m256 hi = _mm256_blend_ps(_mm256_permutevar8x32_ps(comp(lo, c), next),
                                                  _mm256_broadcast_ss(&row[8][c]), 0x80);
                xr[y][c] = lerp8(comp(lo, c), hi, k.fx);
            }
        }
        for (int c = 0; c < 3; ++c) zr[z][c] = lerp8(xr[0][c], xr[1][c], k.fy);
    }
    return {lerp8(zr[0][0], zr[1][0], k.fz), lerp8(zr[0][1], zr[1][1], k.fz),
            lerp8(zr[0][2], zr[1][2], k.fz)};
}

/// gridVector() in 8 lanes: the three components at the same grid positions q, their corners
/// and loads shared.
[[gnu::always_inline]] inline Vec8 gridVector8(const VelocityGrid& g, __m256 qx, __m256 qy,
                                               __m256 qz) {
    const GridCorners8 k = gridCorners8(g, qx, qy, qz);
    if (!k.row[0])
        return {gatherComponent8(g, k, 0), gatherComponent8(g, k, 1), gatherComponent8(g, k, 2)};
    return rowsTrilerp8(k);
}

/// gridCorner() along one axis in 8 lanes, and whether the lanes' stencils allow plain loads:
/// along x, 8 consecutive corners (first: lane 0's); along y or z, one corner for all lanes.
struct Corner8 {
    __m256i i0, i1;
    __m256 f;
    bool ok;
    int first;
};

[[gnu::always_inline]] inline Corner8 xCorner8(__m256 q, int n) {
    Corner8 c;
    gridCorner8(q, n, c.i0, c.i1, c.f);
    c.ok = allLanes(consecutiveLanes(c.i0, c.i1, &c.first));
    return c;
}

[[gnu::always_inline]] inline Corner8 yzCorner8(__m256 q, int n) {
    Corner8 c;
    gridCorner8(q, n, c.i0, c.i1, c.f);
    c.ok = allLanes(sameLanes(c.i0)); // (i1 = min(i0 + 1, n - 1) then agrees too)
    c.first = _mm_cvtsi128_si32(_mm256_castsi256_si128(c.i0));
    return c;
}

/// gridComponent() of one component stored as a plane (VelocityField::planes), in 8 lanes, its
/// y and z corners the same in every lane: rows[] are the stencil's rows (y0, z0), (y1, z0),
/// (y0, z1), (y1, z1) at x = 0, fy and fz their weights. Plain loads where the x corners are
/// consecutive (x1 = x0 + 1, so the upper values are the 8 entries from x0 + 1), else gathers.
[[gnu::always_inline]] inline __m256 planeRows8(const float* const rows[4], const Corner8& x,
                                                __m256 fy, __m256 fz) {
    if (x.ok) {
        auto xl = [&](int r) {
            const float* p = rows[r] + x.first;
            return lerp8(_mm256_loadu_ps(p), _mm256_loadu_ps(p + 1), x.f);
        };
        return lerp8(lerp8(xl(0), xl(1), fy), lerp8(xl(2), xl(3), fy), fz);
    }
    auto at = [&](int r, __m256i i) { return _mm256_i32gather_ps(rows[r], i, 4); };
    return trilerp8(at(0, x.i0), at(0, x.i1), at(1, x.i0), at(1, x.i1), at(2, x.i0), at(2, x.i1),
                    at(3, x.i0), at(3, x.i1), x.f, fy, fz);
}

/// gridComponent() of the component in @p plane at the corners x, y, z, in 8 lanes.
[[gnu::always_inline]] inline __m256 planeComponent8(const VelocityGrid& g, const float* plane,
                                                     const Corner8& x, const Corner8& y,
                                                     const Corner8& z) {
    if (y.ok && z.ok) {
        const int ya = y.first, za = z.first;
        const int yb = _mm_cvtsi128_si32(_mm256_castsi256_si128(y.i1));
        const int zb = _mm_cvtsi128_si32(_mm256_castsi256_si128(z.i1));
        const float* const rows[4] = {plane + g.index(0, ya, za), plane + g.index(0, yb, za),
                                      plane + g.index(0, ya, zb), plane + g.index(0, yb, zb)};
        return planeRows8(rows, x, y.f, z.f);
    }
    const __m256i rx = _mm256_set1_epi32(g.res.x), ry = _mm256_set1_epi32(g.res.y);
    auto rowOf = [&](__m256i yi, __m256i zi) {
        return _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(zi, ry), yi), rx);
    };
    auto at = [&](__m256i row, __m256i xi) {
        return _mm256_i32gather_ps(plane, _mm256_add_epi32(row, xi), 4);
    };
    const __m256i r00 = rowOf(y.i0, z.i0), r10 = rowOf(y.i1, z.i0), r01 = rowOf(y.i0, z.i1),
                  r11 = rowOf(y.i1, z.i1);
    return trilerp8(at(r00, x.i0), at(r00, x.i1), at(r10, x.i0), at(r10, x.i1), at(r01, x.i0),
                    at(r01, x.i1), at(r11, x.i0), at(r11, x.i1), x.f, y.f, z.f);
}

/// GridSampler<K>() in 8 lanes (cells / s at density-grid index positions p). Staggered: from
/// the planes (GridSampler::plane not null), the corners of each axis computed once for the
/// two positions the components use (q and q - 1/2).
template <VelocityKind K>
[[gnu::always_inline]] inline Vec8 gridVelocity8(const GridSampler<K>& s, const Vec8& p) {
    const __m256 sc = _mm256_set1_ps(s.gScale), ih = _mm256_set1_ps(s.invH);
    const __m256 h = _mm256_set1_ps(0.5f);
    const __m256 qx = _mm256_add_ps(_mm256_mul_ps(p.x, sc), _mm256_set1_ps(s.gOff.x));
    const __m256 qy = _mm256_add_ps(_mm256_mul_ps(p.y, sc), _mm256_set1_ps(s.gOff.y));
    const __m256 qz = _mm256_add_ps(_mm256_mul_ps(p.z, sc), _mm256_set1_ps(s.gOff.z));
    const __m256 mx = _mm256_sub_ps(qx, h), my = _mm256_sub_ps(qy, h), mz = _mm256_sub_ps(qz, h);
    if constexpr (K == VelocityKind::Centred) {
        const Vec8 u = gridVector8(s.g, mx, my, mz);
        return {_mm256_mul_ps(u.x, ih), _mm256_mul_ps(u.y, ih), _mm256_mul_ps(u.z, ih)};
    } else {
        const ivec3 n = s.g.res;
        const Corner8 xq = xCorner8(qx, n.x), xm = xCorner8(mx, n.x);
        const Corner8 yq = yzCorner8(qy, n.y), ym = yzCorner8(my, n.y);
        const Corner8 zq = yzCorner8(qz, n.z), zm = yzCorner8(mz, n.z);
        return {_mm256_mul_ps(planeComponent8(s.g, s.plane[0], xq, ym, zm), ih),
                _mm256_mul_ps(planeComponent8(s.g, s.plane[1], xm, yq, zm), ih),
                _mm256_mul_ps(planeComponent8(s.g, s.plane[2], xm, ym, zq), ih)};
    }
}

/// GridRowVelocity<K>(x) for the 8 cells x0 .. x0 + 7 (Staggered: from the planes).
template <VelocityKind K>
[[gnu::always_inline]] inline Vec8 rowVelocity8(const GridRowVelocity<K>& r, __m256 px) {
    const __m256 qx =
        _mm256_add_ps(_mm256_mul_ps(px, _mm256_set1_ps(r.s.gScale)), _mm256_set1_ps(r.s.gOff.x));
    const __m256 ih = _mm256_set1_ps(r.s.invH);
    const __m256 mx = _mm256_sub_ps(qx, _mm256_set1_ps(0.5f));
    __m256 u[3];
    if constexpr (K == VelocityKind::Centred) { // one set of corners and loads for all three
        // the rows where the 8 entries are consecutive (a grid aligned with the density's, away
        // from its x edges): plain loads instead of gathers, the same values
        const auto& k = r.c[0];
        GridCorners8 g;
        gridCorner8(mx, r.nx, g.x0, g.x1, g.fx);
        g.fy = _mm256_set1_ps(k.fy);
        g.fz = _mm256_set1_ps(k.fz);
        int first = 0;
        const bool contiguous = allLanes(consecutiveLanes(g.x0, g.x1, &first));
        for (int row = 0; row < 4; ++row) g.row[row] = contiguous ? k.r[row] + first : nullptr;
        if (contiguous) {
            const Vec8 v = rowsTrilerp8(g);
            u[0] = v.x;
            u[1] = v.y;
            u[2] = v.z;
        } else {
            const __m256i three = _mm256_set1_epi32(3);
            for (int a = 0; a < 3; ++a) {
                const __m256i ca = _mm256_set1_epi32(a);
                const __m256i o0 = _mm256_add_epi32(_mm256_mullo_epi32(g.x0, three), ca);
                const __m256i o1 = _mm256_add_epi32(_mm256_mullo_epi32(g.x1, three), ca);
                auto at = [&](int row, __m256i o) {
                    return _mm256_i32gather_ps(&k.r[row]->x, o, 4);
                };
                u[a] = trilerp8(at(0, o0), at(0, o1), at(1, o0), at(1, o1), at(2, o0), at(2, o1),
                                at(3, o0), at(3, o1), g.fx, g.fy, g.fz);
            }
        }
    } else { // component 0 at x = q, 1 and 2 at q - 1/2 (their x corners shared)
        const Corner8 xq = xCorner8(qx, r.nx), xm = xCorner8(mx, r.nx);
        for (int a = 0; a < 3; ++a)
            u[a] = planeRows8(r.pr[a], a == 0 ? xq : xm, _mm256_set1_ps(r.c[a].fy),
                              _mm256_set1_ps(r.c[a].fz));
    }
    return {_mm256_mul_ps(u[0], ih), _mm256_mul_ps(u[1], ih), _mm256_mul_ps(u[2], ih)};
}

/// axis() with the zero boundary, in 8 lanes: corners, weight, and whether each is inside.
[[gnu::always_inline]] inline void zeroAxis8(__m256 q, int n, __m256i& i0, __m256i& i1, __m256& f,
                                             __m256i& in0, __m256i& in1) {
    const __m256 m2 = _mm256_set1_ps(-2.0f);
    q = _mm256_blendv_ps(m2, q, _mm256_cmp_ps(q, m2, _CMP_GT_OQ)); // NaN -> -2
    q = _mm256_min_ps(_mm256_set1_ps(float(n + 1)), q);
    const __m256 fl = _mm256_round_ps(q, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    i0 = _mm256_cvttps_epi32(fl);
    i1 = _mm256_add_epi32(i0, _mm256_set1_epi32(1));
    f = _mm256_sub_ps(q, fl);
    const __m256i minus1 = _mm256_set1_epi32(-1), nn = _mm256_set1_epi32(n);
    in0 = _mm256_and_si256(_mm256_cmpgt_epi32(i0, minus1), _mm256_cmpgt_epi32(nn, i0));
    in1 = _mm256_and_si256(_mm256_cmpgt_epi32(i1, minus1), _mm256_cmpgt_epi32(nn, i1));
}

/// sampleDensityImpl() with the zero boundary in 8 lanes; lo / hi (if not null) as there.
[[gnu::always_inline]] inline __m256 sampleZero8(const DensityGrid& d, const Vec8& p, __m256* lo,
                                                 __m256* hi) {
    const __m256 h = _mm256_set1_ps(0.5f);
    __m256i x0, x1, y0, y1, z0, z1, ix0, ix1, iy0, iy1, iz0, iz1;
    __m256 fx, fy, fz;
    zeroAxis8(_mm256_sub_ps(p.x, h), d.res.x, x0, x1, fx, ix0, ix1);
    zeroAxis8(_mm256_sub_ps(p.y, h), d.res.y, y0, y1, fy, iy0, iy1);
    zeroAxis8(_mm256_sub_ps(p.z, h), d.res.z, z0, z1, fz, iz0, iz1);
    const float* base = d.v.data();
    // every corner inside and 8 consecutive along x in one row per (y, z) corner: plain loads
    // instead of masked gathers, the same values
    const __m256i all =
        _mm256_and_si256(_mm256_and_si256(_mm256_and_si256(ix0, ix1), _mm256_and_si256(iy0, iy1)),
                         _mm256_and_si256(iz0, iz1));
    int first = 0;
    __m256 v000, v100, v010, v110, v001, v101, v011, v111;
    if (allLanes(
            _mm256_and_si256(_mm256_and_si256(all, sameLanes(y0)),
                             _mm256_and_si256(sameLanes(z0), consecutiveLanes(x0, x1, &first))))) {
        // (y1 = y0 + 1 and z1 = z0 + 1 in every lane, so their rows are uniform too)
        const int ya = _mm_cvtsi128_si32(_mm256_castsi256_si128(y0));
        const int za = _mm_cvtsi128_si32(_mm256_castsi256_si128(z0));
        const size_t nx = size_t(d.res.x), sz = nx * size_t(d.res.y);
        const float* r00 = base + (size_t(za) * size_t(d.res.y) + size_t(ya)) * nx + first;
        const float *r10 = r00 + nx, *r01 = r00 + sz, *r11 = r01 + nx;
        v000 = _mm256_loadu_ps(r00);
        v100 = _mm256_loadu_ps(r00 + 1);
        v010 = _mm256_loadu_ps(r10);
        v110 = _mm256_loadu_ps(r10 + 1);
        v001 = _mm256_loadu_ps(r01);
        v101 = _mm256_loadu_ps(r01 + 1);
        v011 = _mm256_loadu_ps(r11);
        v111 = _mm256_loadu_ps(r11 + 1);
    } else {
        const __m256i rx = _mm256_set1_epi32(d.res.x), ry = _mm256_set1_epi32(d.res.y);
        auto rowOf = [&](__m256i y, __m256i z) {
            return _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(z, ry), y), rx);
        };
        auto at = [&](__m256i row, __m256i x, __m256i in) {
            return _mm256_mask_i32gather_ps(_mm256_setzero_ps(), base, _mm256_add_epi32(row, x),
                                            _mm256_castsi256_ps(in), 4);
        };
        const __m256i r00 = rowOf(y0, z0), r10 = rowOf(y1, z0), r01 = rowOf(y0, z1),
                      r11 = rowOf(y1, z1);
        const __m256i i00 = _mm256_and_si256(iy0, iz0), i10 = _mm256_and_si256(iy1, iz0),
                      i01 = _mm256_and_si256(iy0, iz1), i11 = _mm256_and_si256(iy1, iz1);
        v000 = at(r00, x0, _mm256_and_si256(ix0, i00));
        v100 = at(r00, x1, _mm256_and_si256(ix1, i00));
        v010 = at(r10, x0, _mm256_and_si256(ix0, i10));
        v110 = at(r10, x1, _mm256_and_si256(ix1, i10));
        v001 = at(r01, x0, _mm256_and_si256(ix0, i01));
        v101 = at(r01, x1, _mm256_and_si256(ix1, i01));
        v011 = at(r11, x0, _mm256_and_si256(ix0, i11));
        v111 = at(r11, x1, _mm256_and_si256(ix1, i11));
    }
    // std::min(a, b) is min_ps(b, a); std::max(a, b) is max_ps(b, a)
    auto mn = [&](__m256 a, __m256 b) { return _mm256_min_ps(b, a); };
    auto mx = [&](__m256 a, __m256 b) { return _mm256_max_ps(b, a); };
    if (lo) *lo = mn(mn(mn(v000, v100), mn(v010, v110)), mn(mn(v001, v101), mn(v011, v111)));
    if (hi) *hi = mx(mx(mx(v000, v100), mx(v010, v110)), mx(mx(v001, v101), mx(v011, v111)));
    return trilerp8(v000, v100, v010, v110, v001, v101, v011, v111, fx, fy, fz);
}

/// Cells x0 .. x0 + 7 of row (y, z): the velocity at the centre (GridRowVelocity), its CFL
/// number |u0| adt, one RK2 substep of length dt from the centre, and the density d there (zero
/// boundary; lo / hi: the limiter's range). With @p back (MacCormack), also the end of the
/// substep of length -dt from the centre, the backward trace's, sharing the velocity at the
/// centre: x, y, z in back[0..2]. False, and nothing written, where a cell needs more than one
/// substep (substeps() > 1).
template <VelocityKind K>
bool gridBlock8(const GridSampler<K>& gs, const GridRowVelocity<K>& rowU, const DensityGrid& d,
                int x0, int y, int z, float dt, float adt, float traceCfl, float* v, float* lo,
                float* hi, float* cfl, float* const* back) {
    const __m256 px =
        _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_add_epi32(
                          _mm256_set1_epi32(x0), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7))),
                      _mm256_set1_ps(0.5f));
    const Vec8 p{px, _mm256_set1_ps(float(y) + 0.5f), _mm256_set1_ps(float(z) + 0.5f)};
    const Vec8 u0 = rowVelocity8(rowU, px);
    // glm::length: sqrt((x x + y y) + z z)
    const __m256 len = _mm256_sqrt_ps(
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(u0.x, u0.x), _mm256_mul_ps(u0.y, u0.y)),
                      _mm256_mul_ps(u0.z, u0.z)));
    const __m256 c = _mm256_mul_ps(len, _mm256_set1_ps(adt));
    // substeps() is 1 unless traceCfl > 0 and ceil(cfl / traceCfl) > 1, i.e. cfl / traceCfl > 1
    if (traceCfl > 0.0f &&
        _mm256_movemask_ps(_mm256_cmp_ps(_mm256_div_ps(c, _mm256_set1_ps(traceCfl)),
                                         _mm256_set1_ps(1.0f), _CMP_GT_OQ)))
        return false;
    // trace(): s = dt / 1; k2 = u(p + (0.5 s) k1); p + s k2
    auto rk2 = [&](float s) __attribute__((always_inline)) {
        const __m256 hs = _mm256_set1_ps(0.5f * s), sv = _mm256_set1_ps(s);
        const Vec8 mid{_mm256_add_ps(p.x, _mm256_mul_ps(hs, u0.x)),
                       _mm256_add_ps(p.y, _mm256_mul_ps(hs, u0.y)),
                       _mm256_add_ps(p.z, _mm256_mul_ps(hs, u0.z))};
        const Vec8 k2 = gridVelocity8(gs, mid);
        return Vec8{_mm256_add_ps(p.x, _mm256_mul_ps(sv, k2.x)),
                    _mm256_add_ps(p.y, _mm256_mul_ps(sv, k2.y)),
                    _mm256_add_ps(p.z, _mm256_mul_ps(sv, k2.z))};
    };
    const Vec8 end = rk2(dt);
    __m256 l, h;
    const __m256 r = sampleZero8(d, end, lo ? &l : nullptr, hi ? &h : nullptr);
    _mm256_storeu_ps(v, r);
    if (lo) _mm256_storeu_ps(lo, l);
    if (hi) _mm256_storeu_ps(hi, h);
    _mm256_storeu_ps(cfl, c);
    if (back) {
        const Vec8 b = rk2(-dt);
        _mm256_storeu_ps(back[0], b.x);
        _mm256_storeu_ps(back[1], b.y);
        _mm256_storeu_ps(back[2], b.z);
    }
    return true;
}

/// sampleDensityImpl() with the zero boundary at the 8 positions (px[k], py[k], pz[k]).
void sampleZeroAt8(const DensityGrid& d, const float* px, const float* py, const float* pz,
                   float* out) {
    const Vec8 p{_mm256_loadu_ps(px), _mm256_loadu_ps(py), _mm256_loadu_ps(pz)};
    _mm256_storeu_ps(out, sampleZero8(d, p, nullptr, nullptr));
}

/// MacCormack's correction and limiter (advect()'s correct()) for 8 cells: out = fwd + (in - back)
/// / 2, clamped to [lo, hi] when @p limiter; the clamped cells counted and what the clamp moved
/// and the cells' mass accumulated in cell order, in double, as the scalar loop does (the same
/// bits).
void correct8(const float* fwd, const float* in, const float* back, const float* lo,
              const float* hi, bool limiter, float* out, double& massOut, double& clampMass,
              std::uint32_t& clamped) {
    const __m256 c =
        _mm256_add_ps(_mm256_loadu_ps(fwd),
                      _mm256_mul_ps(_mm256_set1_ps(0.5f),
                                    _mm256_sub_ps(_mm256_loadu_ps(in), _mm256_loadu_ps(back))));
    __m256 v = c;
    if (limiter) {
        const __m256 l = _mm256_loadu_ps(lo), h = _mm256_loadu_ps(hi);
        v = _mm256_blendv_ps(l, v, _mm256_cmp_ps(v, l, _CMP_GE_OQ)); // !(v >= lo): lo (NaN too)
        v = _mm256_blendv_ps(v, h, _mm256_cmp_ps(v, h, _CMP_GT_OQ)); // v > hi: hi
    }
    _mm256_storeu_ps(out, v);
    alignas(32) float vs[8], cs[8];
    _mm256_store_ps(vs, v);
    unsigned moved = unsigned(_mm256_movemask_ps(_mm256_cmp_ps(v, c, _CMP_NEQ_UQ))); // !(v == c)
    if (moved) {
        _mm256_store_ps(cs, c);
        clamped += std::uint32_t(__builtin_popcount(moved));
        for (; moved; moved &= moved - 1) {
            const int k = __builtin_ctz(moved);
            clampMass += std::fabs(double(vs[k]) - double(cs[k]));
        }
    }
    for (int k = 0; k < 8; ++k) massOut += double(vs[k]);
}

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

/// Whether the 8-cell blocks may run: AVX2 on this CPU, and grid offsets that fit in an int.
bool gridBlocksUsable(const VelocityGrid& g, const DensityGrid& d) {
    static const bool avx2 = __builtin_cpu_supports("avx2");
    const double gv = 3.0 * double(g.res.x) * g.res.y * g.res.z;
    const double dv = double(d.res.x) * d.res.y * d.res.z;
    return avx2 && gv < 2147483647.0 && dv < 2147483647.0;
}

/// Calls f.template operator()<K, B>() with the velocity grid's kind (Centred or Staggered) and
/// the boundary as constants, so that the grid kernel has no switch per lookup.
template <class F> void dispatchGrid(VelocityKind kind, Boundary b, F&& f) {
    auto withBoundary = [&]<VelocityKind K>() {
        switch (b) {
        case Boundary::Zero:
            f.template operator()<K, Boundary::Zero>();
            break;
        case Boundary::Clamp:
            f.template operator()<K, Boundary::Clamp>();
            break;
        case Boundary::Periodic:
            f.template operator()<K, Boundary::Periodic>();
            break;
        }
    };
    if (kind == VelocityKind::Centred)
        withBoundary.template operator()<VelocityKind::Centred>();
    else
        withBoundary.template operator()<VelocityKind::Staggered>();
}

} // namespace

float sampleDensity(const DensityGrid& d, vec3 p, Boundary b, float* lo, float* hi) {
    return sampleDensityImpl(d, p, b, lo, hi);
}

double gridMass(const DensityGrid& d, const GridFrame& frame) {
    const int rows = d.res.y * d.res.z;
    std::vector<double> rowSum(size_t(std::max(rows, 0)), 0.0);
    tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& r) {
        for (int row = r.begin(); row < r.end(); ++row) {
            const float* v = &d.v[size_t(row) * d.res.x];
            double s = 0.0;
            for (int x = 0; x < d.res.x; ++x) s += double(v[x]);
            rowSum[row] = s;
        }
    });
    double m = 0.0;
    for (double s : rowSum) m += s;
    const double h = frame.voxelSize;
    return m * h * h * h;
}

namespace {

/// The fused MacCormack passes' slabs per chunk: enough rows and cells per parallel loop to
/// keep both cores busy.
int fusedChunk(ivec3 res) {
    const size_t slabCells = size_t(res.x) * size_t(res.y);
    return std::clamp(int(std::max<size_t>(size_t(128) / size_t(res.y), size_t(32768) / slabCells)),
                      1, res.z);
}

/// The ring's slabs when it is first made (it grows when a vertical wind reaches further).
int ringSlabsAtLeast(ivec3 res) {
    return std::min(res.z, 2 * fusedChunk(res) + 2);
}

} // namespace

StepKernel stepKernel(const VelocityField& vel, const AdvectParams& ap) {
    StepKernel k;
    // a wind the same along every row of x: the row kernel (RowLookup); the Euler and RK2
    // stages of such a wind equal the velocity at the start
    // (RK3's weights 2/9 + 3/9 + 4/9 need not sum to 1 in float: it keeps the per-cell path)
    // (a vertical component moves rows across y: a uniform wind with one keeps the per-cell path)
    k.exact = exactInOneSubstep(vel);
    k.row = k.exact && ap.rowKernel && ap.backtrace != Backtrace::RK3 &&
            !(vel.kind == VelocityKind::Uniform && vel.uniform.y != 0.0f);
    // a velocity grid: the grid kernel (GridRowVelocity for the first stage, no switch per
    // lookup), the same float operations as the per-cell path
    k.grid =
        ap.rowKernel && (vel.kind == VelocityKind::Centred || vel.kind == VelocityKind::Staggered);
    k.mac = ap.scheme == AdvectScheme::MacCormack;
    k.fused = k.mac && k.grid;
    k.limiterGrids = k.mac && !k.row && !k.fused;
    return k;
}

StepMemory stepMemory(ivec3 res, const VelocityField& vel, const AdvectParams& ap, bool inPlace) {
    StepMemory m;
    if (res.x < 1 || res.y < 1 || res.z < 1) return m;
    const StepKernel k = stepKernel(vel, ap);
    const double cells = double(res.x) * res.y * res.z, grid = cells * sizeof(float);
    const double rows = double(res.y) * res.z;
    m.grids = (inPlace ? grid : 0.0) + (k.mac ? grid : 0.0) + (k.limiterGrids ? 2.0 * grid : 0.0);
    m.rows = rows * (3.0 * sizeof(double) + sizeof(float) + 2.0 * sizeof(std::uint32_t) +
                     (k.fused ? sizeof(int) : 0.0));
    if (k.fused) {
        const double slab = 5.0 * double(res.x) * res.y * sizeof(float);
        // a periodic boundary may wrap to the last slab: the ring holds every slab
        m.ring = slab * (ap.boundary == Boundary::Periodic ? res.z : ringSlabsAtLeast(res));
        m.ringMost = slab * res.z;
    }
    return m;
}

AdvectStats advect(const DensityGrid& in, const GridFrame& frame, const VelocityField& vel,
                   float dt, const AdvectParams& ap, DensityGrid& out, AdvectWorkspace& ws) {
    const ivec3 res = in.res;
    const int nx = res.x, ny = res.y, rows = res.y * res.z;
    const size_t cells = size_t(nx) * size_t(std::max(rows, 0));
    const Sampler u(vel, frame);
    const StepKernel kernel = stepKernel(vel, ap);
    const bool exact = kernel.exact, rowKernel = kernel.row, gridKernel = kernel.grid,
               mac = kernel.mac;
    // the grid kernel's 8-cell blocks (AVX2, the zero boundary): pass 1 needs one RK2 substep too
    const bool zeroBlocks =
        gridKernel && ap.boundary == Boundary::Zero && gridBlocksUsable(*vel.grid, in);
    // (a staggered grid's blocks read its planes: a field without them uses the per-cell kernel)
    const bool blocks = zeroBlocks && ap.backtrace == Backtrace::RK2 &&
                        (vel.kind != VelocityKind::Staggered || vel.planes);
    DensityGrid& dst = &in == &out ? ws.tmp : out;
    dst.res = res;
    dst.v.resize(cells);
    DensityGrid& fwd = mac ? ws.fwd : dst;
    fwd.res = res;
    fwd.v.resize(cells);
    // MacCormack with a velocity grid: both traces of a cell in pass 1 (they share the velocity
    // at the centre); the backward trace's end and the limiter's range wait for pass 2 in a ring
    // of z slabs, and pass 2 follows pass 1 slab by slab as soon as the slabs of the forward
    // step its lookups read are done (a wavefront: what pass 2 reads is still in cache)
    const bool fused = kernel.fused;
    if (kernel.limiterGrids) { // the row kernel recomputes the limiter's range in pass 2
        ws.lo.resize(cells);
        ws.hi.resize(cells);
    }
    const size_t nrows = size_t(std::max(rows, 0));
    ws.rowMassIn.assign(nrows, 0.0);
    ws.rowMassOut.assign(nrows, 0.0);
    ws.rowClampMass.assign(nrows, 0.0);
    ws.rowCfl.assign(nrows, 0.0f);
    ws.rowClamped.assign(nrows, 0);
    ws.rowSubsteps.assign(nrows, 0);
    if (fused) ws.rowReach.assign(nrows, 0);
    const float adt = std::fabs(dt);
    const size_t slabCells = size_t(nx) * size_t(ny);
    // the ring's planes for one row: lo, hi, and the backward trace's end x, y, z
    struct RingRow {
        float *lo, *hi, *bx, *by, *bz;
    };
    // the ring's slabs (5 planes of slabCells floats each)
    int ringSlabs = slabCells > 0 ? int(ws.ring.size() / (5 * slabCells)) : 0;
    auto ringRow = [&](int row) {
        float* r =
            ws.ring.data() + size_t((row / ny) % ringSlabs) * 5 * slabCells + size_t(row % ny) * nx;
        return RingRow{r, r + slabCells, r + 2 * slabCells, r + 3 * slabCells, r + 4 * slabCells};
    };

    // pass 1: the forward semi-Lagrangian step (backtrace from every cell centre, trilinear)
    auto pass1Row = [&](int row) {
        const int y = row % ny, z = row / ny;
        const size_t base = size_t(row) * nx;
        double massIn = 0.0, massOut = 0.0;
        float cflMax = 0.0f;
        int subMax = 0;
        if (rowKernel) {
            const vec3 u0 = u(vec3(0.5f, float(y) + 0.5f, float(z) + 0.5f));
            cflMax = glm::length(u0) * adt;
            subMax = 1;
            const RowLookup look(in, y, z, u0, -dt, ap.boundary);
            for (int x = 0; x < nx; ++x) {
                const float v = look(x);
                fwd.v[base + x] = v;
                if (!mac) massOut += double(v);
                massIn += double(in.v[base + x]);
            }
        }
        // cell x: the forward trace from its centre velocity u0 through sampler smp (ex: exact
        // in one substep), the density there (lo / hi, if not null: the limiter's range), the
        // row's stats; returns the trace's substeps
        auto forward = [&](const auto& smp, int x, vec3 u0, bool ex, Boundary b, float* lo,
                           float* hi) {
            const vec3 p(float(x) + 0.5f, float(y) + 0.5f, float(z) + 0.5f);
            const float cfl = glm::length(u0) * adt;
            cflMax = std::max(cflMax, cfl);
            const int n = substeps(ex, ap, cfl);
            subMax = std::max(subMax, n);
            const float v =
                sampleDensityImpl(in, trace(smp, p, u0, -dt, n, ap.backtrace), b, lo, hi);
            fwd.v[base + x] = v;
            if (!mac) massOut += double(v);
            massIn += double(in.v[base + x]);
            return n;
        };
        if (gridKernel) {
            const RingRow ring = fused ? ringRow(row) : RingRow{};
            float* lo = fused ? ring.lo : nullptr;
            float* hi = fused ? ring.hi : nullptr;
            dispatchGrid(vel.kind, ap.boundary, [&]<VelocityKind K, Boundary B>() {
                const GridSampler<K> gs(u);
                const GridRowVelocity<K> rowU(gs, y, z);
                auto cell = [&](int x) {
                    const vec3 u0 = rowU(x);
                    const int n =
                        forward(gs, x, u0, false, B, lo ? lo + x : nullptr, hi ? hi + x : nullptr);
                    if (fused) {
                        const vec3 p(float(x) + 0.5f, float(y) + 0.5f, float(z) + 0.5f);
                        const vec3 back = trace(gs, p, u0, dt, n, ap.backtrace);
                        ring.bx[x] = back.x;
                        ring.by[x] = back.y;
                        ring.bz[x] = back.z;
                    }
                };
                int x = 0;
                if (B == Boundary::Zero && blocks)
                    for (; x + 8 <= nx; x += 8) {
                        float cfl[8];
                        float* v = &fwd.v[base + x];
                        float* back[3] = {nullptr, nullptr, nullptr};
                        if (fused) {
                            back[0] = ring.bx + x;
                            back[1] = ring.by + x;
                            back[2] = ring.bz + x;
                        }
                        if (!gridBlock8(gs, rowU, in, x, y, z, -dt, adt, ap.traceCfl, v,
                                        lo ? lo + x : nullptr, hi ? hi + x : nullptr, cfl,
                                        fused ? back : nullptr)) {
                            for (int k = 0; k < 8; ++k) cell(x + k);
                            continue;
                        }
                        subMax = std::max(subMax, 1);
                        for (int k = 0; k < 8; ++k) {
                            cflMax = std::max(cflMax, cfl[k]);
                            if (!mac) massOut += double(v[k]);
                            massIn += double(in.v[base + x + k]);
                        }
                    }
                for (; x < nx; ++x) cell(x);
            });
            if (fused) { // the last slab of the forward step pass 2's lookups of this row read
                float zMax = -std::numeric_limits<float>::infinity(); // (NaN ends read nothing)
                for (int x = 0; x < nx; ++x)
                    if (ring.bz[x] > zMax) zMax = ring.bz[x];
                // the upper z corner of axis(z - 1/2): zero and clamp boundaries read no slab
                // above it; a periodic one may wrap to the last slab
                const float upper = std::floor(std::min(zMax - 0.5f, float(res.z))) + 1.0f;
                ws.rowReach[row] = ap.boundary == Boundary::Periodic
                                       ? res.z - 1
                                       : int(std::clamp(upper, 0.0f, float(res.z - 1)));
            }
        }
        for (int x = 0; x < (rowKernel || gridKernel ? 0 : nx); ++x)
            forward(u, x, u(vec3(float(x) + 0.5f, float(y) + 0.5f, float(z) + 0.5f)), exact,
                    ap.boundary, mac ? &ws.lo[base + x] : nullptr,
                    mac ? &ws.hi[base + x] : nullptr);
        ws.rowMassIn[row] = massIn;
        ws.rowMassOut[row] = massOut;
        ws.rowCfl[row] = cflMax;
        ws.rowSubsteps[row] = std::uint32_t(subMax);
    };

    // pass 2 (MacCormack): the backward step from phi_hat^{n+1}, the correction, the limiter
    auto pass2Row = [&](int row) {
        const int y = row % ny, z = row / ny;
        const size_t base = size_t(row) * nx;
        double massOut = 0.0, clampMass = 0.0;
        std::uint32_t clamped = 0;
        // the correction and the limiter of cell x, from the backward lookup
        auto correct = [&](int x, float back, float lo, float hi) {
            const size_t i = base + x;
            const float c = fwd.v[i] + 0.5f * (in.v[i] - back);
            float v = c;
            if (ap.limiter) {
                if (!(v >= lo)) v = lo; // a NaN c becomes lo
                if (v > hi) v = hi;
            }
            if (!(v == c)) {
                ++clamped;
                clampMass += std::fabs(double(v) - double(c));
            }
            dst.v[i] = v;
            massOut += double(v);
        };
        if (fused) {
            const RingRow ring = ringRow(row);
            int x = 0;
            if (zeroBlocks)
                for (; x + 8 <= nx; x += 8) {
                    float back[8];
                    sampleZeroAt8(fwd, ring.bx + x, ring.by + x, ring.bz + x, back);
                    const size_t i = base + x;
                    correct8(&fwd.v[i], &in.v[i], back, ring.lo + x, ring.hi + x, ap.limiter,
                             &dst.v[i], massOut, clampMass, clamped);
                }
            for (; x < nx; ++x)
                correct(x,
                        sampleDensityImpl(fwd, vec3(ring.bx[x], ring.by[x], ring.bz[x]),
                                          ap.boundary, nullptr, nullptr),
                        ring.lo[x], ring.hi[x]);
        } else {
            const vec3 uRow =
                rowKernel ? u(vec3(0.5f, float(y) + 0.5f, float(z) + 0.5f)) : vec3(0.0f);
            const RowLookup look(fwd, y, z, uRow, dt, ap.boundary);
            // the forward step's stencil again, for the limiter's range: reading `in` (cached
            // rows) costs less than storing and reloading two grids
            const RowLookup fwdLook(in, y, z, uRow, -dt, ap.boundary);
            for (int x = 0; x < nx; ++x) {
                float back, lo = 0.0f, hi = 0.0f;
                if (rowKernel) {
                    back = look(x);
                    if (ap.limiter) fwdLook.range(x, lo, hi);
                } else {
                    const vec3 p(float(x) + 0.5f, float(y) + 0.5f, float(z) + 0.5f);
                    const vec3 u0 = u(p);
                    const int n = substeps(exact, ap, glm::length(u0) * adt);
                    const vec3 dstPos = trace(u, p, u0, dt, n, ap.backtrace);
                    back = sampleDensityImpl(fwd, dstPos, ap.boundary, nullptr, nullptr);
                    if (ap.limiter) {
                        lo = ws.lo[base + x];
                        hi = ws.hi[base + x];
                    }
                }
                correct(x, back, lo, hi);
            }
        }
        ws.rowMassOut[row] = massOut;
        ws.rowClampMass[row] = clampMass;
        ws.rowClamped[row] = clamped;
    };

    auto runRows = [&](int r0, int r1, const auto& body) {
        tbb::parallel_for(tbb::blocked_range<int>(r0, r1, 4),
                          [&](const tbb::blocked_range<int>& r) {
                              for (int row = r.begin(); row < r.end(); ++row) body(row);
                          });
    };
    if (!fused) {
        runRows(0, rows, pass1Row);
        if (mac) runRows(0, rows, pass2Row);
    } else if (rows > 0) {
        const int nz = res.z;
        // slabs per chunk: enough rows and cells per parallel loop to keep both cores busy
        const int chunk = fusedChunk(res);
        // the ring holds the slabs pass 1 did and pass 2 did not yet: [z, next1)
        auto hold = [&](int z, int next1, int upTo) {
            const int want = upTo - z;
            if (ringSlabs >= want) return;
            const int slabs = std::min(nz, std::max({want, 2 * ringSlabs, ringSlabsAtLeast(res)}));
            std::vector<float> grown(size_t(slabs) * 5 * slabCells);
            for (int s = z; s < next1; ++s) // move the live slabs to their new slots
                std::copy_n(ws.ring.data() + size_t(s % ringSlabs) * 5 * slabCells, 5 * slabCells,
                            grown.data() + size_t(s % slabs) * 5 * slabCells);
            ws.ring.swap(grown);
            ringSlabs = slabs;
        };
        int next1 = 0; // slabs [0, next1) have been through pass 1
        for (int z = 0; z < nz; z += chunk) {
            const int zEnd = std::min(nz, z + chunk);
            auto pass1To = [&](int upTo) {
                if (next1 >= upTo) return;
                hold(z, next1, upTo);
                runRows(next1 * ny, upTo * ny, pass1Row);
                next1 = upTo;
            };
            pass1To(zEnd);
            int reach = 0;
            for (int row = z * ny; row < zEnd * ny; ++row)
                reach = std::max(reach, ws.rowReach[row]);
            pass1To(reach + 1);
            runRows(z * ny, zEnd * ny, pass2Row);
        }
    }

    AdvectStats st;
    const double h = frame.voxelSize, h3 = h * h * h;
    for (size_t r = 0; r < nrows; ++r) {
        st.massBefore += ws.rowMassIn[r];
        st.massAfter += ws.rowMassOut[r];
        st.clampedMass += ws.rowClampMass[r];
        st.clampedCells += ws.rowClamped[r];
        st.maxCfl = std::max(st.maxCfl, ws.rowCfl[r]);
        st.maxSubsteps = std::max(st.maxSubsteps, int(ws.rowSubsteps[r]));
    }
    st.massBefore *= h3;
    st.massAfter *= h3;
    st.clampedMass *= h3;
    if (&dst != &out) {
        std::swap(out.v, dst.v);
        out.res = res;
    }
    return st;
}

vec3 ellipsoidMotion(vec3 centreCells, double /*t*/, const void* user) {
    const auto* w = static_cast<const EllipsoidWind*>(user);
    const vec3 world = w->frame.origin + centreCells * w->frame.voxelSize;
    return velocityAt(*w->field, world) / w->frame.voxelSize;
}

} // namespace nimbus::sim
