/// @file render_util.h
/// @brief Rendering helpers shared by the integrator tests: one frame of a scene and image
/// comparisons (the scenes themselves are in scenes.h).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "core/image_error.h"
#include "core/render.h"
#include "scenes.h"
#include "stats.h"

/// Renders frame `frame` of `s` with what is bound to it (grids, geometry), expecting it to
/// complete with every value finite.
inline nimbus::Framebuffer renderScene(const nimbus::SceneDesc& s,
                                       const nimbus::FrameBindings& bindings,
                                       nimbus::RenderStats* statsOut = nullptr,
                                       nimbus::AovSet aovs = {}, int frame = 1) {
    nimbus::Renderer r(s);
    nimbus::Framebuffer fb;
    nimbus::RenderStats stats;
    EXPECT_TRUE(r.render(r.plan(frame, bindings, aovs), bindings, fb, stats));
    EXPECT_EQ(stats.nonFinite, 0u);
    for (float v : fb.rgba) EXPECT_TRUE(std::isfinite(v));
    if (statsOut) *statsOut = stats;
    return fb;
}

/// Renders frame `frame` of a scene with nothing to bind (procedural fields, no surfaces).
inline nimbus::Framebuffer renderScene(const nimbus::SceneDesc& s,
                                       nimbus::RenderStats* statsOut = nullptr,
                                       nimbus::AovSet aovs = {}, int frame = 1) {
    return renderScene(s, nimbus::FrameBindings{}, statsOut, aovs, frame);
}

/// pathtrace through the pixel centres (as march samples them) as two independent halves of
/// spp / 2 samples: their mean, and the noise of that mean (an RMSE over the cloud's pixels,
/// core/image_error.h).
inline nimbus::Framebuffer pathtraceHalves(nimbus::SceneDesc s, int spp, double& noise) {
    s.render.integrator = nimbus::Integrator::PathTrace;
    s.render.spp = spp / 2;
    s.render.jitter = false;
    const nimbus::Framebuffer a = renderScene(s);
    s.render.seed ^= 0x9e3779b9u;
    const nimbus::Framebuffer b = renderScene(s);
    const nimbus::Framebuffer mean = nimbus::halvesMean(a, b);
    noise = nimbus::halvesNoise(a, b, mean);
    return mean;
}

/// Renders `s` on one thread and on two with tiles of `tileSize` pixels and expects the same
/// image: every pixel's random stream is keyed by the pixel, not the thread.
inline void expectSameImageOnOneAndTwoThreads(nimbus::SceneDesc s, int tileSize = 8) {
    s.render.threads = 1;
    const nimbus::Framebuffer a = renderScene(s);
    s.render.threads = 2;
    s.render.tileSize = tileSize;
    const nimbus::Framebuffer b = renderScene(s);
    EXPECT_EQ(a.rgba, b.rgba);
}

/// Relative RMSE of `a` against `ref` over the cloud's pixels (core/image_error.h: the one
/// error definition of Nimbus).
inline double relativeRmse(const nimbus::Framebuffer& a, const nimbus::Framebuffer& ref) {
    return nimbus::imageError(a, ref).relative();
}

/// Mean of the colour channels over the image.
inline double meanRgb(const nimbus::Framebuffer& fb) {
    double sum = 0.0;
    for (size_t i = 0; i < fb.rgba.size(); ++i)
        if (i % 4 != 3) sum += fb.rgba[i];
    return sum / double(fb.width * fb.height * 3);
}

/// Which values of a frame a statistical comparison looks at.
enum class FrameValues {
    Rgb,          ///< the colour channels, pixel by pixel (alpha left out)
    Transmittance ///< the transmittance AOV (RGB)
};

/// The values `which` of `fb`, in pixel order.
inline std::vector<double> frameValues(const nimbus::Framebuffer& fb,
                                       FrameValues which = FrameValues::Rgb) {
    std::vector<double> out;
    if (which == FrameValues::Transmittance)
        return {fb.transmittance.begin(), fb.transmittance.end()};
    for (size_t i = 0; i < fb.rgba.size(); ++i)
        if (i % 4 != 3) out.push_back(fb.rgba[i]);
    return out;
}

/// `seeds` renders of `s` with seeds firstSeed, firstSeed + 1, ...: the per-value Estimate
/// (stats.h) of the values `which`, for a Z-test.
inline Estimate renderSeeds(nimbus::SceneDesc s, int seeds, FrameValues which = FrameValues::Rgb,
                            std::uint32_t firstSeed = 1000) {
    std::vector<std::vector<double>> samples;
    const nimbus::AovSet aovs{which == FrameValues::Transmittance, false};
    for (int k = 0; k < seeds; ++k) {
        s.render.seed = firstSeed + std::uint32_t(k);
        samples.push_back(frameValues(renderScene(s, nullptr, aovs), which));
    }
    return estimateFromSamples(samples);
}
