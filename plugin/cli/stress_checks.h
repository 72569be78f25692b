/// @file stress_checks.h
/// @brief The checks of `nimbus stress` (plugin/cli/stress.cpp) that are more than a threshold,
/// header-only over core/ so that tests/test_stress.cpp tests them directly: what is wrong in
/// a frame (non-finite, negative, out-of-range values in RGBA and the AOVs), a white furnace's
/// figures, the difference of two images, and a scene scaled by k with its coefficients by 1/k
/// (which must render the same image: every optical depth is unchanged).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/image.h"
#include "core/scene.h"

namespace nimbus::stress {

/// The mean of a set of values and its standard error from their spread (sqrt(var / n)).
struct MeanSe {
    double sum = 0.0, sq = 0.0;
    std::uint64_t n = 0;
    void add(double v) {
        sum += v;
        sq += v * v;
        ++n;
    }
    double mean() const { return n ? sum / double(n) : 0.0; }
    double se() const {
        if (n == 0) return 0.0;
        const double m = mean();
        return std::sqrt(std::max(0.0, sq / double(n) - m * m) / double(n));
    }
};

/// What one frame holds: counts of bad values and the range of the good ones.
struct FrameCheck {
    std::uint64_t nonFinite = 0;          ///< NaN/Inf in RGBA, transmittance or depth
    std::uint64_t negative = 0;           ///< negative RGBA, transmittance or depth
    std::uint64_t alphaOutside = 0;       ///< alpha outside [0, 1] (1e-5 slack)
    std::uint64_t transOutside = 0;       ///< transmittance outside [0, 1] (1e-5 slack)
    std::uint64_t transAlphaMismatch = 0; ///< alpha != 1 - mean transmittance (1e-3 slack)
    double maxRgb = 0.0;                  ///< largest colour value
    double meanRgb = 0.0;                 ///< mean colour value (finite ones)
    double seRgb = 0.0;                   ///< its standard error from the values' spread
    double minT = 1.0, maxT = 0.0;        ///< range of the transmittance AOV (when present)
    bool ok() const {
        return nonFinite == 0 && negative == 0 && alphaOutside == 0 && transOutside == 0;
    }
};

inline FrameCheck checkFrame(const Framebuffer& fb) {
    FrameCheck c;
    constexpr float kSlack = 1e-5f;
    MeanSe rgb;
    for (size_t i = 0; i < fb.rgba.size(); ++i) {
        const float v = fb.rgba[i];
        if (!std::isfinite(v)) {
            ++c.nonFinite;
            continue;
        }
        if (v < 0.0f) ++c.negative;
        if (i % 4 == 3) {
            if (v < -kSlack || v > 1.0f + kSlack) ++c.alphaOutside;
        } else {
            c.maxRgb = std::max(c.maxRgb, double(v));
            rgb.add(v);
        }
    }
    c.meanRgb = rgb.mean();
    c.seRgb = rgb.se();
    for (size_t i = 0; i < fb.transmittance.size(); ++i) {
        const float t = fb.transmittance[i];
        if (!std::isfinite(t)) {
            ++c.nonFinite;
            continue;
        }
        if (t < 0.0f) ++c.negative;
        if (t < -kSlack || t > 1.0f + kSlack) ++c.transOutside;
        c.minT = std::min(c.minT, double(t));
        c.maxT = std::max(c.maxT, double(t));
    }
    for (float d : fb.depth) {
        if (!std::isfinite(d))
            ++c.nonFinite;
        else if (d < 0.0f)
            ++c.negative;
    }
    return c;
}

/// A white furnace's figures over the colour values of a frame (background sky included): the
/// mean, its standard error from the spread of the values, and the largest value.
struct Furnace {
    double mean = 0.0, se = 0.0, max = 0.0;
    std::uint64_t values = 0;
    /// Energy bounded: the mean is at most `sky` plus `z` standard errors and a float slack.
    bool bounded(double sky, double z = 4.0) const { return mean <= sky * (1.0 + 1e-4) + z * se; }
};

inline Furnace furnace(const Framebuffer& fb) {
    Furnace f;
    MeanSe m;
    for (size_t i = 0; i < fb.rgba.size(); ++i) {
        if (i % 4 == 3) continue;
        const double v = fb.rgba[i];
        m.add(v);
        f.max = std::max(f.max, v);
    }
    f.values = m.n;
    f.mean = m.mean();
    f.se = m.se();
    return f;
}

/// Relative difference of two frames of equal size over RGBA: |a - b| / |b| (Euclidean norms
/// over every value); 0 when both are zero, infinite when the sizes differ or a value is not
/// finite.
inline double relativeDifference(const Framebuffer& a, const Framebuffer& b) {
    if (a.rgba.size() != b.rgba.size()) return INFINITY;
    double d2 = 0.0, b2 = 0.0;
    for (size_t i = 0; i < a.rgba.size(); ++i) {
        const double d = double(a.rgba[i]) - b.rgba[i];
        d2 += d * d;
        b2 += double(b.rgba[i]) * b.rgba[i];
    }
    if (!std::isfinite(d2) || !std::isfinite(b2)) return INFINITY;
    if (b2 == 0.0) return d2 == 0.0 ? 0.0 : INFINITY;
    return std::sqrt(d2 / b2);
}

/// The scene scaled by k about the origin with every coefficient scaled by 1/k: the same
/// optical depths, the same image. Scales the camera, homogeneous box, SDF tree's root transform,
/// explicit steps and grid cells and the ground; a VDB grid's voxel size is the host's to scale
/// (its transform is in the binding). Cumulus and Gardner fields are not scaled (their noise
/// periods are many keys); the caller leaves them out.
inline SceneDesc scaleWorld(SceneDesc s, double k) {
    const float kf = float(k);
    s.camera.position *= kf;
    s.camera.lookAt *= kf;
    s.field.homogeneous.box.lo *= kf;
    s.field.homogeneous.box.hi *= kf;
    s.field.sdf.root.transform.translate *= kf;
    s.field.sdf.root.transform.scale *= kf;
    s.field.sdf.falloff *= kf;
    s.medium.sigma_s = vec3(glm::dvec3(s.medium.sigma_s) / k);
    s.medium.sigma_a = vec3(glm::dvec3(s.medium.sigma_a) / k);
    s.render.step *= kf;
    s.render.shadowStep *= kf;
    s.render.majorantCell *= kf;
    s.render.lightVolumeCell *= kf;
    s.ground.height *= kf;
    s.ground.extent *= kf;
    return s;
}

} // namespace nimbus::stress
