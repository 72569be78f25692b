/// @file sampler.h
/// @brief Counter-based random numbers: value n of stream `key` is a hash of (key, n), so every
/// pixel, sample and path vertex draws the same numbers whatever the thread or tile order.
#pragma once

#include <cstdint>

#include "core/kernels/kernels.h"

namespace nimbus {

struct Sampler {
    std::uint32_t key = 0;
    std::uint32_t n = 0;

    /// Stream for (pixel x, y, frame key, sample index).
    static Sampler forPixel(int x, int y, std::uint32_t frameKey, std::uint32_t sample) {
        Sampler s;
        s.key = kern::pcg(std::uint32_t(x) ^
                          kern::pcg(std::uint32_t(y) ^ kern::pcg(frameKey ^ kern::pcg(sample))));
        return s;
    }
    /// Uniform float in [0, 1).
    float next() {
        const kern::uvec3 h = kern::pcg3d(kern::uvec3(key, n++, 0x68bc21ebu));
        return kern::hashToUnit(h.x);
    }
};

} // namespace nimbus
