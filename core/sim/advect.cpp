#include "core/sim/advect.h"

#include <algorithm>
#include <cmath>
#include <utility>

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
[[gnu::always_inline]] inline void trilinearCorners(const VelocityGrid& g, vec3 q, int i0[3],
                                                    int i1[3], float f[3]) {
    for (int a = 0; a < 3; ++a) {
        const int n = g.res[a];
        float x = q[a];
        x = x > 0.0f ? x : 0.0f; // also maps NaN to 0
        x = std::min(x, float(n - 1));
        i0[a] = int(x);
        f[a] = x - float(i0[a]);
        i1[a] = std::min(i0[a] + 1, n - 1);
    }
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
        case VelocityKind::Centred: {
            return gridVector(*f.grid, p * gScale + gOff - 0.5f) * invH;
        }
        case VelocityKind::Staggered: {
            const vec3 q = p * gScale + gOff;
            return vec3(gridComponent(*f.grid, 0, vec3(q.x, q.y - 0.5f, q.z - 0.5f)),
                        gridComponent(*f.grid, 1, vec3(q.x - 0.5f, q.y, q.z - 0.5f)),
                        gridComponent(*f.grid, 2, vec3(q.x - 0.5f, q.y - 0.5f, q.z))) *
                   invH;
        }
        }
        return vec3(0.0f);
    }
};

/// Position after following the velocity for time dt (negative: the backtrace) from p in n
/// substeps; u0 is the velocity at p.
[[gnu::always_inline]] inline vec3 trace(const Sampler& u, vec3 p, vec3 u0, float dt, int n,
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

VelocityField staggeredGrid(const VelocityGrid& g) {
    VelocityField f = centredGrid(g);
    f.kind = VelocityKind::Staggered;
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

AdvectStats advect(const DensityGrid& in, const GridFrame& frame, const VelocityField& vel,
                   float dt, const AdvectParams& ap, DensityGrid& out, AdvectWorkspace& ws) {
    const ivec3 res = in.res;
    const int nx = res.x, ny = res.y, rows = res.y * res.z;
    const size_t cells = size_t(nx) * size_t(std::max(rows, 0));
    const Sampler u(vel, frame);
    const bool exact = exactInOneSubstep(vel);
    // a wind the same along every row of x: the row kernel (RowLookup); the Euler and RK2
    // stages of such a wind equal the velocity at the start
    // (RK3's weights 2/9 + 3/9 + 4/9 need not sum to 1 in float: it keeps the per-cell path)
    // (a vertical component moves rows across y: a uniform wind with one keeps the per-cell path)
    const bool rowKernel = exact && ap.rowKernel && ap.backtrace != Backtrace::RK3 &&
                           !(vel.kind == VelocityKind::Uniform && vel.uniform.y != 0.0f);
    const bool mac = ap.scheme == AdvectScheme::MacCormack;
    DensityGrid& dst = &in == &out ? ws.tmp : out;
    dst.res = res;
    dst.v.resize(cells);
    DensityGrid& fwd = mac ? ws.fwd : dst;
    fwd.res = res;
    fwd.v.resize(cells);
    if (mac && !rowKernel) { // the row kernel recomputes the limiter's range in pass 2
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
    const float adt = std::fabs(dt);

    // pass 1: the forward semi-Lagrangian step (backtrace from every cell centre, trilinear)
    tbb::parallel_for(tbb::blocked_range<int>(0, rows, 4), [&](const tbb::blocked_range<int>& r) {
        for (int row = r.begin(); row < r.end(); ++row) {
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
            for (int x = 0; x < (rowKernel ? 0 : nx); ++x) {
                const vec3 p(float(x) + 0.5f, float(y) + 0.5f, float(z) + 0.5f);
                const vec3 u0 = u(p);
                const float cfl = glm::length(u0) * adt;
                cflMax = std::max(cflMax, cfl);
                const int n = substeps(exact, ap, cfl);
                subMax = std::max(subMax, n);
                const vec3 src = trace(u, p, u0, -dt, n, ap.backtrace);
                float lo, hi;
                const float v = sampleDensityImpl(in, src, ap.boundary, &lo, &hi);
                fwd.v[base + x] = v;
                if (mac) {
                    ws.lo[base + x] = lo;
                    ws.hi[base + x] = hi;
                } else {
                    massOut += double(v);
                }
                massIn += double(in.v[base + x]);
            }
            ws.rowMassIn[row] = massIn;
            ws.rowMassOut[row] = massOut;
            ws.rowCfl[row] = cflMax;
            ws.rowSubsteps[row] = std::uint32_t(subMax);
        }
    });

    // pass 2 (MacCormack): the backward step from phi_hat^{n+1}, the correction, the limiter
    if (mac)
        tbb::parallel_for(
            tbb::blocked_range<int>(0, rows, 4), [&](const tbb::blocked_range<int>& r) {
                for (int row = r.begin(); row < r.end(); ++row) {
                    const int y = row % ny, z = row / ny;
                    const size_t base = size_t(row) * nx;
                    double massOut = 0.0, clampMass = 0.0;
                    std::uint32_t clamped = 0;
                    const vec3 uRow =
                        rowKernel ? u(vec3(0.5f, float(y) + 0.5f, float(z) + 0.5f)) : vec3(0.0f);
                    const RowLookup look(fwd, y, z, uRow, dt, ap.boundary);
                    // the forward step's stencil again, for the limiter's range: reading `in`
                    // (cached rows) costs less than storing and reloading two grids
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
                    }
                    ws.rowMassOut[row] = massOut;
                    ws.rowClampMass[row] = clampMass;
                    ws.rowClamped[row] = clamped;
                }
            });

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
