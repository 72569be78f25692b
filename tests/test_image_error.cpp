// The one error definition (core/image_error.h) on frames with known answers: only the cloud's
// pixels count, alpha is left out, and the figure is the RMSE over the reference's mean.
#include <gtest/gtest.h>

#include "core/image_error.h"

#include <array>
#include <cmath>
#include <initializer_list>

using nimbus::Framebuffer;

namespace {

Framebuffer frame(std::initializer_list<std::array<float, 4>> pixels) {
    Framebuffer fb;
    fb.resize(int(pixels.size()), 1, {});
    size_t i = 0;
    for (const auto& p : pixels)
        for (float v : p) fb.rgba[i++] = v;
    return fb;
}

} // namespace

TEST(ImageError, OverTheCloudsRgbDividedByTheMean) {
    // two cloud pixels and one background pixel whose difference must not count
    const Framebuffer ref = frame({{1, 2, 3, 1}, {3, 2, 1, 0.5f}, {0, 0, 0, 0}});
    const Framebuffer a = frame({{2, 2, 3, 0}, {3, 2, 0, 0.5f}, {9, 9, 9, 1}});
    const nimbus::ImageError e = nimbus::imageError(a, ref);
    EXPECT_EQ(e.pixels, 2u);
    EXPECT_DOUBLE_EQ(e.mean, 2.0);                  // (1+2+3+3+2+1) / 6
    EXPECT_DOUBLE_EQ(e.rmse, std::sqrt(2.0 / 6.0)); // two channels off by 1, alpha ignored
    EXPECT_DOUBLE_EQ(e.relative(), std::sqrt(2.0 / 6.0) / 2.0);
}

TEST(ImageError, TheMaskChoosesThePixels) {
    const Framebuffer ref = frame({{1, 1, 1, 0}, {1, 1, 1, 0}});
    const Framebuffer a = frame({{2, 2, 2, 0}, {1, 1, 1, 0}});
    EXPECT_EQ(nimbus::imageError(a, ref).pixels, 0u); // no cloud: nothing to compare
    EXPECT_EQ(nimbus::imageError(a, ref).relative(), 0.0);
    const Framebuffer mask = frame({{0, 0, 0, 1}, {0, 0, 0, 0}});
    EXPECT_DOUBLE_EQ(nimbus::imageError(a, ref, &mask).relative(), 1.0);
}

TEST(ImageError, HalvesNoiseIsTheNoiseOfTheirMean) {
    // halves 0.2 apart: the noise of their mean is estimated as half their RMSE difference
    const Framebuffer a = frame({{1.1f, 1.1f, 1.1f, 1}}), b = frame({{0.9f, 0.9f, 0.9f, 1}});
    const Framebuffer mean = frame({{1, 1, 1, 1}});
    EXPECT_NEAR(nimbus::halvesNoise(a, b, mean), 0.1, 1e-6);
    EXPECT_NEAR(nimbus::withoutNoise(0.5, 0.3), 0.4, 1e-12);
    EXPECT_EQ(nimbus::withoutNoise(0.1, 0.3), 0.0);
}
