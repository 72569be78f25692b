// Phase-function tests: every kind of core/kernels/phase.glsl (through the kernels and through
// PhaseFunction) gets normalisation, pdf == eval, a chi-square test of its sampler against
// eval, and the closed forms it must reduce to. The Lorenz-Mie table has its own tests in
// test_mie.cpp, which uses the quadrature and chi-square helpers defined here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/kernels/kernels.h"
#include "core/media/phase.h"
#include "core/render.h"
#include "plugin/io/scene_file.h"
#include "scenes.h"

namespace nimbus::phasetest {

struct ChiSquare {
    double chi2 = 0.0;
    double critical = 0.0;
    int dof = 0;
};

/// Integral over the solid angle of the directions with cos(theta) in [mu0, mu1] of f(cos):
/// 2 pi int f(cos theta) sin theta dtheta, adaptive Simpson in theta (which resolves forward
/// peaks) started from `panels` equal panels so that no narrow peak is stepped over.
double sphereIntegral(const std::function<double(double)>& f, double mu0, double mu1, int panels) {
    const double th0 = std::acos(std::clamp(mu1, -1.0, 1.0));
    const double th1 = std::acos(std::clamp(mu0, -1.0, 1.0));
    auto h = [&](double th) { return f(std::cos(th)) * std::sin(th); };
    std::function<double(double, double, double, double, double, double, int)> adapt =
        [&](double a, double b, double fa, double fm, double fb, double whole, int depth) {
            const double m = 0.5 * (a + b), lm = 0.5 * (a + m), rm = 0.5 * (m + b);
            const double flm = h(lm), frm = h(rm);
            const double left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
            const double right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
            if (depth <= 0 || std::abs(left + right - whole) < 1e-12)
                return left + right + (left + right - whole) / 15.0;
            return adapt(a, m, fa, flm, fm, left, depth - 1) +
                   adapt(m, b, fm, frm, fb, right, depth - 1);
        };
    double sum = 0.0;
    for (int i = 0; i < panels; ++i) {
        const double a = th0 + (th1 - th0) * i / panels, b = th0 + (th1 - th0) * (i + 1) / panels;
        const double fa = h(a), fm = h(0.5 * (a + b)), fb = h(b);
        sum += adapt(a, b, fa, fm, fb, (b - a) / 6.0 * (fa + 4.0 * fm + fb), 30);
    }
    return 2.0 * M_PI * sum;
}

double sphereIntegral(const std::function<double(double)>& f) {
    return sphereIntegral(f, -1.0, 1.0, 2048);
}

/// Bin coordinate in [0, 2], increasing with cos and close to linear in the angle at both
/// ends, so peaks at 0 and 180 degrees get narrow bins.
double binCoordinate(double mu) {
    return mu < 0.0 ? std::sqrt(1.0 + mu) : 2.0 - std::sqrt(std::max(0.0, 1.0 - mu));
}
double binCoordinateInverse(double s) {
    return s < 1.0 ? s * s - 1.0 : 1.0 - (2.0 - s) * (2.0 - s);
}

/// Pearson's chi-square of `samples` draws of cos(theta) against the density `pdf` (1/sr), in
/// `bins` bins of binCoordinate, neighbouring bins merged until each expects >= 5 samples.
/// critical: the 0.999 quantile of chi-square with dof degrees (Wilson-Hilferty).
ChiSquare chiSquareTest(const std::function<float()>& sample,
                        const std::function<double(double)>& pdf, int samples, int bins = 400) {
    std::vector<double> observed(bins, 0.0), expected(bins, 0.0);
    for (int i = 0; i < samples; ++i) {
        const double s = binCoordinate(sample());
        observed[std::clamp(int(s * 0.5 * bins), 0, bins - 1)] += 1.0;
    }
    for (int b = 0; b < bins; ++b)
        expected[b] = samples * sphereIntegral(pdf, binCoordinateInverse(2.0 * b / bins),
                                               binCoordinateInverse(2.0 * (b + 1) / bins), 8);
    ChiSquare r;
    double e = 0.0, o = 0.0;
    for (int b = 0; b < bins; ++b) {
        e += expected[b];
        o += observed[b];
        if (e >= 5.0 || b == bins - 1) {
            r.chi2 += (o - e) * (o - e) / std::max(e, 1e-12);
            ++r.dof;
            e = o = 0.0;
        }
    }
    r.dof -= 1;
    const double k = r.dof, z = 3.0902; // one-sided p = 0.001
    const double c = 1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k));
    r.critical = k * c * c * c;
    return r;
}

} // namespace nimbus::phasetest

using namespace nimbus;
using namespace nimbus::kern;
using namespace nimbus::phasetest;

namespace {

struct Case {
    std::string name;
    PhaseParams p;
};

/// The configurations every test runs over: each kind, forward and backward, extreme g,
/// tiny g (where textbook samplers cancel), large alpha, the ends of the Mie-fit range.
std::vector<Case> cases() {
    return {
        {"isotropic", phaseParamsIsotropic()},
        {"hg g=0.8", phaseParamsHG(0.8f)},
        {"hg g=-0.6", phaseParamsHG(-0.6f)},
        {"hg g=0.97", phaseParamsHG(0.97f)},
        {"hg g=1e-4", phaseParamsHG(1e-4f)},
        {"dual_hg 0.9/-0.4/0.3", phaseParamsDualHG(0.9f, -0.4f, 0.3f)},
        {"dual_hg 0.2/0.95/0.8", phaseParamsDualHG(0.2f, 0.95f, 0.8f)},
        {"draine g=0.6 a=1", phaseParamsDraine(0.6f, 1.0f)},
        {"draine g=-0.5 a=4", phaseParamsDraine(-0.5f, 4.0f)},
        {"draine g=0.01 a=30", phaseParamsDraine(0.01f, 30.0f)},
        {"draine g=0.95 a=0.5", phaseParamsDraine(0.95f, 0.5f)},
        {"draine g=0 a=1 (rayleigh)", phaseParamsDraine(0.0f, 1.0f)},
        {"mie_approx d=5", phaseParamsMieApprox(5.0f)},
        {"mie_approx d=20", phaseParamsMieApprox(20.0f)},
        {"mie_approx d=50", phaseParamsMieApprox(50.0f)},
    };
}

double hg(double mu, double g) {
    return (1.0 - g * g) / (4.0 * M_PI * std::pow(1.0 + g * g - 2.0 * g * mu, 1.5));
}

double draine(double mu, double g, double a) {
    return hg(mu, g) * (1.0 + a * mu * mu) / (1.0 + a * (1.0 + 2.0 * g * g) / 3.0);
}

/// CDF of Draine by direct numerical integration in double (Simpson in theta).
double draineCdf(double mu, double g, double a) {
    return sphereIntegral([&](double m) { return draine(m, g, a); }, -1.0, mu, 256);
}

} // namespace

TEST(PhaseKernels, EveryKindIsNormalised) {
    for (const Case& c : cases()) {
        const double norm = sphereIntegral([&](double mu) { return phaseEval(c.p, float(mu)); });
        EXPECT_NEAR(norm, 1.0, 1e-4) << c.name;
    }
}

TEST(PhaseKernels, PdfEqualsEval) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (const Case& c : cases())
        for (int i = 0; i < 1000; ++i) {
            const float mu = u(rng);
            ASSERT_EQ(phasePdf(c.p, mu), phaseEval(c.p, mu)) << c.name;
            ASSERT_GT(phaseEval(c.p, mu), 0.0f) << c.name;
        }
}

TEST(PhaseKernels, SamplingMatchesEvalChiSquare) {
    for (const Case& c : cases()) {
        std::mt19937 rng(1234);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        const ChiSquare r =
            chiSquareTest([&] { return phaseSample(c.p, vec2(u(rng), u(rng))); },
                          [&](double mu) { return double(phaseEval(c.p, float(mu))); }, 500000);
        EXPECT_LT(r.chi2, r.critical)
            << c.name << ": chi2 " << r.chi2 << " with " << r.dof << " dof";
        EXPECT_GT(r.dof, 20) << c.name;
    }
}

TEST(PhaseKernels, SamplesStayInRangeAndAreMonotoneInU) {
    for (const Case& c : cases()) {
        float prev = -2.0f;
        for (int i = 0; i <= 4096; ++i) {
            const float u = std::min(float(i) / 4096.0f, 0.99999994f);
            const float mu = phaseSample(c.p, vec2(u, 0.999f)); // one lobe: monotone in u.x
            ASSERT_GE(mu, -1.0f) << c.name;
            ASSERT_LE(mu, 1.0f) << c.name;
            ASSERT_GE(mu, prev - 2.5e-7f) << c.name << " u=" << u; // up to float rounding
            prev = mu;
        }
    }
}

TEST(PhaseKernels, HenyeyGreensteinMeanCosineIsG) {
    for (float g : {-0.9f, -0.3f, 0.0f, 0.5f, 0.85f, 0.97f}) {
        const PhaseParams p = phaseParamsHG(g);
        const double m = sphereIntegral([&](double mu) { return mu * phaseEval(p, float(mu)); });
        EXPECT_NEAR(m, g, 2e-4) << "g=" << g;
        EXPECT_NEAR(PhaseFunction(p).meanCosine(), g, 1e-7);
    }
}

TEST(PhaseKernels, MeanCosinesOfTheOtherKindsMatchPhaseFunction) {
    for (const Case& c : cases()) {
        const double m = sphereIntegral([&](double mu) { return mu * phaseEval(c.p, float(mu)); });
        EXPECT_NEAR(m, PhaseFunction(c.p).meanCosine(), 2e-4) << c.name;
    }
}

TEST(PhaseKernels, HenyeyGreensteinSamplerIsExactForTinyG) {
    // the textbook inverse (1 + g^2 - s^2) / 2g loses ~|log10 g| digits; ours does not
    for (double g : {1e-6, 1e-4, 1e-2, 0.5, -0.9}) {
        for (int i = 0; i <= 100; ++i) {
            const double u = float(i / 100.0); // the float the kernel gets
            const double s = (1.0 - g * g) / (1.0 + g * (2.0 * u - 1.0));
            const double exact = (1.0 + g * g - s * s) / (2.0 * g);
            EXPECT_NEAR(phaseHGSampleCos(float(g), float(u)), exact, 3e-7) << "g=" << g;
        }
    }
}

TEST(PhaseKernels, DualLobeReducesToHG) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (float g : {-0.5f, 0.3f, 0.9f})
        for (float w : {0.0f, 0.25f, 1.0f})
            for (int i = 0; i < 200; ++i) {
                const float mu = 2.0f * u(rng) - 1.0f;
                const PhaseParams same = phaseParamsDualHG(g, g, w);
                ASSERT_NEAR(phaseEval(same, mu), phaseHG(mu, g), 1e-6f * phaseHG(mu, g));
                const vec2 uu(u(rng), u(rng));
                ASSERT_EQ(phaseSample(same, uu), phaseHGSampleCos(g, uu.x));
            }
    // blend 0 and 1 pick one lobe
    EXPECT_EQ(phaseEval(phaseParamsDualHG(0.7f, -0.2f, 0.0f), 0.3f), phaseHG(0.3f, 0.7f));
    EXPECT_NEAR(phaseEval(phaseParamsDualHG(0.7f, -0.2f, 1.0f), 0.3f), phaseHG(0.3f, -0.2f), 1e-7f);
}

TEST(PhaseKernels, DraineReducesToHGAndRayleigh) {
    for (int i = 0; i <= 200; ++i) {
        const float mu = -1.0f + i / 100.0f;
        for (float g : {-0.8f, 0.0f, 0.4f, 0.9f}) {
            ASSERT_NEAR(phaseDraine(mu, g, 0.0f), phaseHG(mu, g), 1e-6f * phaseHG(mu, g));
            ASSERT_NEAR(phaseEval(phaseParamsDraine(g, 0.0f), mu), phaseHG(mu, g),
                        1e-6f * phaseHG(mu, g));
        }
        const double rayleigh = 3.0 / (16.0 * M_PI) * (1.0 + double(mu) * mu);
        ASSERT_NEAR(phaseEval(phaseParamsDraine(0.0f, 1.0f), mu), rayleigh, 1e-7);
    }
    // the sampler too: alpha = 0 is the HG sampler; g = 0, alpha = 1 inverts the Rayleigh CDF
    // F(mu) = (mu^3 + 3 mu + 4) / 8
    for (int i = 0; i <= 1000; ++i) {
        const float u = std::min(i / 1000.0f, 0.9999999f);
        for (float g : {-0.8f, 0.0f, 0.4f, 0.9f})
            ASSERT_EQ(phaseDraineSampleCos(g, 0.0f, u), phaseHGSampleCos(g, u)) << g;
        const double mu = phaseDraineSampleCos(0.0f, 1.0f, u);
        ASSERT_NEAR((mu * mu * mu + 3.0 * mu + 4.0) / 8.0, u, 4e-7) << "u=" << u;
    }
}

TEST(PhaseKernels, DraineSecondMomentClosedFormHasNoCancellation) {
    // M2(mu) = int_{-1}^{mu} t^2 HG(t) 2 pi dt, in float, against double quadrature, for g
    // down to 1e-6 where the direct antiderivative loses everything to a 1/g^3 cancellation
    for (double g : {0.0, 1e-6, 1e-3, 0.05, 0.4, 0.9, 0.99, -0.3, -0.95})
        for (int i = 0; i <= 40; ++i) {
            const double mu = -1.0 + i / 20.0;
            const double ref =
                sphereIntegral([&](double t) { return t * t * hg(t, g); }, -1.0, mu, 256);
            ASSERT_NEAR(phaseDraineM2(float(g), float(mu)), ref, 5e-7) << "g=" << g << " mu=" << mu;
        }
}

TEST(PhaseKernels, DraineSamplerInvertsItsCdf) {
    // exact to float precision: F(sample(u)) = u, F from double quadrature of the density, up
    // to the CDF step of one float ulp of cos (2 pi p(cos) ulp: up to 1e-5 near a g = 0.999 peak)
    const std::pair<double, double> params[] = {{0.6, 1.0},   {-0.5, 4.0},  {1e-4, 2.0},
                                                {0.02, 30.0}, {0.95, 0.5},  {0.999, 3.0},
                                                {-0.99, 1.0}, {0.5, 1000.0}};
    for (auto [g, a] : params)
        for (int i = 1; i < 100; ++i) {
            const double u = i / 100.0;
            const float mu = phaseDraineSampleCos(float(g), float(a), float(u));
            const double ulp = std::nextafter(mu, 2.0f) - mu;
            const double tol = 2e-6 + 2.0 * 2.0 * M_PI * draine(mu, g, a) * ulp;
            EXPECT_NEAR(draineCdf(mu, g, a), u, tol) << "g=" << g << " alpha=" << a;
        }
}

TEST(PhaseKernels, MieApproxParametersMatchTheDesignFormulas) {
    for (double d : {5.0, 7.5, 10.0, 15.0, 20.0, 35.0, 50.0}) {
        const PhaseParams p = phaseParamsMieApprox(float(d));
        const double gHG = std::exp(-0.0990567 / (d - 1.67154));
        const double gD = std::exp(-2.20679 / (d + 3.91029) - 0.428934);
        const double alpha = std::exp(3.62489 - 8.29288 / (d + 5.52825));
        const double w = std::exp(-0.599085 / (d - 0.641583) - 0.665888);
        EXPECT_EQ(p.kind, PHASE_MIE_APPROX);
        EXPECT_NEAR(p.g, gHG, 1e-6) << d;
        EXPECT_NEAR(p.g2, gD, 1e-6) << d;
        EXPECT_NEAR(p.alpha, alpha, 1e-5 * alpha) << d;
        EXPECT_NEAR(p.blend, w, 1e-6) << d;
        EXPECT_FLOAT_EQ(p.diameter, float(d));
        for (int i = 0; i <= 100; ++i) {
            const double mu = -1.0 + i / 50.0;
            const double ref = (1.0 - w) * hg(mu, gHG) + w * draine(mu, gD, alpha);
            ASSERT_NEAR(phaseEval(p, float(mu)), ref, 2e-5 * ref + 1e-7) << d << " " << mu;
        }
    }
    // d = 10 um by hand: g_HG = 0.98818, g_D = 0.55567, alpha = 21.995, w = 0.48196
    const PhaseParams p10 = phaseParamsMieApprox(10.0f);
    EXPECT_NEAR(p10.g, 0.98818, 1e-5);
    EXPECT_NEAR(p10.g2, 0.55567, 1e-5);
    EXPECT_NEAR(p10.alpha, 21.995, 1e-3);
    EXPECT_NEAR(p10.blend, 0.48196, 1e-5);
    // outside the fit's range the diameter is clamped to [5, 50]
    EXPECT_EQ(phaseParamsMieApprox(1.0f).g, phaseParamsMieApprox(5.0f).g);
    EXPECT_EQ(phaseParamsMieApprox(80.0f).alpha, phaseParamsMieApprox(50.0f).alpha);
    EXPECT_EQ(phaseParamsMieApprox(1.0f).diameter, 5.0f);
}

TEST(PhaseKernels, SampledDirectionsHaveTheSampledCosine) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const PhaseParams p = phaseParamsMieApprox(12.0f);
    for (vec3 wi : {vec3(0, 0, 1), vec3(0, 0, -1), glm::normalize(vec3(1, -2, 0.5f)),
                    glm::normalize(vec3(-1e-4f, 1, 0))}) {
        vec3 mean(0.0f);
        const int N = 20000;
        for (int i = 0; i < N; ++i) {
            const vec3 uu(u(rng), u(rng), u(rng));
            const vec3 wo = phaseSampleDirection(p, wi, uu);
            ASSERT_NEAR(glm::length(wo), 1.0f, 1e-5f);
            ASSERT_NEAR(glm::dot(wi, wo), phaseSample(p, vec2(uu.x, uu.y)), 2e-5f);
            mean += wo - glm::dot(wo, wi) * wi;
        }
        // the azimuth is uniform: the component across wi averages to zero
        EXPECT_LT(glm::length(mean / float(N)), 0.02f);
    }
}

TEST(PhaseFunction, FromMediumCoversEveryKind) {
    MediumDesc m;
    m.g = 0.7f;
    m.g2 = -0.2f;
    m.blend = 0.3f;
    m.alpha = 2.0f;
    m.dropletDiameter = 15.0f;
    const std::pair<PhaseKind, int> kinds[] = {{PhaseKind::Isotropic, PHASE_ISOTROPIC},
                                               {PhaseKind::HenyeyGreenstein, PHASE_HG},
                                               {PhaseKind::DualHG, PHASE_DUAL_HG},
                                               {PhaseKind::Draine, PHASE_DRAINE},
                                               {PhaseKind::MieApprox, PHASE_MIE_APPROX}};
    for (auto [kind, value] : kinds) {
        m.phase = kind;
        const PhaseFunction f = PhaseFunction::fromMedium(m);
        EXPECT_EQ(int(kind), value);
        EXPECT_EQ(f.params().kind, value);
        EXPECT_EQ(f.table(), nullptr);
        const double norm = sphereIntegral([&](double mu) { return f.eval(float(mu)).y; });
        EXPECT_NEAR(norm, 1.0, 1e-4) << value;
        std::mt19937 rng(8);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        for (int i = 0; i < 1000; ++i) {
            const PhaseSample s = f.sample(vec2(u(rng), u(rng)));
            ASSERT_EQ(s.pdf, f.pdf(s.cosTheta));
            ASSERT_EQ(s.weight, vec3(1.0f));
            ASSERT_EQ(f.eval(s.cosTheta), vec3(f.pdf(s.cosTheta)));
        }
    }
    EXPECT_EQ(int(PhaseKind::MieTable), PHASE_MIE_TABLE);
}

TEST(PhaseFunction, HenyeyGreensteinOctavesAreTheMarchsOldArithmetic) {
    // core/integrators/march.cpp used phaseEval(kind, g, cos) with g *= eccentricity per octave:
    // the new path must give the same bits
    const float cosTheta = 0.437f, e = 0.5f;
    PhaseFunction f(phaseParamsHG(0.8f));
    float g = 0.8f;
    for (int i = 0; i < 8; ++i) {
        ASSERT_EQ(f.eval(cosTheta), vec3(phaseEval(PHASE_HG, g, cosTheta))) << i;
        f = f.octave(e);
        g *= e;
    }
    PhaseFunction iso;
    EXPECT_EQ(iso.eval(cosTheta), vec3(phaseEval(PHASE_ISOTROPIC, 0.8f, cosTheta)));
    EXPECT_EQ(iso.octave(e).eval(cosTheta), vec3(NB_INV_4PI));
}

TEST(PhaseFunction, OctavesScaleTheAsymmetry) {
    const PhaseFunction d(phaseParamsDualHG(0.8f, -0.3f, 0.25f));
    const PhaseFunction o = d.octave(0.5f);
    EXPECT_FLOAT_EQ(o.params().g, 0.4f);
    EXPECT_FLOAT_EQ(o.params().g2, -0.15f);
    EXPECT_FLOAT_EQ(o.meanCosine(), 0.5f * d.meanCosine());
    const double norm = sphereIntegral([&](double mu) { return o.eval(float(mu)).x; });
    EXPECT_NEAR(norm, 1.0, 1e-4);
}

TEST(PhaseInMarch, EveryKindScalesTheSunTermByItsPhase) {
    // single scattering from the sun only (no sky, no in-scatter term, one octave): every pixel
    // of a homogeneous slab is L_iso(pixel) * 4 pi * phase(cos(view, sun)), per channel
    SceneDesc s =
        homogeneousBox(Box{vec3(-2.0f), vec3(2.0f)}, 0.5f,
                       cameraLookingAt(vec3(0.0f, 0.0f, -4.0f), vec3(0.0f), 24, 16, 50.0f));
    s.medium.sigma_s = vec3(0.6f, 0.8f, 1.0f);
    s.sky.kind = SkyKind::None;
    s.sun.direction = glm::normalize(vec3(0.2f, 0.1f, 1.0f)); // nearly behind the slab
    s.render.octaves = 1;
    s.render.multipleScattering = MultipleScattering::None;
    s.render.inScatter = InScatter::None;
    s.render.background = Background::Transparent;
    s.render.jitter = false;
    auto render = [](const SceneDesc& scene) {
        Renderer r(scene);
        Framebuffer fb;
        RenderStats st;
        EXPECT_TRUE(r.render(r.plan(1), fb, st));
        EXPECT_EQ(st.nonFinite, 0u);
        return fb;
    };
    s.medium.phase = PhaseKind::Isotropic;
    const Framebuffer iso = render(s);
    const Camera cam(s.camera);
    const PhaseKind kinds[] = {PhaseKind::HenyeyGreenstein, PhaseKind::DualHG, PhaseKind::Draine,
                               PhaseKind::MieApprox, PhaseKind::MieTable};
    for (PhaseKind k : kinds) {
        s.medium.phase = k;
        const Framebuffer fb = render(s);
        const PhaseFunction f = PhaseFunction::fromMedium(s.medium);
        for (int y = 0; y < s.camera.height; ++y)
            for (int x = 0; x < s.camera.width; ++x) {
                const float c = glm::dot(cam.generate(x + 0.5f, y + 0.5f).d, s.sun.direction);
                const vec3 p = f.eval(c);
                const size_t i = 4 * (size_t(y) * s.camera.width + x);
                for (int ch = 0; ch < 3; ++ch) {
                    const double expected = iso.rgba[i + ch] * 4.0 * M_PI * p[ch];
                    ASSERT_NEAR(fb.rgba[i + ch], expected, 1e-5 * expected + 1e-9)
                        << int(k) << " pixel " << x << "," << y << " channel " << ch;
                }
            }
    }
}

TEST(PhaseInSceneFiles, MediumKeysParseValidateAndWarn) {
    using io::parseSceneText;
    io::SceneFile f = parseSceneText("[medium]\nphase = \"dual_hg\"\ng = 0.7\ng2 = -0.4\n"
                                     "blend = 0.35\n",
                                     "p.toml");
    EXPECT_EQ(f.scene.medium.phase, PhaseKind::DualHG);
    EXPECT_FLOAT_EQ(f.scene.medium.g2, -0.4f);
    EXPECT_FLOAT_EQ(f.scene.medium.blend, 0.35f);
    EXPECT_TRUE(f.warnings.empty());
    f = parseSceneText("[medium]\nphase = \"draine\"\ng = 0.5\nalpha = 2\n", "p.toml");
    EXPECT_EQ(f.scene.medium.phase, PhaseKind::Draine);
    EXPECT_FLOAT_EQ(f.scene.medium.alpha, 2.0f);
    f = parseSceneText("[medium]\nphase = \"mie_approx\"\ndroplet_diameter = 12\n", "p.toml");
    EXPECT_EQ(f.scene.medium.phase, PhaseKind::MieApprox);
    EXPECT_FLOAT_EQ(f.scene.medium.dropletDiameter, 12.0f);
    f = parseSceneText("[medium]\nphase = \"mie_table\"\neffective_radius = 8\n"
                       "effective_variance = 0.05\n",
                       "p.toml");
    EXPECT_EQ(f.scene.medium.phase, PhaseKind::MieTable);
    EXPECT_FLOAT_EQ(f.scene.medium.effectiveRadius, 8.0f);
    EXPECT_FLOAT_EQ(f.scene.medium.effectiveVariance, 0.05f);
    EXPECT_TRUE(f.warnings.empty());
    // outside the fit's range: an error naming the key and the range
    try {
        parseSceneText("[medium]\nphase = \"mie_approx\"\ndroplet_diameter = 3\n", "p.toml");
        ADD_FAILURE() << "droplet_diameter = 3 accepted";
    } catch (const io::SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("droplet_diameter"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("[5, 50]"), std::string::npos) << e.what();
    }
    // a key of another kind is ignored with a warning
    f = parseSceneText("[medium]\nphase = \"hg\"\ng2 = 0.1\n", "p.toml");
    ASSERT_EQ(f.warnings.size(), 1u);
    EXPECT_NE(f.warnings[0].find("medium.g2 is ignored"), std::string::npos) << f.warnings[0];
}
