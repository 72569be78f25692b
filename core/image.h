/// @file image.h
/// @brief Frame buffers: the beauty pass and the optional AOVs of one frame, scene-linear.
#pragma once

#include <cstddef>
#include <vector>

namespace nimbus {

struct AovSet {
    bool transmittance = false; ///< RGB transmittance of the whole camera ray
    bool depth = false; ///< distance at which transmittance first falls below 0.5 (0 if never)
};

struct Framebuffer {
    int width = 0;
    int height = 0;
    AovSet aovs;
    std::vector<float> rgba;          ///< 4 floats per pixel, premultiplied, working space
    std::vector<float> transmittance; ///< 3 floats per pixel, empty unless aovs.transmittance
    std::vector<float> depth;         ///< 1 float per pixel, empty unless aovs.depth

    void resize(int w, int h, AovSet a) {
        width = w;
        height = h;
        aovs = a;
        rgba.assign(size_t(w) * h * 4, 0.0f);
        // an AOV not asked for holds no memory, even in a buffer reused from a frame that had it
        auto aov = [](std::vector<float>& v, bool wanted, size_t n) {
            if (wanted)
                v.assign(n, 0.0f);
            else
                std::vector<float>().swap(v);
        };
        aov(transmittance, a.transmittance, size_t(w) * h * 3);
        aov(depth, a.depth, size_t(w) * h);
    }
    /// Bytes held by the AOV buffers (beyond the beauty pass).
    size_t aovBytes() const {
        return (transmittance.capacity() + depth.capacity()) * sizeof(float);
    }
};

} // namespace nimbus
