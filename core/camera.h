/// @file camera.h
/// @brief Pinhole camera: position, look-at, up, vertical field of view, resolution.
#pragma once

#include <cmath>

#include "core/scene.h"

namespace nimbus {

struct Camera {
    vec3 origin{0.0f};
    vec3 forward{0.0f, 0.0f, 1.0f}, right{1.0f, 0.0f, 0.0f}, up{0.0f, 1.0f, 0.0f};
    float tanHalfY = 1.0f, aspect = 1.0f;
    int width = 1, height = 1;

    explicit Camera(const CameraDesc& d) {
        origin = d.position;
        forward = glm::normalize(d.lookAt - d.position);
        if (!(glm::length(forward) > 0.5f))
            // the squared length overflowed a float (a target over ~1e19 away): in double
            forward = vec3(glm::normalize(glm::dvec3(d.lookAt) - glm::dvec3(d.position)));
        right = glm::normalize(glm::cross(forward, d.up));
        up = glm::cross(right, forward);
        tanHalfY = std::tan(glm::radians(d.fovY) * 0.5f);
        width = d.width;
        height = d.height;
        aspect = float(width) / float(height);
    }

    /// Ray through image position (px, py) in pixels; (0, 0) is the top-left corner.
    Ray generate(float px, float py) const {
        float sx = (2.0f * px / float(width) - 1.0f) * tanHalfY * aspect;
        float sy = (1.0f - 2.0f * py / float(height)) * tanHalfY;
        return Ray{origin, glm::normalize(forward + sx * right + sy * up)};
    }
};

} // namespace nimbus
