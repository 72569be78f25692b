// Lorenz-Mie tests: BHMIE against published values (Bohren & Huffman 1983, appendix A;
// Wiscombe 1979 MIEV0 test cases) and physical limits, then the tabulated cloud phase function:
// normalisation, sampling (chi-square, inverse CDF), and the physics it must show (forward
// peak, fog bow near 140 degrees, glory at 180 degrees, mean cosine of cumulus droplets).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <random>
#include <vector>

#include <tbb/global_control.h>

#include "core/media/mie.h"
#include "core/media/phase.h"

namespace nimbus::phasetest { // defined in test_phase.cpp
struct ChiSquare {
    double chi2 = 0.0;
    double critical = 0.0;
    int dof = 0;
};
double sphereIntegral(const std::function<double(double)>& f, double mu0, double mu1, int panels);
double sphereIntegral(const std::function<double(double)>& f);
ChiSquare chiSquareTest(const std::function<float()>& sample,
                        const std::function<double(double)>& pdf, int samples, int bins);
} // namespace nimbus::phasetest

using namespace nimbus;
using namespace nimbus::phasetest;
using cd = std::complex<double>;

namespace {

/// The default table (r_eff = 10 um, v_eff = 0.1, water at 680/550/440 nm), computed once.
const MieTable& defaultTable() {
    static std::shared_ptr<const MieTable> t = [] {
        auto table = sharedMieTable(MieTableParams{});
        const MieTable::Stats& s = table->stats();
        ::testing::Test::RecordProperty("mie_table_seconds", std::to_string(s.seconds));
        ::testing::Test::RecordProperty("mie_table_cpu_seconds", std::to_string(s.cpuSeconds));
        ::testing::Test::RecordProperty("mie_table_mean_cosine",
                                        std::to_string(table->meanCosine()));
        return table;
    }();
    return *t;
}

double degToCos(double deg) {
    return std::cos(deg * M_PI / 180.0);
}

/// Angle (degrees) of the largest value of channel c in [a, b], scanned every 0.05 degrees.
double argmaxDegrees(const MieTable& t, int c, double a, double b) {
    double best = -1.0, at = a;
    for (double th = a; th <= b + 1e-9; th += 0.05) {
        const double v = t.eval(c, float(degToCos(th)));
        if (v > best) {
            best = v;
            at = th;
        }
    }
    return at;
}

double minOver(const MieTable& t, int c, double a, double b) {
    double m = 1e30;
    for (double th = a; th <= b + 1e-9; th += 0.05)
        m = std::min(m, double(t.eval(c, float(degToCos(th)))));
    return m;
}

} // namespace

// ------------------------------------------------------------------------------ one sphere

TEST(Mie, BohrenHuffmanAppendixExample) {
    // BHMIE's example: n = 1.55, radius 0.525 um, wavelength 0.6328 um (x = 5.2128):
    // Qext = Qsca = 3.10543, Qback = 2.92534, g = 0.63314
    const double x = 2.0 * M_PI * 0.525 / 0.6328;
    const MieSphere r = mieSphere(cd(1.55, 0.0), x);
    EXPECT_NEAR(r.qext, 3.10543, 1e-5);
    EXPECT_NEAR(r.qsca, 3.10543, 1e-5);
    EXPECT_NEAR(r.qback, 2.92534, 1e-5);
    EXPECT_NEAR(r.g, 0.63314, 1e-5);
}

TEST(Mie, WiscombeTestCases) {
    // Wiscombe's MIEV0 test cases (his m = n - ik is our n + ik)
    struct Case {
        cd m;
        double x, qsca, g;
    };
    const Case cases[] = {
        {cd(0.75, 0.0), 10.0, 2.232265, 0.896473},     // case 7
        {cd(0.75, 0.0), 1000.0, 1.997908, 0.844944},   // case 8
        {cd(1.33, 1e-5), 1.0, 0.093923, 0.184517},     // case 9
        {cd(1.33, 1e-5), 100.0, 2.096594, 0.868959},   // case 10
        {cd(1.33, 1e-5), 10000.0, 1.723857, 0.907840}, // case 11: large x
        {cd(1.5, 1.0), 1.0, 0.6634538, 0.192136},      // case 14
        {cd(1.5, 1.0), 10000.0, 1.236575, 0.846309},   // case 16
        {cd(10.0, 10.0), 100.0, 1.836785, 0.556215},   // case 18: |m| large
    };
    for (const Case& c : cases) {
        const MieSphere r = mieSphere(c.m, c.x);
        EXPECT_NEAR(r.qsca, c.qsca, 2e-6) << "m=" << c.m << " x=" << c.x;
        EXPECT_NEAR(r.g, c.g, 2e-6) << "m=" << c.m << " x=" << c.x;
    }
    // amplitudes of case 14 every 30 degrees (Wiscombe's S are the conjugates of ours)
    std::vector<double> mu;
    for (int i = 0; i <= 6; ++i) mu.push_back(degToCos(30.0 * i));
    const MieSphere r = mieSphere(cd(1.5, 1.0), 1.0, mu);
    const cd s1[] = {{0.584080, 0.190515}, {0.565702, 0.187200}, {0.517525, 0.178443},
                     {0.456340, 0.167167}, {0.400212, 0.156643}, {0.362157, 0.149391},
                     {0.348844, 0.146829}};
    const cd s2[] = {{0.584080, 0.190515},    {0.500161, 0.145611},   {0.287964, 0.041054},
                     {0.0362285, -0.0618265}, {-0.174875, -0.122959}, {-0.305682, -0.143846},
                     {-0.348844, -0.146829}};
    for (int i = 0; i <= 6; ++i) {
        EXPECT_NEAR(std::abs(r.s1[i] - std::conj(s1[i])), 0.0, 2e-6) << 30 * i << " deg";
        EXPECT_NEAR(std::abs(r.s2[i] - std::conj(s2[i])), 0.0, 2e-6) << 30 * i << " deg";
    }
}

TEST(Mie, ExtinctionTendsToTwoForLargeSpheres) {
    // extinction paradox: Qext -> 2 (plus an x^{-2/3} edge term)
    for (double x : {500.0, 2000.0, 5000.0}) {
        const MieSphere r = mieSphere(cd(1.333, 1e-8), x);
        EXPECT_NEAR(r.qext, 2.0, 2.0 * std::pow(x, -2.0 / 3.0) + 0.01) << x;
        if (x >= 2000.0) EXPECT_NEAR(r.qext, 2.0, 0.02) << x; // within 1%
        EXPECT_GT(r.qext, 2.0) << x;                          // approached from above
    }
}

TEST(Mie, RayleighLimitForSmallSpheres) {
    for (cd m : {cd(1.333, 0.0), cd(1.55, 0.0), cd(1.5, 0.1)})
        for (double x : {0.001, 0.01, 0.05}) {
            const MieSphere r = mieSphere(m, x);
            const double K = std::norm((m * m - 1.0) / (m * m + 2.0));
            const double rayleigh = 8.0 / 3.0 * std::pow(x, 4) * K;
            EXPECT_NEAR(r.qsca / rayleigh, 1.0, 0.01) << "m=" << m << " x=" << x;
            EXPECT_NEAR(r.g, 0.0, 0.01); // Rayleigh scattering is symmetric
        }
}

TEST(Mie, OpticalTheoremAndNormalisation) {
    // Qext = 4/x^2 Re S(0) (optical theorem) equals the series; S1(0) = S2(0);
    // (|S1|^2 + |S2|^2) / (2 pi x^2 Qsca) integrates to 1 with mean cosine g;
    // Qback = 4/x^2 |S1(180)|^2 / 4 pi ... = |S1(180)|^2 * 4 / x^2
    for (auto [m, x] : {std::pair{cd(1.33, 1e-3), 5.0}, std::pair{cd(1.5, 0.0), 30.0},
                        std::pair{cd(1.333, 1e-8), 120.0}}) {
        const double mu[] = {1.0, -1.0};
        const MieSphere r = mieSphere(m, x, mu);
        EXPECT_NEAR(4.0 / (x * x) * r.s1[0].real(), r.qext, 1e-10 * r.qext);
        EXPECT_NEAR(std::abs(r.s1[0] - r.s2[0]), 0.0, 1e-10 * std::abs(r.s1[0]));
        EXPECT_NEAR(4.0 / (x * x) * std::norm(r.s1[1]), r.qback, 1e-9 * r.qback);
        auto phase = [&](double c) {
            const double one[] = {c};
            const MieSphere s = mieSphere(m, x, one);
            return (std::norm(s.s1[0]) + std::norm(s.s2[0])) / (2.0 * M_PI * x * x * r.qsca);
        };
        const double norm = sphereIntegral(phase, -1.0, 1.0, 64);
        const double meanCos =
            sphereIntegral([&](double c) { return c * phase(c); }, -1.0, 1.0, 64);
        EXPECT_NEAR(norm, 1.0, 1e-6) << "x=" << x;
        EXPECT_NEAR(meanCos, r.g, 1e-6) << "x=" << x;
    }
}

// ------------------------------------------------------------------------------ the table

TEST(MieTable, IsNormalisedPerChannel) {
    const MieTable& t = defaultTable();
    for (int c = 0; c < 4; ++c) {
        const double norm = sphereIntegral([&](double mu) { return t.eval(c, float(mu)); });
        EXPECT_NEAR(norm, 1.0, 2e-4) << "channel " << c;
    }
    // before the rescale the angle grid already integrated the Mie intensity to ~1
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(t.stats().rawNormalisation[c], 1.0, 1e-3) << c;
    // eval(rgb) is the three channels; pdf is their mean
    for (int i = 0; i <= 1000; ++i) {
        const float mu = -1.0f + i / 500.0f;
        const vec3 v = t.eval(mu);
        ASSERT_EQ(v.x, t.eval(0, mu));
        ASSERT_EQ(v.z, t.eval(2, mu));
        ASSERT_NEAR(t.pdf(mu), (v.x + v.y + v.z) / 3.0f, 1e-6f * t.pdf(mu));
    }
}

TEST(MieTable, MeanCosineOfCumulusDroplets) {
    const MieTable& t = defaultTable();
    EXPECT_GE(t.meanCosine(), 0.85f);
    EXPECT_LE(t.meanCosine(), 0.87f);
    for (int c = 0; c < 3; ++c) {
        // the tabulated function (interpolated, forward peak included) has the asymmetry of
        // the size-averaged Mie series
        EXPECT_NEAR(t.meanCosineRGB()[c], t.stats().asymmetry[c], 1e-3) << c;
        const double m = sphereIntegral([&](double mu) { return mu * t.eval(c, float(mu)); });
        EXPECT_NEAR(m, t.meanCosineRGB()[c], 2e-4) << c;
    }
    // and the size-averaged extinction efficiency is close to 2 for droplets this large
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(t.stats().qext[c], 2.0, 0.15) << c;
}

TEST(MieTable, StrongForwardPeak) {
    const MieTable& t = defaultTable();
    for (int c = 0; c < 4; ++c) {
        const float p0 = t.eval(c, 1.0f), p90 = t.eval(c, 0.0f);
        EXPECT_GT(p0, 100.0f * p90) << c;
        EXPECT_GT(p0, 100.0f) << c; // 1/sr: hundreds of times isotropic (1/4 pi)
        // monotone over the diffraction peak
        EXPECT_GT(p0, t.eval(c, float(degToCos(0.5)))) << c;
        EXPECT_GT(t.eval(c, float(degToCos(0.5))), t.eval(c, float(degToCos(2.0)))) << c;
        EXPECT_GT(t.eval(c, float(degToCos(2.0))), t.eval(c, float(degToCos(10.0)))) << c;
    }
}

TEST(MieTable, CloudBowNear140Degrees) {
    const MieTable& t = defaultTable();
    for (int c = 0; c < 4; ++c) {
        const double bow = argmaxDegrees(t, c, 125.0, 155.0);
        RecordProperty("cloud_bow_deg_channel_" + std::to_string(c), std::to_string(bow));
        EXPECT_GE(bow, 135.0) << c;
        EXPECT_LE(bow, 145.0) << c;
        // a real local maximum: well above the dark band before it and the values after it
        const double peak = t.eval(c, float(degToCos(bow)));
        EXPECT_GT(peak, 1.5 * minOver(t, c, 120.0, bow - 5.0)) << c;
        EXPECT_GT(peak, 1.5 * t.eval(c, float(degToCos(155.0)))) << c;
    }
}

TEST(MieTable, GloryRisesTowardBackscatter) {
    const MieTable& t = defaultTable();
    for (int c = 0; c < 4; ++c) {
        const double p180 = t.eval(c, -1.0f);
        const double floor = minOver(t, c, 150.0, 175.0);
        const double glory = argmaxDegrees(t, c, 170.0, 180.0);
        RecordProperty("glory_deg_channel_" + std::to_string(c), std::to_string(glory));
        EXPECT_GT(p180, 3.0 * floor) << c;
        EXPECT_GT(glory, 177.0) << c;
        EXPECT_GT(t.eval(c, float(degToCos(178.0))), t.eval(c, float(degToCos(172.0)))) << c;
    }
}

TEST(MieTable, SamplingMatchesPdfChiSquare) {
    const MieTable& t = defaultTable();
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const ChiSquare r =
        chiSquareTest([&] { return t.sample(u(rng)); },
                      [&](double mu) { return double(t.pdf(float(mu))); }, 1000000, 400);
    EXPECT_LT(r.chi2, r.critical) << "chi2 " << r.chi2 << " with " << r.dof << " dof";
    EXPECT_GT(r.dof, 100);
}

TEST(MieTable, SampleInvertsTheCdf) {
    // exact inversion of the piecewise-quadratic CDF: F(sample(u)) = u, F integrated from the
    // nodes independently of the table's own CDF
    const MieTable& t = defaultTable();
    const std::vector<float>& c = t.cosines();
    const std::vector<float>& p = t.values(MieTable::kSampling);
    auto cdf = [&](double mu) {
        double F = 0.0;
        for (size_t k = 0; k + 1 < c.size() && c[k] < mu; ++k) {
            const double b = std::min<double>(mu, c[k + 1]), h = double(c[k + 1]) - c[k];
            const double pb = p[k] + (p[k + 1] - p[k]) * (b - c[k]) / h;
            F += (b - c[k]) * 0.5 * (p[k] + pb);
        }
        return 2.0 * M_PI * F;
    };
    const double total = cdf(1.0);
    EXPECT_NEAR(total, 1.0, 1e-6);
    float prev = -1.0f;
    for (int i = 0; i <= 2000; ++i) {
        const float u = std::min(i / 2000.0f, 0.99999994f);
        const float mu = t.sample(u);
        ASSERT_GE(mu, prev) << u; // monotone
        prev = mu;
        // tolerance: one float ulp of cos times the density there
        const double ulp = std::nextafter(mu, 2.0f) - mu;
        const double tol = 1e-6 + 2.0 * 2.0 * M_PI * t.pdf(mu) * ulp;
        ASSERT_NEAR(cdf(mu) / total, double(u), tol) << "u=" << u;
    }
    EXPECT_EQ(t.sample(0.0f), -1.0f);
}

TEST(MieTable, PhaseFunctionWrapsTheTable) {
    const MieTable& t = defaultTable();
    MediumDesc m;
    m.phase = PhaseKind::MieTable; // default r_eff / v_eff: the same cached table
    const PhaseFunction f = PhaseFunction::fromMedium(m);
    ASSERT_EQ(f.table(), &t);
    EXPECT_EQ(f.params().kind, kern::PHASE_MIE_TABLE);
    EXPECT_FLOAT_EQ(f.params().g, t.meanCosine()); // the HG stand-in of the kernels
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < 2000; ++i) {
        const PhaseSample s = f.sample(vec2(u(rng), u(rng)));
        ASSERT_EQ(s.pdf, t.pdf(s.cosTheta));
        const vec3 w = t.eval(s.cosTheta) / t.pdf(s.cosTheta);
        ASSERT_NEAR(s.weight.x, w.x, 1e-6f * w.x);
        ASSERT_NEAR(s.weight.z, w.z, 1e-6f * w.z);
    }
    // octaves blend toward isotropic: normalised, mean cosine scaled
    const PhaseFunction o = f.octave(0.5f);
    EXPECT_NEAR(o.meanCosine(), 0.5f * t.meanCosine(), 1e-6f);
    const double norm = sphereIntegral([&](double mu) { return o.eval(float(mu)).y; });
    EXPECT_NEAR(norm, 1.0, 2e-4);
    const ChiSquare r =
        chiSquareTest([&] { return o.sample(vec2(u(rng), u(rng))).cosTheta; },
                      [&](double mu) { return double(o.pdf(float(mu))); }, 300000, 400);
    EXPECT_LT(r.chi2, r.critical) << "chi2 " << r.chi2 << " with " << r.dof << " dof";
}

TEST(MieTable, DoesNotDependOnTheThreadCount) {
    MieTableParams p; // a small, quick table
    p.effectiveRadius = 4.0;
    p.sizeStep = 0.5;
    const MieTable a = MieTable::compute(p);
    MieTable b = [&] {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        return MieTable::compute(p);
    }();
    ASSERT_EQ(a.cosines(), b.cosines());
    for (int c = 0; c < 4; ++c) EXPECT_EQ(a.values(c), b.values(c)) << c;
}

TEST(MieTable, SmallerDropletsScatterLessForward) {
    // physics across droplet sizes: a smaller r_eff gives a smaller mean cosine and a lower,
    // wider diffraction peak
    MieTableParams p;
    p.effectiveRadius = 4.0;
    const MieTable small = MieTable::compute(p);
    const MieTable& big = defaultTable();
    EXPECT_LT(small.meanCosine(), big.meanCosine());
    EXPECT_LT(small.eval(3, 1.0f), big.eval(3, 1.0f));
    EXPECT_GT(small.meanCosine(), 0.75f);
}
