/// @file stats.h
/// @brief Statistical comparison of noisy images: a per-value Z-test with a Šidák correction over
/// the values compared, as Mitsuba 3's render tests do (reference + variance images), so that
/// noisy renders are tested at a stated significance level instead of a hand-tuned threshold.
///
/// Each side is an Estimate: per value (pixel and channel) the mean of n independent samples and
/// the variance of one sample. A closed-form reference is an Estimate with variance 0. For every
/// value z = (a - b) / sqrt(var_a / n_a + var_b / n_b); under the hypothesis that both estimate
/// the same expectation z is close to standard normal, and the test rejects when some value's
/// two-sided p-value falls below alpha_value = 1 - (1 - alpha)^(1 / N) (Šidák), N the number of
/// values compared: the whole image is then wrongly rejected with probability alpha.
///
/// @note The variances are themselves estimated (from the spread of K seeds, or of M samples),
/// so z follows Student's t with K - 1 degrees of freedom rather than the normal: with few seeds
/// the test rejects a little more often than alpha says. Use K >= 16 seeds (or many samples).
/// Tests stay deterministic: fixed seeds, so a given build passes or fails every time.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

/// Per value: the mean of n independent samples and the (unbiased) variance of one sample.
struct Estimate {
    std::vector<double> mean;
    std::vector<double> variance;
    double n = 1.0;
};

/// An exact reference (a closed form): variance 0.
inline Estimate exactValues(std::vector<double> values) {
    Estimate e;
    e.variance.assign(values.size(), 0.0);
    e.mean = std::move(values);
    return e;
}

/// Mean and variance over `samples` (each one independent image or value list of equal size).
inline Estimate estimateFromSamples(const std::vector<std::vector<double>>& samples) {
    Estimate e;
    const size_t K = samples.size(), size = K ? samples[0].size() : 0;
    e.n = double(K);
    e.mean.assign(size, 0.0);
    e.variance.assign(size, 0.0);
    for (const auto& s : samples)
        for (size_t i = 0; i < size; ++i) e.mean[i] += s[i] / double(K);
    if (K < 2) return e;
    for (const auto& s : samples)
        for (size_t i = 0; i < size; ++i)
            e.variance[i] += (s[i] - e.mean[i]) * (s[i] - e.mean[i]) / double(K - 1);
    return e;
}

/// The same estimate with every mean multiplied by `factor` (same noise): a deliberately biased
/// image, to show that a Z-test can fail.
inline Estimate scaled(Estimate e, double factor) {
    for (double& m : e.mean) m *= factor;
    return e;
}

/// The outcome of zTest.
struct ZTestResult {
    double alpha = 0.0;       ///< the stated significance level for the whole comparison
    double alphaValue = 0.0;  ///< the Šidák-corrected level per value
    size_t tested = 0;        ///< values with a nonzero variance (N)
    size_t rejected = 0;      ///< values whose p-value fell below alphaValue
    size_t exactMismatch = 0; ///< values with variance 0 on both sides that differ
    double maxAbsZ = 0.0;
    size_t worst = 0; ///< index of the value with the largest |z|
    bool passed() const { return rejected == 0 && exactMismatch == 0; }
};

/// Compares `a` and `b` value by value at significance `alpha` (Šidák over the values tested).
/// Values with variance 0 on both sides must agree to 1e-6 relative (they are deterministic).
inline ZTestResult zTest(const Estimate& a, const Estimate& b, double alpha) {
    ZTestResult r;
    r.alpha = alpha;
    const size_t size = a.mean.size();
    std::vector<double> z(size, 0.0);
    for (size_t i = 0; i < size; ++i) {
        const double var = a.variance[i] / a.n + b.variance[i] / b.n, d = a.mean[i] - b.mean[i];
        if (var <= 0.0) {
            r.exactMismatch += std::abs(d) > 1e-6 * (std::abs(a.mean[i]) + std::abs(b.mean[i]));
            continue;
        }
        z[i] = d / std::sqrt(var);
        ++r.tested;
        if (std::abs(z[i]) > r.maxAbsZ) r.maxAbsZ = std::abs(z[i]), r.worst = i;
    }
    r.alphaValue = r.tested ? -std::expm1(std::log1p(-alpha) / double(r.tested)) : alpha;
    for (size_t i = 0; i < size; ++i)
        if (z[i] != 0.0 && std::erfc(std::abs(z[i]) / std::sqrt(2.0)) < r.alphaValue) ++r.rejected;
    return r;
}

/// zTest as a gtest assertion: EXPECT_TRUE(zTestPasses(render, reference, 0.01)).
inline testing::AssertionResult zTestPasses(const Estimate& a, const Estimate& b, double alpha) {
    const ZTestResult r = zTest(a, b, alpha);
    testing::AssertionResult out =
        r.passed() ? testing::AssertionSuccess() : testing::AssertionFailure();
    out << "Z-test at alpha " << alpha << " over " << r.tested << " values (Šidák: " << r.alphaValue
        << " per value): " << r.rejected << " rejected, " << r.exactMismatch
        << " exact values differ; largest |z| " << r.maxAbsZ << " at value " << r.worst;
    if (r.worst < a.mean.size())
        out << " (" << a.mean[r.worst] << " against " << b.mean[r.worst] << ")";
    return out;
}
