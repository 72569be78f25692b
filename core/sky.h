/// @file sky.h
/// @brief Sky radiance by direction: uniform, or a gradient from the horizon (and below) to the
/// zenith. Shared by every integrator.
#pragma once

#include <algorithm>
#include <cmath>

#include "core/scene.h"

namespace nimbus {

inline vec3 skyRadiance(const SkyDesc& sky, vec3 d) {
    switch (sky.kind) {
    case SkyKind::None:
        return vec3(0.0f);
    case SkyKind::Uniform:
        return sky.zenith;
    case SkyKind::Gradient:
        return glm::mix(sky.horizon, sky.zenith, std::sqrt(std::clamp(d.y, 0.0f, 1.0f)));
    }
    return vec3(0.0f);
}

} // namespace nimbus
