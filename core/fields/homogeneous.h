/// @file homogeneous.h
/// @brief A box of constant density (tests, fog layers, closed-form checks).
#pragma once

#include "core/scene.h"

namespace nimbus {

struct HomogeneousField {
    float rho = 1.0f; ///< density inside the box

    float density(vec3) const { return rho; }
    float majorant(const Box&) const { return rho; }
};

} // namespace nimbus
