// Kernel tests: the single-source kernels compiled as C++ against known answers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/fields/cumulus.h"
#include "core/kernels/kernels.h"

using namespace nimbus::kern;

namespace {

vec3 randomPoint(std::mt19937& rng, float scale) {
    std::uniform_real_distribution<float> u(-scale, scale);
    return vec3(u(rng), u(rng), u(rng));
}

} // namespace

TEST(Kernels, HashIsDeterministicAndSpreads) {
    EXPECT_EQ(pcg(1u), pcg(1u));
    EXPECT_NE(pcg(1u), pcg(2u));
    // hashToUnit of consecutive integers fills [0,1) evenly: chi-square over 16 bins
    const int N = 160000, B = 16;
    std::vector<int> bins(B, 0);
    for (int i = 0; i < N; ++i) {
        float u = hashToUnit(pcg(uint(i)));
        ASSERT_GE(u, 0.0f);
        ASSERT_LT(u, 1.0f);
        bins[int(u * B)]++;
    }
    double chi2 = 0.0, e = double(N) / B;
    for (int b : bins) chi2 += (b - e) * (b - e) / e;
    EXPECT_LT(chi2, 37.7); // 15 dof, p = 0.001
}

TEST(Kernels, PerlinRangeAndZeroAtLattice) {
    std::mt19937 rng(1);
    float mn = 1e9f, mx = -1e9f;
    double mean = 0.0;
    const int N = 200000;
    for (int i = 0; i < N; ++i) {
        float v = perlinNoise(randomPoint(rng, 20.0f), 16, 5u);
        mn = std::min(mn, v);
        mx = std::max(mx, v);
        mean += v;
    }
    EXPECT_GE(mn, -1.0f);
    EXPECT_LE(mx, 1.0f);
    EXPECT_LT(mn, -0.6f); // not degenerate
    EXPECT_GT(mx, 0.6f);
    EXPECT_NEAR(mean / N, 0.0, 0.02);
    // gradient noise vanishes on lattice points
    for (int i = -3; i <= 3; ++i)
        EXPECT_NEAR(perlinNoise(vec3(float(i), float(2 * i), 5.0f), 16, 5u), 0.0f, 1e-6f);
}

TEST(Kernels, WorleyRangeAndOneAtFeaturePoints) {
    std::mt19937 rng(2);
    float mn = 1e9f, mx = -1e9f;
    for (int i = 0; i < 100000; ++i) {
        float v = worleyNoise(randomPoint(rng, 20.0f), 8, 3u);
        mn = std::min(mn, v);
        mx = std::max(mx, v);
    }
    EXPECT_GE(mn, 0.0f);
    EXPECT_LE(mx, 1.0f);
    EXPECT_GT(mx, 0.9f);
    EXPECT_LT(mn, 0.55f);
    // at a cell's feature point the distance is 0, so the value is exactly 1 - 0/sqrt(3)
    for (int c = 0; c < 20; ++c) {
        ivec3 cell(c, -c, 2 * c);
        vec3 fp = vec3(cell) + hashToUnit3(latticeHash3(cell, 8, 3u));
        EXPECT_NEAR(worleyNoise(fp, 8, 3u), 1.0f, 1e-5f);
        // half way to... the value falls linearly with distance: 1 - d/sqrt(3) <= 1 - 0.1/sqrt(3)
        EXPECT_LE(worleyNoise(fp + vec3(0.1f, 0.0f, 0.0f), 8, 3u),
                  1.0f - 0.1f / std::sqrt(3.0f) + 1e-5f);
    }
}

TEST(Kernels, NoiseIsTileable) {
    std::mt19937 rng(3);
    for (int i = 0; i < 2000; ++i) {
        vec3 p = randomPoint(rng, 10.0f);
        const int P = 4;
        for (vec3 off : {vec3(P, 0, 0), vec3(0, P, 0), vec3(0, 0, -P), vec3(P, -2 * P, 3 * P)}) {
            ASSERT_NEAR(perlinNoise(p, P, 9u), perlinNoise(p + off, P, 9u), 2e-5f);
            ASSERT_NEAR(worleyNoise(p, P, 9u), worleyNoise(p + off, P, 9u), 2e-5f);
            ASSERT_NEAR(perlinFbm(p, P, 5, 0.5f, 9u), perlinFbm(p + off, P, 5, 0.5f, 9u), 1e-4f);
            ASSERT_NEAR(worleyFbm(p, P, 3, 0.5f, 9u), worleyFbm(p + off, P, 3, 0.5f, 9u), 1e-4f);
            ASSERT_NEAR(perlinWorley(p, P, 4, 9u), perlinWorley(p + off, P, 4, 9u), 1e-4f);
        }
    }
    // and it is not trivially periodic with a smaller period
    int differ = 0;
    for (int i = 0; i < 100; ++i) {
        vec3 p = randomPoint(rng, 10.0f);
        differ += std::abs(perlinNoise(p, 4, 9u) - perlinNoise(p + vec3(2, 0, 0), 4, 9u)) > 1e-3f;
    }
    EXPECT_GT(differ, 50);
}

TEST(Kernels, FbmRanges) {
    std::mt19937 rng(4);
    for (int i = 0; i < 20000; ++i) {
        vec3 p = randomPoint(rng, 8.0f);
        float a = perlinFbm(p, 4, 6, 0.5f, 1u);
        float b = worleyFbm(p, 4, 4, 0.5f, 1u);
        float c = perlinWorley(p, 4, 4, 1u);
        ASSERT_GE(a, -1.0f);
        ASSERT_LE(a, 1.0f);
        ASSERT_GE(b, 0.0f);
        ASSERT_LE(b, 1.0f);
        ASSERT_GE(c, 0.0f);
        ASSERT_LE(c, 1.0f);
    }
}

TEST(Kernels, HeightDistributionMatchesFormula) {
    for (float a : {50.0f, 10.0f, 3.0f})
        for (float b : {4.0f, 1.0f, 0.5f})
            for (int i = 0; i <= 1000; ++i) {
                double h = i / 1000.0;
                double ref = (1.0 - std::exp(-a * h)) * std::exp(-b * h);
                ASSERT_NEAR(heightDistribution(float(h), a, b), ref, 2e-6 * std::max(1.0, ref));
            }
    // the analytic peak is the argmax, and heightProfileMax is the max over an interval
    const float a = 50.0f, b = 4.0f;
    const float hp = heightDistributionPeak(a, b);
    EXPECT_GT(heightDistribution(hp, a, b), heightDistribution(hp - 1e-3f, a, b));
    EXPECT_GT(heightDistribution(hp, a, b), heightDistribution(hp + 1e-3f, a, b));
    EXPECT_NEAR(heightProfile(hp, a, b), 1.0f, 1e-6f);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < 500; ++i) {
        float h0 = u(rng), h1 = u(rng);
        if (h0 > h1) std::swap(h0, h1);
        float brute = 0.0f;
        for (int k = 0; k <= 200; ++k)
            brute = std::max(brute, heightProfile(h0 + (h1 - h0) * k / 200.0f, a, b));
        float m = heightProfileMax(h0, h1, a, b);
        ASSERT_GE(m + 1e-6f, brute);
        ASSERT_LE(m, brute + 0.02f); // and tight
    }
}

TEST(Kernels, TowerBoundIsConservative) {
    CloudLayer L{};
    L.bottom = 0.0f;
    L.top = 1.0f;
    L.heightA = 50.0f;
    L.heightB = 2.0f;
    L.coverage = 0.5f;
    L.softness = 0.1f;
    L.towerSpacing = 4.0f;
    L.towerRadiusMin = 1.0f;
    L.towerRadiusMax = 4.0f;
    L.towerHeightMin = 0.2f;
    L.towerHeightMax = 1.0f;
    L.towerProbability = 0.8f;
    L.towerAnisotropy = 0.6f;
    L.seed = 11u;
    std::mt19937 rng(6);
    std::uniform_real_distribution<float> u(-30.0f, 30.0f), w(0.05f, 3.0f);
    int nonzero = 0;
    for (int i = 0; i < 2000; ++i) {
        float x0 = u(rng), z0 = u(rng), x1 = x0 + w(rng), z1 = z0 + w(rng);
        float h0 = std::abs(u(rng)) / 40.0f, h1 = std::min(1.0f, h0 + w(rng) / 6.0f);
        float bound = towerEnvelopeBound(L, h0, h1, x0, x1, z0, z1);
        for (int k = 0; k < 125; ++k) {
            float x = x0 + (x1 - x0) * (k % 5) / 4.0f, z = z0 + (z1 - z0) * ((k / 5) % 5) / 4.0f;
            float h = h0 + (h1 - h0) * (k / 25) / 4.0f;
            float v = towerEnvelope(L, h, x, z);
            nonzero += v > 0.0f;
            ASSERT_LE(v, bound + 1e-6f) << "box " << x0 << ".." << x1 << " x " << z0 << ".." << z1;
        }
    }
    EXPECT_GT(nonzero, 10000);
}

TEST(Kernels, HenyeyGreensteinNormalisedWithMeanCosineG) {
    for (float g : {-0.9f, -0.5f, 0.0f, 0.3f, 0.8f, 0.95f}) {
        // integrate over the sphere: 2 pi * int_{-1}^{1} p(mu) dmu (Simpson, fine grid)
        const int N = 200000;
        double norm = 0.0, meanCos = 0.0;
        for (int i = 0; i <= N; ++i) {
            double mu = -1.0 + 2.0 * i / N;
            double wgt = (i == 0 || i == N) ? 1.0 : (i % 2 ? 4.0 : 2.0);
            double p = phaseHG(float(mu), g);
            norm += wgt * p;
            meanCos += wgt * p * mu;
        }
        norm *= 2.0 * M_PI * (2.0 / N) / 3.0;
        meanCos *= 2.0 * M_PI * (2.0 / N) / 3.0;
        EXPECT_NEAR(norm, 1.0, 1e-3) << "g=" << g;
        EXPECT_NEAR(meanCos, g, 2e-3) << "g=" << g;
    }
}

TEST(Kernels, HenyeyGreensteinSamplingMatchesEval) {
    // chi-square of sampled cos(theta) against the integrated pdf, bins merged to >= 5 expected
    for (float g : {-0.7f, 0.0f, 0.6f, 0.9f}) {
        const int N = 200000, B = 64;
        std::vector<double> observed(B, 0.0), expected(B, 0.0);
        for (int i = 0; i < N; ++i) {
            float mu = phaseSampleCos(PHASE_HG, g, hashToUnit(pcg(uint(i) * 3u + 1u)));
            observed[std::min(B - 1, int((mu + 1.0f) * 0.5f * B))] += 1.0;
        }
        for (int b = 0; b < B; ++b) {
            const int sub = 400;
            double acc = 0.0;
            for (int k = 0; k < sub; ++k) {
                double mu = -1.0 + 2.0 * (b + (k + 0.5) / sub) / B;
                acc += phaseEval(PHASE_HG, g, float(mu));
            }
            expected[b] = N * 2.0 * M_PI * acc * (2.0 / B) / sub;
        }
        double chi2 = 0.0, eAcc = 0.0, oAcc = 0.0;
        int dof = -1;
        for (int b = 0; b < B; ++b) {
            eAcc += expected[b];
            oAcc += observed[b];
            if (eAcc >= 5.0 || b == B - 1) {
                chi2 += (oAcc - eAcc) * (oAcc - eAcc) / std::max(eAcc, 1e-9);
                eAcc = oAcc = 0.0;
                ++dof;
            }
        }
        // 99.9% quantile of chi2 with dof degrees: dof + 3.1 sqrt(2 dof) + 4 is a safe bound
        EXPECT_LT(chi2, dof + 3.1 * std::sqrt(2.0 * dof) + 4.0) << "g=" << g;
    }
}

TEST(Kernels, LightingTermsMatchFormulas) {
    for (int i = 0; i <= 2000; ++i) {
        float d = i * 0.005f;
        ASSERT_NEAR(beerPowder(d), 2.0 * std::exp(-d) * (1.0 - std::exp(-2.0 * d)), 1e-6);
        ASSERT_NEAR(inScatterOlajos(d, 1.7f), 1.0 - std::exp(-1.7 * d), 1e-6);
        vec3 T = beerLambert(vec3(d, 2.0f * d, 0.5f * d));
        ASSERT_NEAR(T.y, std::exp(-2.0 * d), 1e-6);
    }
    // energy-conserving step: integral of S e^{-sigma s} over [0, dt], and T composes exactly
    for (float sigma : {0.0f, 1e-8f, 0.3f, 5.0f, 200.0f}) {
        vec3 L(0.0f), T(1.0f);
        const float S = 2.5f, dt = 0.7f;
        for (int k = 0; k < 10; ++k) integrateStep(vec3(S), vec3(sigma), dt / 10.0f, L, T);
        double ref = sigma > 0 ? S * (1.0 - std::exp(-double(sigma) * dt)) / sigma : S * dt;
        EXPECT_NEAR(L.x, ref, 1e-5 * std::max(1.0, ref)) << "sigma=" << sigma;
        EXPECT_NEAR(T.x, std::exp(-double(sigma) * dt), 1e-6);
    }
}

TEST(Kernels, CloudShapeIsMonotoneInItsInputs) {
    CloudLayer L{};
    L.coverage = 0.6f;
    L.softness = 0.2f;
    L.erosion = 0.4f;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < 20000; ++i) {
        float e = u(rng), b = u(rng), d = u(rng), k = u(rng);
        float v = cloudShape(L, e, b, d);
        ASSERT_GE(v, 0.0f);
        ASSERT_LE(v, 1.0f);
        ASSERT_LE(v, cloudShape(L, std::min(1.0f, e + k * 0.2f), b, d) + 1e-6f);
        ASSERT_LE(v, cloudShape(L, e, std::min(1.0f, b + k * 0.2f), d) + 1e-6f);
        ASSERT_GE(v, cloudShape(L, e, b, std::min(1.0f, d + k * 0.2f)) - 1e-6f);
    }
    EXPECT_EQ(cloudShape(L, 0.0f, 1.0f, 0.0f), 0.0f);  // no envelope: no cloud
    EXPECT_EQ(cloudShape(L, 1.0f, 0.35f, 0.0f), 0.0f); // base below the threshold 1 - coverage
    EXPECT_EQ(cloudShape(L, 1.0f, 1.0f, 0.0f), 1.0f);  // well above: full density
    // soft edge: half way up the ramp the smoothstep gives exactly 1/2
    EXPECT_NEAR(cloudShape(L, 1.0f, 0.4f + 0.1f, 0.0f), 0.5f, 1e-6f);
}

TEST(Lighting, StepIntegralIsAccurateForTinyAndLargeOpticalDepths) {
    // (S - S e^{-x}) / sigma_t in float cancels for x = sigma_t dt << 1 (at sigma_t = 1e-6,
    // dt = 1e-3 it gave 0 instead of S dt); against the closed form in double, relative
    // error below 1e-5 from x = 1e-9 to 50
    const float S = 9.78f;
    for (float dt : {1e-3f, 0.05f, 1.0f})
        for (double x = 1e-9; x < 50.0; x *= 1.7) {
            const float sigma_t = float(x / dt);
            const double xs = double(sigma_t) * dt;
            const double exact = double(S) * -std::expm1(-xs) / double(sigma_t);
            const double got = stepIntegral(S, sigma_t, dt);
            EXPECT_NEAR(got / exact, 1.0, 1e-5) << "sigma_t " << sigma_t << " dt " << dt;
        }
    EXPECT_FLOAT_EQ(stepIntegral(S, 0.0f, 0.5f), S * 0.5f); // no medium: S dt
}

// The bake (core/fields/cumulus.cpp) hashes each octave's lattice once into a table instead of
// per node and corner; its nodes must stay the kernels' values bit for bit: at the default
// lattices (tables) and at lattices whose upper octaves are too fine for a table (hashed as the
// kernels hash them), for two seeds.
TEST(NoiseBake, TabledOctavesEqualTheKernelsBitForBit) {
    struct Case {
        int baseLattice, baseOctaves, detailLattice, detailOctaves;
        nimbus::kern::uint seed;
    };
    for (const Case k :
         {Case{4, 4, 4, 3, 1u}, Case{3, 5, 5, 4, 0xdeadbeefu}, Case{64, 4, 96, 3, 7u}}) {
        nimbus::CumulusDesc c;
        c.baseLattice = k.baseLattice;
        c.baseOctaves = k.baseOctaves;
        c.detailLattice = k.detailLattice;
        c.detailOctaves = k.detailOctaves;
        c.seed = k.seed;
        c.baseBakeResolution = 20;
        c.detailBakeResolution = 18;
        const nimbus::kern::CumulusParams P = nimbus::cumulusParams(c, 0.0f);
        const auto base = nimbus::bakeCumulusBase(c), detail = nimbus::bakeCumulusDetail(c);
        for (const auto& [vol, isBase] : {std::pair{base, true}, std::pair{detail, false}}) {
            const int res = vol->res;
            int differ = 0;
            for (int z = 0; z < res; ++z)
                for (int y = 0; y < res; ++y)
                    for (int x = 0; x < res; ++x) {
                        const glm::vec3 q = glm::vec3(float(x), float(y), float(z)) / float(res);
                        const float want = isBase ? nimbus::kern::cumulusBaseNoise(P, q)
                                                  : nimbus::kern::cumulusDetailNoise(P, q);
                        differ += vol->values[(size_t(z) * res + y) * res + x] != want;
                    }
            EXPECT_EQ(differ, 0) << (isBase ? "base" : "detail") << " lattice "
                                 << (isBase ? k.baseLattice : k.detailLattice) << " seed "
                                 << k.seed;
        }
    }
}
