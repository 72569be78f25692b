// The Z-test helper (stats.h) on synthetic data with known answers: it accepts two estimates of
// the same image, rejects a biased one with the same noise, uses the Šidák level it states, and
// treats exact (zero-variance) values as exact.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "stats.h"

namespace {

/// K noisy samples of `truth` (Gaussian, standard deviation `relSd` times each value).
Estimate noisy(const std::vector<double>& truth, int K, double relSd, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, 1.0);
    std::vector<std::vector<double>> samples(K, truth);
    for (auto& s : samples)
        for (size_t i = 0; i < s.size(); ++i) s[i] += relSd * truth[i] * n(rng);
    return estimateFromSamples(samples);
}

std::vector<double> image(size_t size) {
    std::vector<double> v(size);
    for (size_t i = 0; i < size; ++i) v[i] = 0.1 + 0.9 * double(i % 17) / 16.0;
    return v;
}

} // namespace

TEST(ZTest, SidakLevelPerValue) {
    const Estimate a = noisy(image(500), 32, 0.1, 1), b = noisy(image(500), 32, 0.1, 2);
    const ZTestResult r = zTest(a, b, 0.01);
    EXPECT_EQ(r.tested, 500u);
    EXPECT_NEAR(r.alphaValue, 1.0 - std::pow(0.99, 1.0 / 500.0), 1e-12);
    EXPECT_EQ(r.alpha, 0.01);
}

TEST(ZTest, AcceptsTwoEstimatesOfTheSameImage) {
    // 20 independent pairs of 500-value images at alpha 0.01: each pair passes (a wrongly
    // rejected pair would happen with probability about 0.01 each, and these seeds have none)
    const std::vector<double> truth = image(500);
    for (unsigned k = 0; k < 20; ++k)
        EXPECT_TRUE(
            zTestPasses(noisy(truth, 32, 0.1, 2 * k + 10), noisy(truth, 32, 0.1, 2 * k + 11), 0.01))
            << "pair " << k;
}

TEST(ZTest, RejectsABiasedImageWithTheSameNoise) {
    // the same image scaled by 1.05, with the same noise (2% per sample, 32 samples): rejected
    const std::vector<double> truth = image(500);
    const Estimate a = noisy(truth, 32, 0.02, 3), b = noisy(truth, 32, 0.02, 4);
    EXPECT_TRUE(zTestPasses(a, b, 0.01));
    EXPECT_FALSE(zTestPasses(scaled(a, 1.05), b, 0.01));
    // against an exact reference too
    EXPECT_TRUE(zTestPasses(a, exactValues(truth), 0.01));
    EXPECT_FALSE(zTestPasses(scaled(a, 1.05), exactValues(truth), 0.01));
}

TEST(ZTest, ExactValuesMustAgreeExactly) {
    // variance 0 on both sides: a deterministic value; it must match (to 1e-6 relative)
    const Estimate a = exactValues({1.0, 2.0}), b = exactValues({1.0, 2.0 + 1e-3});
    EXPECT_TRUE(zTestPasses(a, a, 0.01));
    const ZTestResult r = zTest(a, b, 0.01);
    EXPECT_FALSE(r.passed());
    EXPECT_EQ(r.exactMismatch, 1u);
    EXPECT_EQ(r.tested, 0u);
}
