/// @file counters.h
/// @brief What an integrator counts while it renders a tile (added up per frame in RenderStats).
#pragma once

#include <cstdint>

namespace nimbus {

struct RayCounters {
    std::uint64_t rays = 0;
    std::uint64_t primarySamples = 0; ///< density lookups on camera rays (and path segments)
    std::uint64_t shadowSamples = 0;  ///< density lookups on shadow rays
    /// density lookups on the flights of march's paths for the sun's orders from the second
    /// (render.photon_second_share, photon_march_depth; their shadow rays count as shadow rays)
    std::uint64_t secondSamples = 0;
    std::uint64_t nonFinite = 0; ///< pixels or samples that were NaN/Inf (replaced by 0)
};

} // namespace nimbus
