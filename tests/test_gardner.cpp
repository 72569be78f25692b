/// @file test_gardner.cpp
/// @brief Gardner's textured ellipsoids (core/fields/gardner.h, core/kernels/gardner.glsl):
/// the density against a hand computation written here independently, the texture's spectrum,
/// the majorant's bounds, the scattered cumulus, and empty-space skipping in the march.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <random>

#include "core/fields/field.h"
#include "core/tracking/majorant.h"
#include "render_util.h"

using namespace nimbus;

namespace {

constexpr double kPi = std::numbers::pi;

/// One of Gardner's sums, in double, straight from the paper's recurrences.
double handSum(double f, int n, double t0, double A, double x, double y) {
    double s = 0.0;
    for (int i = 1; i <= n; ++i) {
        const double Fi = 2.0 * kPi * f * std::pow(2.0, i - 1);
        const double Ci = std::pow(2.0, -0.5 * (i - 1));
        // P_1 = A sin(F_1 y / 2) and P_i = A sin(F_{i-1} y) = A sin(F_i y / 2)
        const double Pi = A * std::sin(0.5 * Fi * y);
        s += Ci * std::sin(Fi * x + Pi) + t0;
    }
    return s;
}

/// I = k S(x; y) S(y; z) S(z; x) / S_max^3, S_max = sum C_i + n T0.
double handTexture(const GardnerTextureDesc& t, vec3 p) {
    const double x = double(p.x) + t.offset.x, y = double(p.y) + t.offset.y,
                 z = double(p.z) + t.offset.z;
    double smax = 0.0;
    for (int i = 1; i <= t.terms; ++i) smax += std::pow(2.0, -0.5 * (i - 1)) + t.t0;
    return t.k * handSum(t.frequency, t.terms, t.t0, t.phase, x, y) *
           handSum(t.frequency, t.terms, t.t0, t.phase, y, z) *
           handSum(t.frequency, t.terms, t.t0, t.phase, z, x) / (smax * smax * smax);
}

/// r^2 of p in an ellipsoid rotated about y only (degrees), in double.
double handR2(const GardnerEllipsoidSpec& e, vec3 p) {
    const double a = e.rotate.y * kPi / 180.0;
    const double dx = p.x - e.center.x, dy = p.y - e.center.y, dz = p.z - e.center.z;
    // local = R^T (p - c), R = rotation about y: x' = cos dx - sin dz, z' = sin dx + cos dz
    const double lx = std::cos(a) * dx - std::sin(a) * dz;
    const double lz = std::sin(a) * dx + std::cos(a) * dz;
    return lx * lx / (e.radii.x * e.radii.x) + dy * dy / (e.radii.y * e.radii.y) +
           lz * lz / (e.radii.z * e.radii.z);
}

/// Gardner's density for one ellipsoid: 1 - a inside, 0 outside.
double handDensity(const GardnerEllipsoidSpec& e, vec3 p) {
    const double r2 = handR2(e, p);
    if (r2 >= 1.0) return 0.0;
    const double g = 1.0 - r2;
    const GardnerShapeDesc& s = e.shape;
    const double I = handTexture(s.texture, p);
    const double a = std::clamp(1.0 - (I - s.t1 - (s.t2 - s.t1) * (1.0 - g)) / s.d, 0.0, 1.0);
    return s.density * (1.0 - a);
}

GardnerDesc twoEllipsoids() {
    GardnerDesc d;
    d.defaults.t1 = 0.01f;
    d.defaults.t2 = 0.12f;
    d.defaults.d = 0.1f;
    d.defaults.density = 1.5f;
    GardnerEllipsoidDesc a;
    a.center = vec3(-4.0f, 2.0f, 0.0f);
    a.radii = vec3(2.5f, 1.5f, 2.0f);
    a.rotate = vec3(0.0f, 30.0f, 0.0f);
    GardnerEllipsoidDesc b;
    b.center = vec3(4.0f, 2.5f, 1.0f);
    b.radii = vec3(2.0f, 2.0f, 1.5f);
    b.rotate = vec3(0.0f, -50.0f, 0.0f);
    b.t2 = 0.5f;
    b.frequency = 0.35f;
    b.terms = 4;
    d.ellipsoids = {a, b};
    return d;
}

GardnerDesc scattered(std::uint32_t seed) {
    GardnerDesc d;
    d.scatter.enabled = true;
    d.scatter.seed = seed;
    return d;
}

Field fieldOf(const GardnerDesc& g) {
    FieldDesc f;
    f.kind = FieldKind::Gardner;
    f.gardner = g;
    return makeField(f, 0.0f);
}

} // namespace

TEST(GardnerDensity, HandComputedSpotValue) {
    // one term, no phase shift: S(x) = sin(2 pi f x) + T0. With f = 1/4 and x = y = z = 1 every
    // sine is sin(pi/2) = 1, so each sum is 1 + T0 = S_max and I = k = 0.8. At (1, 1, 1) in a
    // sphere of radius 2 at the origin r^2 = 3/4, g = 1/4, and
    // a = 1 - (0.8 - 0.1 - (0.5 - 0.1)(0.75)) / 0.5 = 1 - 0.4 / 0.5 = 0.2: density 2 (1 - 0.2).
    GardnerDesc d;
    GardnerEllipsoidDesc e;
    e.radii = vec3(2.0f);
    d.ellipsoids = {e};
    d.defaults = {0.1f, 0.5f, 0.5f, 2.0f, {0.25f, 1, 0.8f, 1.0f, 0.0f, vec3(0.0f)}};
    const Field f = fieldOf(d);
    EXPECT_NEAR(f.density(vec3(1.0f)), 1.6f, 1e-5f);
    // at the centre g = 1: a = 1 - (I - T1) / D with I = k sin(0)^... : every sum is T0 = 1 of
    // S_max = 2, I = 0.8 / 8 = 0.1 = T1: a = 1, density 0
    EXPECT_NEAR(f.density(vec3(0.0f)), 0.0f, 1e-6f);
}

TEST(GardnerDensity, FollowsTheFormulaInsideAndIsZeroOutside) {
    const GardnerDesc d = twoEllipsoids();
    const std::vector<GardnerEllipsoidSpec> es = gardnerEllipsoids(d);
    ASSERT_EQ(es.size(), 2u);
    EXPECT_EQ(es[1].shape.t2, 0.5f);         // its own
    EXPECT_EQ(es[1].shape.t1, 0.01f);        // the cloud's
    EXPECT_EQ(es[1].shape.texture.terms, 4); // its own
    EXPECT_EQ(es[0].shape.texture.terms, 5); // the default
    const Field f = fieldOf(d);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-8.0f, 8.0f), v(-1.0f, 6.0f);
    int inside = 0, positive = 0, outside = 0;
    for (int i = 0; i < 20000; ++i) {
        const vec3 p(u(rng), v(rng), u(rng) * 0.5f);
        const double expect = std::max(handDensity(es[0], p), handDensity(es[1], p));
        const bool in = handR2(es[0], p) < 1.0 || handR2(es[1], p) < 1.0;
        if (!in) {
            ++outside;
            ASSERT_EQ(f.density(p), 0.0f) << p.x << " " << p.y << " " << p.z;
            continue;
        }
        ++inside;
        positive += expect > 0.0;
        ASSERT_NEAR(f.density(p), expect, 2e-4) << p.x << " " << p.y << " " << p.z;
    }
    EXPECT_GT(inside, 1000);
    EXPECT_GT(outside, 1000);
    EXPECT_GT(positive, 300); // the comparison is not all zeros
}

TEST(GardnerTexture, SpectrumHasGardnersFrequenciesAmplitudesAndPhases) {
    // along x (y fixed) a sum is sum_i C_i sin(F_i x + P_i) + n T0 with constant phases: its DFT
    // over one period 1/f has peaks at bins 1, 2, 4, ... (frequencies f 2^(i-1)) of magnitude
    // C_i N / 2 with C_{i+1} / C_i = 1 / sqrt(2), phase P_i - pi/2, the mean n T0, nothing else
    kern::GardnerTexture t{};
    t.frequency = 0.3f;
    t.terms = 5;
    t.k = 1.0f;
    t.t0 = 0.4f;
    t.phase = 1.5707964f;
    const float y = 1.7f;
    const int N = 256;
    std::vector<std::complex<double>> X(N / 2);
    for (int k = 0; k < N / 2; ++k)
        for (int j = 0; j < N; ++j) {
            const double x = double(j) / (double(N) * t.frequency);
            X[size_t(k)] +=
                double(kern::gardnerSum(t, float(x), y)) * std::polar(1.0, -2.0 * kPi * k * j / N);
        }
    EXPECT_NEAR(X[0].real() / N, 5 * 0.4, 1e-5);
    double previous = 0.0;
    for (int k = 1; k < N / 2; ++k) {
        const double mag = std::abs(X[size_t(k)]) / (N / 2.0);
        const int i = int(std::round(std::log2(double(k)))) + 1; // bin 2^(i-1) holds term i
        if ((1 << (i - 1)) != k || i > t.terms) {
            EXPECT_LT(mag, 1e-5) << "bin " << k;
            continue;
        }
        EXPECT_NEAR(mag, std::pow(2.0, -0.5 * (i - 1)), 1e-5) << "term " << i;
        if (i > 1) EXPECT_NEAR(mag / previous, 1.0 / std::sqrt(2.0), 1e-5) << "term " << i;
        previous = mag;
        // phase: P_1 = A sin(F_1 y / 2), P_i = A sin(F_{i-1} y); a sine's DFT phase is P - pi/2
        const double F1 = 2.0 * kPi * t.frequency;
        const double P = t.phase * std::sin((i == 1 ? 0.5 * F1 : F1 * std::pow(2.0, i - 2)) * y);
        const double diff = std::remainder(std::arg(X[size_t(k)]) - (P - 0.5 * kPi), 2.0 * kPi);
        EXPECT_NEAR(diff, 0.0, 1e-4) << "term " << i;
    }
    // the texture along x with no phase shifts is a constant times one sum: the same peaks
    t.phase = 0.0f;
    const float z = 0.6f;
    std::vector<double> ratio;
    for (int k : {1, 2, 4, 8, 16, 3}) {
        std::complex<double> c;
        for (int j = 0; j < N; ++j) {
            const double x = double(j) / (double(N) * t.frequency);
            c += double(kern::gardnerTexture(t, vec3(float(x), y, z))) *
                 std::polar(1.0, -2.0 * kPi * k * j / N);
        }
        ratio.push_back(std::abs(c));
    }
    for (int i = 1; i < 5; ++i) EXPECT_NEAR(ratio[i] / ratio[i - 1], 1.0 / std::sqrt(2.0), 1e-4);
    EXPECT_LT(ratio[5], 1e-5 * ratio[0]); // bin 3: no term
}

TEST(GardnerMajorant, BoundsTheDensityInRandomBoxes) {
    for (std::uint32_t seed : {1u, 2u}) {
        GardnerDesc d = scattered(seed);
        d.ellipsoids = twoEllipsoids().ellipsoids;
        const Field f = fieldOf(d);
        const Box B = f.bounds();
        std::mt19937 rng(seed);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        int tight = 0;
        for (int b = 0; b < 400; ++b) {
            const vec3 lo = B.lo + vec3(u(rng), u(rng), u(rng)) * B.extent();
            const float size = b % 4 == 0 ? 3.0f : b % 4 == 1 ? 0.5f : b % 4 == 2 ? 0.05f : 0.0f;
            const Box box{lo, lo + size * vec3(u(rng), u(rng), u(rng))};
            const float m = f.majorant(box);
            float seen = 0.0f;
            for (int k = 0; k < 200; ++k) {
                const vec3 p = box.lo + vec3(u(rng), u(rng), u(rng)) * box.extent();
                const float rho = f.density(p);
                seen = std::max(seen, rho);
                ASSERT_LE(rho, m) << "box " << b << " point " << p.x << " " << p.y << " " << p.z;
            }
            tight += m > 0.0f && seen > 0.5f * m;
        }
        EXPECT_GT(tight, 20) << "the bound is not everywhere far above the density";
    }
}

TEST(GardnerMajorant, ZeroBetweenEllipsoidsAndTheGridSkipsThere) {
    const GardnerDesc d = twoEllipsoids();
    const Field f = fieldOf(d);
    // the gap between the two: x in [-1, 1.2] clears both (the first reaches x <= -4 + 2.5,
    // the second x >= 4 - 2.0 rotated: at most its longest radius 2 from x = 4)
    EXPECT_EQ(f.majorant(Box{vec3(-1.4f, 0.0f, -3.0f), vec3(1.9f, 5.0f, 3.0f)}), 0.0f);
    // above and below them
    EXPECT_EQ(f.majorant(Box{vec3(-8.0f, 4.6f, -3.0f), vec3(8.0f, 6.0f, 3.0f)}), 0.0f);
    EXPECT_GT(f.majorant(Box{vec3(-5.0f, 1.0f, -1.0f), vec3(-3.0f, 3.0f, 1.0f)}), 0.0f);
    const MajorantGrid g = buildMajorantGrid(f, 0.25f);
    int gapCells = 0;
    for (int z = 0; z < g.res.z; ++z)
        for (int y = 0; y < g.res.y; ++y)
            for (int x = 0; x < g.res.x; ++x) {
                const vec3 lo = g.bounds.lo + vec3(x, y, z) * g.cellSize;
                if (lo.x > -1.2f && lo.x + g.cellSize.x < 1.6f) {
                    EXPECT_EQ(g.at(ivec3(x, y, z)), 0.0f);
                    ++gapCells;
                }
            }
    EXPECT_GT(gapCells, 100);
    EXPECT_GT(g.emptyFraction(), 0.5);
}

TEST(GardnerScatter, DeterministicPerSeedInsideItsBoxOnAFlatBase) {
    GardnerDesc d = scattered(11);
    d.scatter.count = 36;
    const std::vector<GardnerEllipsoidSpec> a = gardnerEllipsoids(d), b = gardnerEllipsoids(d);
    ASSERT_EQ(a.size(), 36u);
    for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].center, b[i].center);
        EXPECT_EQ(a[i].radii, b[i].radii);
    }
    d.scatter.seed = 12;
    const std::vector<GardnerEllipsoidSpec> c = gardnerEllipsoids(d);
    int moved = 0;
    for (size_t i = 0; i < a.size(); ++i) moved += a[i].center != c[i].center;
    EXPECT_GT(moved, 30);
    EXPECT_NE(a[0].shape.texture.offset, c[0].shape.texture.offset);
    const GardnerScatterDesc& s = d.scatter;
    float lowest = 1e9f, largest = 0.0f, smallest = 1e9f;
    for (const GardnerEllipsoidSpec& e : a) {
        const Box box = gardnerEllipsoidBox(e);
        for (int k = 0; k < 3; ++k) {
            const float lo = k == 1 ? s.center.y : s.center[k] - 0.5f * s.extent[k];
            const float hi = k == 1 ? s.center.y + s.extent.y : s.center[k] + 0.5f * s.extent[k];
            EXPECT_GE(box.lo[k], lo - 1e-3f);
            EXPECT_LE(box.hi[k], hi + 1e-3f);
        }
        lowest = std::min(lowest, box.lo.y);
        largest = std::max(largest, e.radii.x);
        smallest = std::min(smallest, e.radii.x);
        EXPECT_LE(e.radii.y, e.radii.x * 1.0001f); // flattened or round, never tall
    }
    EXPECT_NEAR(lowest, s.center.y, 1e-3f); // the base is the plane y = center.y
    EXPECT_GT(largest, 2.0f * smallest);    // large body, small heaps
}

TEST(GardnerMarch, SkippingSameImageFewerLookups) {
    SceneDesc s;
    s.field.kind = FieldKind::Gardner;
    s.field.gardner = twoEllipsoids();
    s.camera.position = vec3(0.0f, 2.5f, -14.0f);
    s.camera.lookAt = vec3(0.0f, 2.3f, 0.0f);
    s.camera.width = 64;
    s.camera.height = 36;
    s.medium.sigma_s = vec3(4.0f);
    s.render.multipleScattering = MultipleScattering::None;
    s.sun.direction = glm::normalize(vec3(0.5f, 0.8f, -0.3f));
    s.render.skipEmpty = false;
    RenderStats off, on;
    const Framebuffer a = renderScene(s, &off, AovSet{true, true});
    s.render.skipEmpty = true;
    const Framebuffer b = renderScene(s, &on, AovSet{true, true});
    EXPECT_TRUE(on.majorantUsed);
    float maxDiff = 0.0f, maxVal = 0.0f;
    for (size_t i = 0; i < a.rgba.size(); ++i) {
        maxDiff = std::max(maxDiff, std::abs(a.rgba[i] - b.rgba[i]));
        maxVal = std::max(maxVal, a.rgba[i]);
    }
    EXPECT_LE(maxDiff, 1e-4f * std::max(1.0f, maxVal));
    EXPECT_GT(maxVal, 0.0f);
    EXPECT_LT(on.lookups() * 3, off.lookups() * 2)
        << "on " << on.lookups() << " off " << off.lookups();
    int cloudy = 0;
    for (size_t i = 0; i < a.transmittance.size(); i += 3) cloudy += a.transmittance[i] < 0.9f;
    EXPECT_GT(cloudy, 50);
}
