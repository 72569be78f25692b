/// @file image_error.h
/// @brief The one error definition of Nimbus, used by converge, calibrate, bench-vdb-render and
/// the tests: relative RMSE over the cloud's pixels.
///
/// Over the pixels whose alpha in the mask frame (the reference, unless another is given)
/// exceeds kCloudAlpha, and over the R, G and B channels of each (alpha is left out):
///
///     relative RMSE = sqrt(mean((a - ref)^2)) / mean(ref)
///
/// Dividing by the reference's mean (not its RMS) and leaving the background out makes the
/// figure independent of how much empty sky the frame holds and comparable with other
/// renderers' published figures.
#pragma once

#include "core/image.h"

#include <cmath>
#include <algorithm>
#include <cstddef>

namespace nimbus {

/// A pixel belongs to the cloud when the mask's alpha exceeds this.
constexpr float kCloudAlpha = 0.01f;

struct ImageError {
    double rmse = 0.0; ///< over the cloud's pixels, RGB
    double mean = 0.0; ///< of the reference over the same pixels and channels
    size_t pixels = 0; ///< cloud pixels
    double relative() const { return mean > 0.0 ? rmse / mean : 0.0; }
};

/// `a` against `ref` over the cloud's pixels, the cloud taken from `mask` (default: `ref`).
/// The frames must have the same size.
inline ImageError imageError(const Framebuffer& a, const Framebuffer& ref,
                             const Framebuffer* mask = nullptr) {
    if (!mask) mask = &ref;
    ImageError e;
    double sq = 0.0, sum = 0.0;
    const size_t n = ref.rgba.size() / 4;
    for (size_t i = 0; i < n; ++i) {
        if (!(mask->rgba[4 * i + 3] > kCloudAlpha)) continue;
        ++e.pixels;
        for (int c = 0; c < 3; ++c) {
            const double d = double(a.rgba[4 * i + c]) - ref.rgba[4 * i + c];
            sq += d * d;
            sum += ref.rgba[4 * i + c];
        }
    }
    if (e.pixels == 0) return e;
    e.rmse = std::sqrt(sq / double(3 * e.pixels));
    e.mean = sum / double(3 * e.pixels);
    return e;
}

/// The mean of two independent halves of a reference (every channel, alpha included): the
/// reference itself.
inline Framebuffer halvesMean(const Framebuffer& a, const Framebuffer& b) {
    Framebuffer m = a;
    for (size_t i = 0; i < m.rgba.size(); ++i) m.rgba[i] = 0.5f * (a.rgba[i] + b.rgba[i]);
    return m;
}

/// The noise of the mean of two independent halves of a reference, as an RMSE over the cloud's
/// pixels (the cloud taken from `mask`, normally the mean): each half has noise sigma, their
/// difference 2 sigma^2, their mean sigma^2 / 2, so the mean's noise is half the halves' RMSE.
inline double halvesNoise(const Framebuffer& a, const Framebuffer& b, const Framebuffer& mask) {
    return 0.5 * imageError(a, b, &mask).rmse;
}

/// The error left once the reference's own noise is taken out (independent errors add in
/// quadrature).
inline double withoutNoise(double err, double noise) {
    return std::sqrt(std::max(0.0, err * err - noise * noise));
}

} // namespace nimbus
