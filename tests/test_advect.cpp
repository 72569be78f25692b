// Wind advection (core/sim/advect.h): a blob under a uniform wind moves by wind * dt; no new
// extrema at CFL 1, 10 and 50 (MacCormack, limiter on); no NaN; mass conserved under a uniform
// wind on a periodic grid within what the limiter clamped; a rotating field brings a blob back
// after one turn (MacCormack closer than semi-Lagrangian); a layered wind shears; staggered and
// centred velocity grids agree; 1 and 2 threads give the same bits; the automaton's ellipsoids
// follow a velocity field. Figures: docs/advection.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <tbb/global_control.h>

#include "core/sim/advect.h"

using namespace nimbus::sim;

namespace {

constexpr double kPi = 3.14159265358979323846;

DensityGrid blank(ivec3 res, float value = 0.0f) {
    DensityGrid d;
    d.res = res;
    d.v.assign(size_t(res.x) * res.y * res.z, value);
    return d;
}

size_t idx(const DensityGrid& d, int x, int y, int z) {
    return (size_t(z) * d.res.y + y) * d.res.x + x;
}

/// Adds a Gaussian exp(-|p - c|^2 / (2 s^2)) (index space, cell centres at i + 1/2).
void addBlob(DensityGrid& d, glm::dvec3 c, double s, double amp = 1.0, int y0 = 0,
             int y1 = 1 << 30) {
    for (int z = 0; z < d.res.z; ++z)
        for (int y = std::max(0, y0); y < std::min(d.res.y, y1); ++y)
            for (int x = 0; x < d.res.x; ++x) {
                const glm::dvec3 p(x + 0.5, y + 0.5, z + 0.5);
                const glm::dvec3 r = p - c;
                d.v[idx(d, x, y, z)] += float(amp * std::exp(-glm::dot(r, r) / (2.0 * s * s)));
            }
}

/// Centre of mass (index space) of the cells with y in [y0, y1).
glm::dvec3 centreOfMass(const DensityGrid& d, int y0 = 0, int y1 = 1 << 30) {
    glm::dvec3 m(0.0);
    double w = 0.0;
    for (int z = 0; z < d.res.z; ++z)
        for (int y = std::max(0, y0); y < std::min(d.res.y, y1); ++y)
            for (int x = 0; x < d.res.x; ++x) {
                const double v = d.v[idx(d, x, y, z)];
                m += v * glm::dvec3(x + 0.5, y + 0.5, z + 0.5);
                w += v;
            }
    return m / w;
}

struct Range {
    float lo, hi;
    bool nan;
};
Range range(const DensityGrid& d) {
    Range r{INFINITY, -INFINITY, false};
    for (float v : d.v) {
        if (std::isnan(v)) r.nan = true;
        r.lo = std::min(r.lo, v);
        r.hi = std::max(r.hi, v);
    }
    return r;
}

/// Relative L2 difference |a - b| / |b|.
double relL2(const DensityGrid& a, const DensityGrid& b) {
    double n = 0.0, d = 0.0;
    for (size_t i = 0; i < a.v.size(); ++i) {
        n += (double(a.v[i]) - b.v[i]) * (double(a.v[i]) - b.v[i]);
        d += double(b.v[i]) * b.v[i];
    }
    return std::sqrt(n / d);
}

/// Rigid rotation about the y axis through world point c at omega rad/s, plus a uniform drift
/// and a pure strain (strain x, 0, -strain z): divergence-free, linear in position.
vec3 rotation(vec3 p, vec3 c, float omega, vec3 drift = vec3(0.0f), float strain = 0.0f) {
    const vec3 r = p - c;
    return vec3(omega * r.z + strain * r.x, 0.0f, -omega * r.x - strain * r.z) + drift;
}

/// A velocity grid of res entries on frame f, entry (x, y, z) at(x, y, z), x fastest.
template <class F> VelocityGrid gridOf(ivec3 res, GridFrame f, F&& at) {
    VelocityGrid g;
    g.res = res;
    g.frame = f;
    g.v.resize(size_t(res.x) * res.y * res.z);
    for (int z = 0; z < res.z; ++z)
        for (int y = 0; y < res.y; ++y)
            for (int x = 0; x < res.x; ++x) g.v[g.index(x, y, z)] = at(x, y, z);
    return g;
}

/// A density of res cells, random in [0, 1) with a fraction @p empty of zeros.
DensityGrid speckled(ivec3 res, unsigned seed, float empty) {
    DensityGrid d = blank(res);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (float& v : d.v) v = u(rng) < empty ? 0.0f : u(rng);
    return d;
}

/// A drift with a slow swirl, entries of res on frame f: smooth across 8 cells, so the 8-cell
/// blocks read most corners with plain loads.
VelocityGrid smoothDrift(ivec3 res, GridFrame f) {
    return gridOf(res, f, [](int x, int y, int z) {
        return vec3(0.9f + 0.05f * std::sin(0.05f * float(z)), 0.02f * float(y) / 10.0f,
                    -0.4f + 0.05f * std::cos(0.05f * float(x)));
    });
}

/// The rotation sampled at cell centres (centred) or at the faces (staggered, res + 1).
VelocityGrid rotationGrid(ivec3 res, GridFrame f, vec3 c, float omega, bool staggered,
                          vec3 drift = vec3(0.0f), float strain = 0.0f) {
    auto at = [&](vec3 cell) {
        return rotation(f.origin + cell * f.voxelSize, c, omega, drift, strain);
    };
    return gridOf(staggered ? res + 1 : res, f, [&](int x, int y, int z) {
        const vec3 i{float(x), float(y), float(z)};
        if (!staggered) return at(i + 0.5f);
        return vec3(at(i + vec3(0.0f, 0.5f, 0.5f)).x, at(i + vec3(0.5f, 0.0f, 0.5f)).y,
                    at(i + vec3(0.5f, 0.5f, 0.0f)).z);
    });
}

AdvectParams scheme(AdvectScheme s, Boundary b = Boundary::Zero) {
    AdvectParams p;
    p.scheme = s;
    p.boundary = b;
    return p;
}

/// Two steps' stats, field by field: the same bits.
void expectSameStats(const AdvectStats& a, const AdvectStats& b) {
    EXPECT_EQ(a.massBefore, b.massBefore);
    EXPECT_EQ(a.massAfter, b.massAfter);
    EXPECT_EQ(a.clampedCells, b.clampedCells);
    EXPECT_EQ(a.clampedMass, b.clampedMass);
    EXPECT_EQ(a.maxCfl, b.maxCfl);
    EXPECT_EQ(a.maxSubsteps, b.maxSubsteps);
}

const char* name(AdvectScheme s) {
    return s == AdvectScheme::MacCormack ? "MacCormack" : "semi-Lagrangian";
}

/// One full turn of a blob (16 cells from the axis, sigma 4 cells) in an 80 x 1 x 80 grid (a 2D
/// problem: the rotation has no y component), in n steps. The step's max CFL is reached at the
/// corner cells, 39.5 sqrt(2) = 55.9 cells from the axis; at the blob's centre it is 16 / 55.9 of
/// that.
constexpr double kCornerRadius = 39.5 * 1.4142135623730951;
struct TurnResult {
    double err, peak, worstStepMass, worstBeyondClamps, totalMass, maxCfl;
    float lo, hi;
    bool nan;
    std::uint64_t clamped;
};
TurnResult oneTurn(AdvectScheme s, int n) {
    const ivec3 res(80, 1, 80);
    const GridFrame f{vec3(-40.0f, 0.0f, -40.0f), 1.0f}; // the axis through the world origin
    DensityGrid d = blank(res);
    addBlob(d, glm::dvec3(40.5 + 16.0, 0.5, 40.5), 4.0); // peak 1 at a cell centre
    const DensityGrid start = d;
    const float dt = 0.1f;
    const float omega = float(2.0 * kPi / (double(n) * dt));
    const VelocityGrid g = rotationGrid(res, f, vec3(0.0f), omega, false);
    const VelocityField v = centredGrid(g);
    AdvectWorkspace ws;
    TurnResult r{0, 0, 0, 0, 0, 0, INFINITY, -INFINITY, false, 0};
    const double m0 = gridMass(d, f);
    for (int k = 0; k < n; ++k) {
        const AdvectStats st = advect(d, f, v, dt, scheme(s), d, ws);
        const double dm = std::fabs(st.massAfter - st.massBefore);
        r.worstStepMass = std::max(r.worstStepMass, dm / st.massBefore);
        r.worstBeyondClamps = std::max(r.worstBeyondClamps, (dm - st.clampedMass) / st.massBefore);
        r.maxCfl = std::max(r.maxCfl, double(st.maxCfl));
        r.clamped += st.clampedCells;
        const Range rg = range(d);
        r.lo = std::min(r.lo, rg.lo);
        r.hi = std::max(r.hi, rg.hi);
        r.nan |= rg.nan;
    }
    r.err = relL2(d, start);
    r.peak = range(d).hi;
    r.totalMass = (gridMass(d, f) - m0) / m0;
    return r;
}

int stepsPerTurn(double maxCfl) {
    return std::max(1, int(std::lround(2.0 * kPi * kCornerRadius / maxCfl)));
}

// --- a uniform wind moves a blob by wind * dt ---

TEST(AdvectUniform, BlobMovesByWindTimesDt) {
    const ivec3 res(48, 24, 48);
    const GridFrame f{vec3(-3.0f, 100.0f, 7.0f), 0.5f};
    const vec3 wind(3.3f, 0.7f, -1.9f); // world units / s: CFL (0.66, 0.14, 0.38) at dt 0.1
    const float dt = 0.1f;
    const int steps = 10;
    for (AdvectScheme s : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack}) {
        DensityGrid d = blank(res);
        addBlob(d, glm::dvec3(14.0, 11.0, 16.0), 2.5);
        const glm::dvec3 c0 = glm::dvec3(f.origin) + centreOfMass(d) * double(f.voxelSize);
        AdvectWorkspace ws;
        // mass: the Gaussian's integral (2 pi)^(3/2) sigma^3 cells, times h^3
        const double h3 = double(f.voxelSize) * f.voxelSize * f.voxelSize;
        const double m = std::pow(2.0 * kPi, 1.5) * 2.5 * 2.5 * 2.5 * h3;
        EXPECT_NEAR(gridMass(d, f), m, 1e-5 * m); // the tail cut by the grid: 5e-6
        for (int k = 0; k < steps; ++k) {
            const double before = gridMass(d, f);
            const AdvectStats st = advect(d, f, uniformWind(wind), dt, scheme(s), d, ws);
            EXPECT_NEAR(st.maxCfl, glm::length(wind) * dt / f.voxelSize, 1e-5);
            EXPECT_EQ(st.massBefore, before);
            EXPECT_EQ(st.massAfter, gridMass(d, f));
        }
        const glm::dvec3 c1 = glm::dvec3(f.origin) + centreOfMass(d) * double(f.voxelSize);
        const glm::dvec3 moved = c1 - c0, want = glm::dvec3(wind) * double(dt * steps);
        const double err = glm::length(moved - want) / f.voxelSize; // cells
        std::printf("[uniform] %s: moved (%.5f %.5f %.5f), wind*t (%.5f %.5f %.5f): error %.2e "
                    "cells\n",
                    name(s), moved.x, moved.y, moved.z, want.x, want.y, want.z, err);
        // Semi-Lagrangian: trilinear interpolation under a constant shift keeps the first moment
        // exactly (the weights of each source cell sum to 1 and average to the shift); what is
        // left is float rounding and the Gaussian's tail cut by the grid: bound 1e-3 cells.
        // MacCormack: unlimited it also keeps the first moment, but it rings behind the blob
        // (dispersion) and the limiter lifts those undershoots to the local minimum, adding mass
        // in the wake: measured 0.026 cells in 10 steps, bound 0.02 cells per step.
        EXPECT_LT(err, s == AdvectScheme::SemiLagrangian ? 1e-3 : 0.02 * steps) << name(s);
    }
}

// --- boundaries: what enters from outside the grid ---

TEST(AdvectBoundary, ZeroClampAndPeriodicInflow) {
    const ivec3 res(8, 3, 4);
    const GridFrame f{vec3(0.0f), 2.0f};
    DensityGrid d = blank(res, 1.0f);
    for (int x = 0; x < res.x; ++x) d.v[idx(d, x, 1, 2)] = float(x + 1); // a ramp in one row
    // half a cell per step in +x: the first column takes half of what lies outside
    const VelocityField v = uniformWind(vec3(1.0f, 0.0f, 0.0f));
    for (AdvectScheme s : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack}) {
        AdvectWorkspace ws;
        DensityGrid z, c, p;
        advect(d, f, v, 1.0f, scheme(s, Boundary::Zero), z, ws);
        advect(d, f, v, 1.0f, scheme(s, Boundary::Clamp), c, ws);
        advect(d, f, v, 1.0f, scheme(s, Boundary::Periodic), p, ws);
        // zeros flow in: half a cell of them (MacCormack's correction sharpens the front to
        // 0.5 + (1 - 0.75) / 2, within the limiter's [0, 1])
        EXPECT_EQ(z.v[idx(z, 0, 0, 0)], s == AdvectScheme::MacCormack ? 0.625f : 0.5f) << name(s);
        EXPECT_EQ(c.v[idx(c, 0, 0, 0)], 1.0f) << name(s); // the edge value flows in
        EXPECT_EQ(p.v[idx(p, 0, 0, 0)], 1.0f) << name(s);
        EXPECT_EQ(z.v[idx(z, 5, 0, 0)], 1.0f) << name(s); // inside: untouched by the boundary
        // the ramp row: semi-Lagrangian takes the mean of x - 1 and x (values x and x + 1);
        // periodic wraps the last cell (8) into the first
        if (s == AdvectScheme::SemiLagrangian) {
            EXPECT_EQ(z.v[idx(z, 3, 1, 2)], 3.5f);
            EXPECT_EQ(p.v[idx(p, 0, 1, 2)], 4.5f);
            EXPECT_EQ(z.v[idx(z, 0, 1, 2)], 0.5f);
        }
    }
}

// --- stability: no new extrema, no NaN, at CFL 1, 10, 50 ---

TEST(AdvectStability, NoNewExtremaNoNanAtCfl1To50) {
    const ivec3 res(40, 12, 40);
    const GridFrame f{vec3(0.0f), 1.0f};
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.1f, 0.9f);
    DensityGrid start = blank(res);
    for (float& v : start.v) v = u(rng); // rough: every cell an extremum somewhere
    const Range r0 = range(start);
    for (float target : {1.0f, 10.0f, 50.0f})
        for (AdvectScheme s : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack})
            for (Boundary b : {Boundary::Periodic, Boundary::Zero}) {
                // a rotation about the grid's centre plus a drift: non-uniform, so every
                // lookup interpolates; scaled so that the step's maximum CFL is the target
                const vec3 c(20.0f, 0.0f, 20.0f);
                const float omega = 1.0f;
                const vec3 drift(3.0f, 1.0f, -2.0f);
                const VelocityGrid g = rotationGrid(res, f, c, omega, false, drift);
                const VelocityField v = centredGrid(g);
                AdvectWorkspace ws;
                DensityGrid d = start;
                float dt = 1.0f;
                DensityGrid probe;
                dt = target / advect(d, f, v, dt, scheme(s, b), probe, ws).maxCfl;
                std::uint64_t clamped = 0;
                float cfl = 0.0f;
                for (int k = 0; k < 6; ++k) {
                    const AdvectStats st = advect(d, f, v, dt, scheme(s, b), d, ws);
                    cfl = st.maxCfl;
                    clamped += st.clampedCells;
                    const Range r = range(d);
                    ASSERT_FALSE(r.nan) << name(s) << " CFL " << target << " step " << k;
                    // exact: every value is a convex combination of (MacCormack: clamped to)
                    // values of the previous step, or 0 from outside with Boundary::Zero
                    const float lo = b == Boundary::Zero ? 0.0f : r0.lo;
                    ASSERT_LE(r.hi, r0.hi) << name(s) << " CFL " << target << " step " << k;
                    ASSERT_GE(r.lo, lo) << name(s) << " CFL " << target << " step " << k;
                    ASSERT_TRUE(std::isfinite(st.massAfter));
                }
                EXPECT_NEAR(cfl, target, 1e-3 * target);
                if (s == AdvectScheme::MacCormack) {
                    EXPECT_GT(clamped, 0u); // the limiter worked
                }
                std::printf("[stability] %s %s CFL %.1f: range [%.4f, %.4f] of [%.4f, %.4f], "
                            "clamped %llu cells in 6 steps\n",
                            name(s), b == Boundary::Zero ? "zero" : "periodic", cfl, range(d).lo,
                            range(d).hi, r0.lo, r0.hi, (unsigned long long)clamped);
            }
}

// --- mass: conserved by a uniform wind on a periodic grid, within the limiter's clamps ---

TEST(AdvectMass, UniformWindOnAPeriodicGridConservesMassUpToTheLimiter) {
    const ivec3 res(32, 16, 24);
    const GridFrame f{vec3(0.0f), 2.0f};
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    DensityGrid start = blank(res);
    for (float& v : start.v) v = u(rng) < 0.3f ? u(rng) : 0.0f;
    const vec3 dir = glm::normalize(vec3(1.0f, 0.37f, -0.61f));
    for (float cfl : {0.1f, 1.0f, 10.0f, 50.0f})
        for (AdvectScheme s : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack}) {
            DensityGrid d = start;
            AdvectWorkspace ws;
            double worst = 0.0, worstExcess = 0.0;
            for (int k = 0; k < 8; ++k) {
                const AdvectStats st = advect(d, f, uniformWind(dir * (cfl * f.voxelSize)), 1.0f,
                                              scheme(s, Boundary::Periodic), d, ws);
                const double dm = std::fabs(st.massAfter - st.massBefore);
                worst = std::max(worst, dm / st.massBefore);
                // Bound: with a constant shift on a periodic grid the trilinear weights of each
                // source cell sum to 1, so a semi-Lagrangian step keeps the sum exactly and so do
                // both steps of MacCormack (its correction sums to 0); the limiter then changes
                // the mass by at most clampedMass. 1e-6 relative covers float rounding of the
                // values (2^-24 each, summed in double).
                EXPECT_LE(dm, st.clampedMass + 1e-6 * st.massBefore)
                    << name(s) << " CFL " << cfl << " step " << k;
                worstExcess = std::max(worstExcess, (dm - st.clampedMass) / st.massBefore);
                if (s == AdvectScheme::SemiLagrangian) {
                    EXPECT_EQ(st.clampedCells, 0u);
                }
            }
            std::printf("[mass] %s CFL %.1f: worst |dm|/m per step %.2e, beyond the clamps "
                        "%.2e\n",
                        name(s), cfl, worst, worstExcess);
        }
}

// --- rotation: one full turn; MacCormack less diffusive than semi-Lagrangian ---

TEST(AdvectRotation, BlobReturnsAfterOneTurnAndMacCormackIsLessDiffusive) {
    for (double cfl : {1.0, 10.0, 50.0}) {
        const int n = stepsPerTurn(cfl);
        const TurnResult sl = oneTurn(AdvectScheme::SemiLagrangian, n);
        const TurnResult mc = oneTurn(AdvectScheme::MacCormack, n);
        std::printf("[rotation] max CFL %.2f, %d steps per turn: relative L2 error SL %.4f, "
                    "MacCormack %.4f; peak SL %.4f, MacCormack %.4f; worst |dm|/m per step SL "
                    "%.2e, MacCormack %.2e (beyond its clamps %.2e)\n",
                    mc.maxCfl, n, sl.err, mc.err, sl.peak, mc.peak, sl.worstStepMass,
                    mc.worstStepMass, mc.worstBeyondClamps);
        EXPECT_FALSE(sl.nan || mc.nan);
        EXPECT_LE(mc.hi, 1.0f);
        EXPECT_GE(mc.lo, 0.0f);
        if (cfl <= 1.0) {
            // many steps: semi-Lagrangian's diffusion (one interpolation per step) dominates
            EXPECT_LT(mc.err, 0.5 * sl.err) << n; // measured 0.29 vs 0.68
            EXPECT_LT(mc.err, 0.35) << n;
            EXPECT_GT(mc.peak, 2.0 * sl.peak) << n; // measured 0.85 vs 0.25
        } else if (cfl <= 10.0) {
            EXPECT_LT(mc.err, sl.err) << n;   // measured 0.165 vs 0.203
            EXPECT_GT(mc.peak, sl.peak) << n; // 0.87 vs 0.74
        } else {
            // 7 steps of 51 degrees: few interpolations, both close (measured 0.050, 0.057);
            // the characteristic is traced in ~50 substeps (an unsubstepped RK2 backtrace of
            // 51 degrees misses the circle)
            EXPECT_LT(sl.err, 0.1) << n;
            EXPECT_LT(mc.err, 0.1) << n;
        }
        // Mass: the flow is divergence-free and the blob 6 sigma inside the grid, so a step
        // changes the mass only by interpolation error (measured <= 2e-4, bound 1e-3) and, for
        // MacCormack, by what its limiter clamped (reported per step as clampedMass).
        EXPECT_LT(sl.worstStepMass, 1e-3) << n;
        EXPECT_LT(mc.worstBeyondClamps, 1e-3) << n;
    }
}

// --- a layered wind shears ---

TEST(AdvectLayered, LayersShearEachBlobMovesWithItsOwnWind) {
    const ivec3 res(64, 64, 64);
    const GridFrame f{vec3(0.0f, 1000.0f, 0.0f), 5.0f}; // cell y centres 1002.5 .. 1317.5 m
    const vec3 low(7.3f, 0.0f, -2.1f), high(-4.4f, 0.0f, 6.9f);
    const VelocityField v = layeredWind({{1100.0f, low}, {1230.0f, high}});
    ASSERT_STREQ(validate(v), "");
    // three blobs (sigma 2.5 cells = 12.5 m) in three bands of y: below the table (1032.5 m,
    // 4 sigma below 1100), inside it (1162.5 m, t = 0.48) and above it (1287.5 m)
    DensityGrid start = blank(res);
    addBlob(start, glm::dvec3(16.0, 6.5, 32.0), 2.5, 1.0, 0, 16);
    addBlob(start, glm::dvec3(24.0, 32.5, 20.0), 2.5, 1.0, 16, 48);
    addBlob(start, glm::dvec3(40.0, 57.5, 20.0), 2.5, 1.0, 48, 64);
    const int bands[4] = {0, 16, 48, 64};
    // the mid blob: the wind at its centre's altitude (the profile is linear across the blob and
    // the blob symmetric, so its centre of mass moves with the wind there)
    const vec3 mid = low + (high - low) * ((1162.5f - 1100.0f) / 130.0f);
    const vec3 want[3] = {low, mid, high};
    const char* names[3] = {"low", "mid", "high"};
    const float dt = 1.0f;
    const int steps = 10;
    for (AdvectScheme s : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack}) {
        DensityGrid d = start;
        AdvectWorkspace ws;
        for (int k = 0; k < steps; ++k) advect(d, f, v, dt, scheme(s), d, ws);
        for (int b = 0; b < 3; ++b) {
            const glm::dvec3 moved = (centreOfMass(d, bands[b], bands[b + 1]) -
                                      centreOfMass(start, bands[b], bands[b + 1])) *
                                     double(f.voxelSize);
            const glm::dvec3 w = glm::dvec3(want[b]) * double(dt * steps);
            const double err = glm::length(moved - w) / f.voxelSize;
            std::printf("[layered] %s %s: moved (%.3f %.3f %.3f) m, wind*t (%.3f %.3f %.3f) m, "
                        "error %.2e cells\n",
                        name(s), names[b], moved.x, moved.y, moved.z, w.x, w.y, w.z, err);
            // the bounds of AdvectUniform.BlobMovesByWindTimesDt (same reasons; MacCormack's
            // limiter drags the centre back by up to 0.015 cells per step here, bound 0.02)
            EXPECT_LT(err, s == AdvectScheme::SemiLagrangian ? 1e-3 : 0.02 * steps) << names[b];
        }
    }
}

TEST(AdvectLayered, InterpolatesLinearlyAndClampsOutsideTheTable) {
    const VelocityField v =
        layeredWind({{0.0f, vec3(1, 0, 0)}, {100.0f, vec3(3, 0, 2)}, {300.0f, vec3(3, 1, 2)}});
    EXPECT_EQ(velocityAt(v, vec3(5, -50, 5)), vec3(1, 0, 0));
    EXPECT_EQ(velocityAt(v, vec3(5, 50, 5)), vec3(2, 0, 1));
    EXPECT_EQ(velocityAt(v, vec3(5, 200, 5)), vec3(3, 0.5f, 2));
    EXPECT_EQ(velocityAt(v, vec3(5, 1e6f, 5)), vec3(3, 1, 2));
    EXPECT_STRNE(validate(layeredWind({})), "");
    EXPECT_STRNE(validate(layeredWind({{1.0f, vec3(0)}, {1.0f, vec3(0)}})), "");
    EXPECT_STRNE(validate(layeredWind({{1.0f, vec3(NAN)}})), "");
    VelocityGrid g;
    g.res = ivec3(2);
    EXPECT_STRNE(validate(centredGrid(g)), ""); // v holds no entries
    g.v.resize(8);
    EXPECT_STREQ(validate(staggeredGrid(g)), "");
}

// --- staggered vs centred velocity grids ---

TEST(AdvectStaggered, SameResultAsCentredForAUniformField) {
    const ivec3 res(24, 20, 28);
    const GridFrame f{vec3(5.0f, -2.0f, 1.0f), 0.25f};
    const vec3 w(1.3f, -0.4f, 0.9f);
    VelocityGrid cg, sg;
    cg.res = res;
    cg.frame = f;
    cg.v.assign(size_t(res.x) * res.y * res.z, w);
    sg.res = res + 1;
    sg.frame = f;
    sg.v.assign(size_t(sg.res.x) * sg.res.y * sg.res.z, w);
    DensityGrid start = blank(res);
    addBlob(start, glm::dvec3(10, 9, 12), 2.0);
    for (AdvectScheme s : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack}) {
        AdvectParams p = scheme(s);
        p.traceCfl = 0.0f; // one substep, as the uniform kind
        DensityGrid a = start, b = start, c = start;
        AdvectWorkspace ws;
        for (int k = 0; k < 5; ++k) {
            advect(a, f, centredGrid(cg), 0.3f, p, a, ws);
            advect(b, f, staggeredGrid(sg), 0.3f, p, b, ws);
            advect(c, f, uniformWind(w), 0.3f, p, c, ws);
        }
        EXPECT_EQ(a.v, b.v) << name(s); // bit for bit
        EXPECT_EQ(a.v, c.v) << name(s);
    }
}

TEST(AdvectStaggered, AgreesWithCentredForALinearField) {
    // a rotation plus a strain is linear in position (and every component varies along every
    // horizontal axis): trilinear lookups of either layout reproduce it (to rounding) inside the
    // grid, so a blob away from the edges advects the same way; a wrong face offset in either
    // layout shifts the velocity by half a cell's worth of gradient
    const ivec3 res(48, 4, 48);
    const GridFrame f{vec3(-24.0f, 0.0f, -24.0f), 1.0f};
    const VelocityGrid cg = rotationGrid(res, f, vec3(0.0f), 0.3f, false, vec3(0.0f), 0.1f);
    const VelocityGrid sg = rotationGrid(res, f, vec3(0.0f), 0.3f, true, vec3(0.0f), 0.1f);
    for (vec3 p : {vec3(3.2f, 1.7f, -5.1f), vec3(-11.0f, 2.0f, 9.9f)}) {
        const vec3 a = velocityAt(centredGrid(cg), p), b = velocityAt(staggeredGrid(sg), p);
        const vec3 want = rotation(p, vec3(0.0f), 0.3f, vec3(0.0f), 0.1f);
        EXPECT_NEAR(a.x, want.x, 1e-5f);
        EXPECT_NEAR(a.z, want.z, 1e-5f);
        EXPECT_NEAR(b.x, want.x, 1e-5f);
        EXPECT_NEAR(b.z, want.z, 1e-5f);
    }
    DensityGrid a = blank(res);
    addBlob(a, glm::dvec3(34, 2, 24), 2.5);
    DensityGrid b = a;
    AdvectWorkspace ws;
    for (int k = 0; k < 10; ++k) {
        advect(a, f, centredGrid(cg), 0.5f, AdvectParams{}, a, ws);
        advect(b, f, staggeredGrid(sg), 0.5f, AdvectParams{}, b, ws);
    }
    float worst = 0.0f;
    for (size_t i = 0; i < a.v.size(); ++i) worst = std::max(worst, std::fabs(a.v[i] - b.v[i]));
    std::printf("[staggered] rotation, 10 steps: max |centred - staggered| %.2e (peak 1)\n", worst);
    EXPECT_LT(worst, 1e-4f);
}

// --- determinism ---

TEST(AdvectDeterminism, OneAndTwoThreadsGiveTheSameBits) {
    const ivec3 res(64, 24, 64); // 1536 rows: both threads get work
    const GridFrame f{vec3(0.0f), 1.0f};
    const VelocityGrid g = rotationGrid(res, f, vec3(32, 0, 30), 0.1f, true, vec3(1, 0.5f, 0));
    DensityGrid start = blank(res);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (float& v : start.v) v = u(rng);
    for (AdvectScheme s : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack}) {
        auto run = [&](int threads, DensityGrid& d, std::vector<AdvectStats>& stats) {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
            d = start;
            AdvectWorkspace ws;
            for (int k = 0; k < 4; ++k)
                stats.push_back(advect(d, f, staggeredGrid(g), 3.0f, scheme(s), d, ws));
        };
        DensityGrid one, two;
        std::vector<AdvectStats> s1, s2;
        run(1, one, s1);
        run(2, two, s2);
        EXPECT_EQ(one.v, two.v) << name(s);
        ASSERT_EQ(s1.size(), s2.size());
        for (size_t k = 0; k < s1.size(); ++k) {
            EXPECT_EQ(s1[k].massBefore, s2[k].massBefore) << name(s); // bit for bit, not near
            EXPECT_EQ(s1[k].massAfter, s2[k].massAfter) << name(s);
            EXPECT_EQ(s1[k].clampedMass, s2[k].clampedMass) << name(s);
            EXPECT_EQ(s1[k].clampedCells, s2[k].clampedCells) << name(s);
            EXPECT_EQ(s1[k].maxCfl, s2[k].maxCfl) << name(s);
        }
        if (s == AdvectScheme::MacCormack) {
            EXPECT_GT(s1[0].clampedCells, 0u);
        }
    }
}

TEST(AdvectRowKernel, SameBitsAsThePerCellPathForUniformAndHorizontalLayeredWinds) {
    const ivec3 res(40, 12, 36);
    const GridFrame f{vec3(-3.0f, 100.0f, 7.0f), 0.5f};
    DensityGrid start = blank(res);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (float& v : start.v) v = u(rng) < 0.6f ? 0.0f : u(rng);
    const VelocityField winds[] = {
        uniformWind(vec3(1.3f, 0.0f, -0.7f)),
        uniformWind(vec3(1.3f, 0.6f, -0.7f)), // vertical: the per-cell path in both
        layeredWind({{101.0f, vec3(0.4f, 0.0f, 2.1f)}, {104.0f, vec3(-3.7f, 0.0f, 0.9f)}}),
        layeredWind({{100.0f, vec3(9.0f, 0.0f, -6.0f)}, {106.0f, vec3(23.0f, 0.0f, 4.0f)}}),
    };
    int compared = 0;
    for (const VelocityField& w : winds)
        for (AdvectScheme sc : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack})
            for (Boundary b : {Boundary::Zero, Boundary::Clamp, Boundary::Periodic})
                for (Backtrace bt : {Backtrace::Euler, Backtrace::RK2}) {
                    AdvectParams fast = scheme(sc);
                    fast.boundary = b;
                    fast.backtrace = bt;
                    AdvectParams slow = fast;
                    slow.rowKernel = false;
                    DensityGrid a = start, c = start;
                    AdvectWorkspace wa, wc;
                    for (int k = 0; k < 3; ++k) {
                        const AdvectStats sa = advect(a, f, w, 0.37f, fast, a, wa);
                        const AdvectStats sc2 = advect(c, f, w, 0.37f, slow, c, wc);
                        ASSERT_EQ(a.v, c.v) << name(sc) << " boundary " << int(b);
                        expectSameStats(sa, sc2);
                    }
                    ++compared;
                }
    EXPECT_EQ(compared, 48);
    // the steps moved something: not a comparison of two untouched grids
    DensityGrid moved = start;
    AdvectWorkspace ws;
    advect(moved, f, winds[2], 0.37f, scheme(AdvectScheme::MacCormack), moved, ws);
    EXPECT_NE(moved.v, start.v);
}

TEST(AdvectGridKernel, SameBitsAsThePerCellPathOnRandomVelocityGrids) {
    // the grid kernel (AdvectParams::rowKernel, a velocity grid) against the per-cell path (the
    // reference): random velocities on centred and staggered grids, on the density's own frame
    // and on a finer, shifted one that does not cover the whole density grid (lookups clamped
    // at its edges), both schemes, every boundary and backtrace, max CFL 0.5, 3 and 12 (up to
    // 12 trace substeps): the grid, the stats, all the same bits
    const ivec3 res(40, 12, 36);
    const GridFrame f{vec3(-3.0f, 100.0f, 7.0f), 0.5f};
    DensityGrid start = blank(res);
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), w(-1.0f, 1.0f);
    for (float& v : start.v) v = u(rng) < 0.5f ? 0.0f : u(rng);
    auto randomGrid = [&](ivec3 r, GridFrame gf) {
        VelocityGrid g;
        g.res = r;
        g.frame = gf;
        g.v.resize(size_t(r.x) * r.y * r.z);
        for (vec3& v : g.v) v = vec3(w(rng), w(rng), w(rng)) + vec3(0.6f, 0.1f, -0.3f);
        return g;
    };
    const GridFrame shifted{f.origin + vec3(1.13f, -0.61f, 2.07f), 0.37f};
    const VelocityGrid grids[] = {randomGrid(res, f), randomGrid(res + 1, f),
                                  randomGrid(ivec3(45, 19, 37), shifted),
                                  randomGrid(ivec3(46, 20, 38), shifted)};
    const VelocityField fields[] = {centredGrid(grids[0]), staggeredGrid(grids[1]),
                                    centredGrid(grids[2]), staggeredGrid(grids[3])};
    int compared = 0, substepped = 0;
    for (const VelocityField& v : fields) {
        AdvectWorkspace probe;
        DensityGrid scratch;
        // maxCfl is |u| |dt| / h at the cell centres: linear in dt
        const float cflPerSecond =
            advect(start, f, v, 1.0f, scheme(AdvectScheme::SemiLagrangian), scratch, probe).maxCfl;
        for (float cfl : {0.5f, 3.0f, 12.0f})
            for (AdvectScheme sc : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack})
                for (Boundary b : {Boundary::Zero, Boundary::Clamp, Boundary::Periodic})
                    for (Backtrace bt : {Backtrace::Euler, Backtrace::RK2, Backtrace::RK3}) {
                        AdvectParams fast = scheme(sc, b);
                        fast.backtrace = bt;
                        AdvectParams slow = fast;
                        slow.rowKernel = false;
                        const float dt = cfl / cflPerSecond;
                        DensityGrid a = start, c = start;
                        AdvectWorkspace wa, wc;
                        for (int k = 0; k < 2; ++k) {
                            const AdvectStats sa = advect(a, f, v, dt, fast, a, wa);
                            const AdvectStats sc2 = advect(c, f, v, dt, slow, c, wc);
                            ASSERT_EQ(a.v, c.v)
                                << name(sc) << " boundary " << int(b) << " backtrace " << int(bt)
                                << " cfl " << cfl << " kind " << int(v.kind);
                            expectSameStats(sa, sc2);
                            if (sa.maxSubsteps > 1) ++substepped;
                        }
                        EXPECT_NE(a.v, start.v); // something moved
                        ++compared;
                    }
    }
    EXPECT_EQ(compared, 4 * 3 * 2 * 3 * 3);
    EXPECT_GT(substepped, 0);
}

// The same on smooth velocity grids (a drift with a slow swirl, on the density's frame), where
// the 8-cell blocks' corners are mostly 8 consecutive entries of one row per (y, z) corner and
// read with plain loads instead of gathers: the grid kernel equals the per-cell path bit for
// bit, both schemes (MacCormack with and without its limiter), the zero boundary (the blocks'
// boundary) and RK2, max CFL 0.5 and 0.9.
TEST(AdvectGridKernel, SameBitsAsThePerCellPathOnSmoothVelocityGrids) {
    const ivec3 res(48, 10, 40);
    const GridFrame f{vec3(2.0f, 50.0f, -4.0f), 0.5f};
    const DensityGrid start = speckled(res, 23, 0.3f);
    const VelocityGrid centred = smoothDrift(res, f), staggered = smoothDrift(res + 1, f);
    int compared = 0;
    for (const VelocityField& v : {centredGrid(centred), staggeredGrid(staggered)}) {
        AdvectWorkspace probe;
        DensityGrid scratch;
        const float cflPerSecond =
            advect(start, f, v, 1.0f, scheme(AdvectScheme::SemiLagrangian), scratch, probe).maxCfl;
        for (float cfl : {0.5f, 0.9f})
            for (int variant = 0; variant < 3; ++variant) {
                const AdvectScheme sc =
                    variant == 0 ? AdvectScheme::SemiLagrangian : AdvectScheme::MacCormack;
                AdvectParams fast = scheme(sc, Boundary::Zero);
                fast.backtrace = Backtrace::RK2;
                fast.limiter = variant != 2;
                AdvectParams slow = fast;
                slow.rowKernel = false;
                const float dt = cfl / cflPerSecond;
                DensityGrid a = start, c = start;
                AdvectWorkspace wa, wc;
                for (int k = 0; k < 3; ++k) {
                    const AdvectStats sa = advect(a, f, v, dt, fast, a, wa);
                    const AdvectStats sc2 = advect(c, f, v, dt, slow, c, wc);
                    ASSERT_EQ(a.v, c.v) << name(sc) << " cfl " << cfl << " kind " << int(v.kind)
                                        << " limiter " << fast.limiter;
                    expectSameStats(sa, sc2);
                }
                EXPECT_NE(a.v, start.v);
                ++compared;
            }
    }
    EXPECT_EQ(compared, 2 * 2 * 3);
}

// staggeredGrid() copies the components into planes that the 8-cell blocks read. A staggered
// field made without them (kind set by hand) takes the per-cell grid kernel: the same bits. A
// grid resized after its field was made no longer matches the planes: validate() says so.
TEST(AdvectStaggered, PlanesAreACopyOfTheGridThatOnlyTheBlocksNeed) {
    const ivec3 res(48, 10, 40);
    const GridFrame f{vec3(2.0f, 50.0f, -4.0f), 0.5f};
    const DensityGrid start = speckled(res, 29, 0.3f);
    VelocityGrid g = smoothDrift(res + 1, f);
    const VelocityField withPlanes = staggeredGrid(g);
    ASSERT_TRUE(withPlanes.planes);
    ASSERT_EQ(withPlanes.planes->size(), 3 * g.v.size());
    EXPECT_EQ((*withPlanes.planes)[g.v.size() + 5], g.v[5].y);
    VelocityField without = centredGrid(g);
    without.kind = VelocityKind::Staggered;
    EXPECT_STREQ(validate(without), "");
    AdvectParams p = scheme(AdvectScheme::MacCormack, Boundary::Zero);
    p.backtrace = Backtrace::RK2;
    DensityGrid a = start, b = start;
    AdvectWorkspace wa, wb;
    for (int k = 0; k < 2; ++k) {
        const AdvectStats sa = advect(a, f, withPlanes, 0.3f, p, a, wa);
        const AdvectStats sb = advect(b, f, without, 0.3f, p, b, wb);
        ASSERT_EQ(a.v, b.v);
        expectSameStats(sa, sb);
    }
    EXPECT_NE(a.v, start.v);
    g.res.x += 1;
    g.v.resize(size_t(g.res.x) * g.res.y * g.res.z, vec3(0.0f));
    EXPECT_NE(std::string(validate(withPlanes)).find("planes"), std::string::npos)
        << validate(withPlanes);
    EXPECT_STREQ(validate(staggeredGrid(g)), "");
}

// MacCormack with a velocity grid runs its two passes as a wavefront over z slabs (pass 2 of a
// slab as soon as the forward step's slabs its lookups read are done; the backward trace's end
// and the limiter's range kept in a ring of slabs that grows when a step reaches further). On a
// grid with many slabs per chunk of rows, a vertical wind that reaches 0.5 to 12 slabs, every
// boundary: the same bits as the per-cell path, two steps in a row (the ring reused).
TEST(AdvectGridKernel, MacCormackWavefrontEqualsThePerCellPath) {
    const ivec3 res(64, 64, 40);
    const GridFrame f{vec3(0.0f), 1.0f};
    DensityGrid start = blank(res);
    std::mt19937 rng(31);
    std::uniform_real_distribution<float> u(0.0f, 1.0f), w(-0.3f, 0.3f);
    for (float& v : start.v) v = u(rng) < 0.4f ? 0.0f : u(rng);
    const VelocityGrid g = gridOf(res, f, [&](int x, int y, int) {
        // mostly vertical, up and down, some noise
        const float nx = w(rng), ny = w(rng), nz = w(rng);
        return vec3(0.3f + nx, ny, std::sin(0.09f * float(x + y)) + 0.2f * nz);
    });
    const VelocityField v = centredGrid(g);
    AdvectWorkspace probe;
    DensityGrid scratch;
    const float cflPerSecond =
        advect(start, f, v, 1.0f, scheme(AdvectScheme::SemiLagrangian), scratch, probe).maxCfl;
    int compared = 0;
    for (Boundary b : {Boundary::Zero, Boundary::Clamp, Boundary::Periodic}) {
        AdvectWorkspace wa; // one workspace across the CFL numbers: the ring grows between steps
        for (float cfl : {0.5f, 3.0f, 12.0f}) {
            AdvectParams fast = scheme(AdvectScheme::MacCormack, b);
            AdvectParams slow = fast;
            slow.rowKernel = false;
            const float dt = cfl / cflPerSecond;
            DensityGrid a = start, c = start;
            AdvectWorkspace wc;
            for (int k = 0; k < 2; ++k) {
                const AdvectStats sa = advect(a, f, v, dt, fast, a, wa);
                const AdvectStats sc = advect(c, f, v, dt, slow, c, wc);
                ASSERT_EQ(a.v, c.v) << "boundary " << int(b) << " cfl " << cfl << " step " << k;
                expectSameStats(sa, sc);
            }
            EXPECT_NE(a.v, start.v);
            // a wavefront, not both passes over the whole grid one after the other: at CFL 0.5
            // with the zero boundary the ring holds fewer slabs than the grid has
            if (b == Boundary::Zero && cfl == 0.5f)
                EXPECT_LT(wa.ring.size() / (5 * size_t(res.x) * size_t(res.y)), size_t(res.z));
            ++compared;
        }
    }
    EXPECT_EQ(compared, 9);
}

// --- the automaton's region ellipsoids follow the same wind ---

TEST(AdvectEllipsoids, MotionHookMovesCentresWithTheLayeredWind) {
    const VelocityField v = layeredWind({{0.0f, vec3(10, 0, 0)}, {400.0f, vec3(0, 0, 20)}});
    EllipsoidWind ew{&v, GridFrame{vec3(0.0f, 100.0f, 0.0f), 10.0f}};
    // cell-space y 10 is world 200 m: t = 0.5, (5, 0, 10) m/s = (0.5, 0, 1) cells/s
    const vec3 m = ellipsoidMotion(vec3(3.0f, 10.0f, 7.0f), 0.0, &ew);
    EXPECT_NEAR(m.x, 0.5f, 1e-6f);
    EXPECT_NEAR(m.y, 0.0f, 1e-6f);
    EXPECT_NEAR(m.z, 1.0f, 1e-6f);
    AutomatonParams p;
    p.res = {64, 16, 64};
    p.lifeMean = 1000.0f; // nothing expires
    p.lifeVar = 0.0f;
    p.regionMargin = 500.0f;
    p.adaptPeriod = 1000;
    p.motion = ellipsoidMotion;
    p.motionUser = &ew;
    AutomatonState s = initialState(p);
    const std::vector<RegionEllipsoid> before = s.ellipsoids;
    ASSERT_FALSE(before.empty());
    s.step = 1;
    updateEllipsoids(s, p);
    ASSERT_GE(s.ellipsoids.size(), before.size());
    for (size_t k = 0; k < before.size(); ++k) {
        const vec3 want = before[k].centre + ellipsoidMotion(before[k].centre, 0.0, &ew) * p.dt;
        EXPECT_EQ(s.ellipsoids[k].centre, want) << k;
    }
}

// --- the table of docs/advection.md ---

TEST(AdvectReport, CflTable) {
    // One turn of the blob at a step's max CFL (over the cell centres) of about 0.1, 1, 10, 50.
    std::printf("| max CFL | steps/turn | scheme | max | min | worst |dm|/m per step | same beyond "
                "the clamps | mass change over the turn | rotation error (rel. L2) | peak | "
                "clamped cells |\n");
    for (double target : {0.1, 1.0, 10.0, 50.0}) {
        const int n = stepsPerTurn(target);
        for (AdvectScheme s : {AdvectScheme::SemiLagrangian, AdvectScheme::MacCormack}) {
            const TurnResult r = oneTurn(s, n);
            std::printf("| %.2f | %d | %s | %.4f | %.4f | %.2e | %.2e | %+.2e | %.5f | %.5f | "
                        "%llu |\n",
                        r.maxCfl, n, name(s), r.hi, r.lo, r.worstStepMass,
                        std::max(0.0, r.worstBeyondClamps), r.totalMass, r.err, r.peak,
                        (unsigned long long)r.clamped);
            EXPECT_FALSE(r.nan);
            EXPECT_LE(r.hi, 1.0f);
            EXPECT_GE(r.lo, 0.0f);
        }
    }
}

} // namespace
