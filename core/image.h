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
        transmittance.assign(a.transmittance ? size_t(w) * h * 3 : 0, 0.0f);
        depth.assign(a.depth ? size_t(w) * h : 0, 0.0f);
    }
};

} // namespace nimbus
