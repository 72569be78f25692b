/// @file kernels.h
/// @brief The single-source kernels (core/kernels/*.glsl) compiled as C++.
///
/// Include order is the dependency order; the GLSL side assembles the same files in the same
/// order after prelude.glsl (see tests/glsl_check.cmake and NIMBUS_KERNEL_FILES in CMake).
#pragma once

#include "core/kernels/prelude.h"

namespace nimbus::kern {
#include "core/kernels/hash.glsl"
#include "core/kernels/dda.glsl"
#include "core/kernels/noise.glsl"
#include "core/kernels/cloud.glsl"
#include "core/kernels/phase.glsl"
#include "core/kernels/lighting.glsl"
} // namespace nimbus::kern
