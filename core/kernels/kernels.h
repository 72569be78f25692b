/// @file kernels.h
/// @brief The single-source kernels (core/kernels/*.glsl) compiled as C++.
///
/// This include list is THE list of kernel files, in dependency order. CMake reads the
/// `#include "core/kernels/<name>.glsl"` lines below (NIMBUS_KERNEL_FILES) to embed the same
/// files in the same order after prelude.glsl (core/kernels/source.h) and to validate them as
/// GLSL (tests/glsl_check.cmake): a new kernel file is one line here, nothing else.
#pragma once

#include "core/kernels/prelude.h"

namespace nimbus::kern {
#include "core/kernels/hash.glsl"
#include "core/kernels/dda.glsl"
#include "core/kernels/noise.glsl"
#include "core/kernels/cloud.glsl"
#include "core/kernels/phase.glsl"
#include "core/kernels/lighting.glsl"
#include "core/kernels/pixel.glsl"
#include "core/kernels/gardner.glsl"
#include "core/kernels/sdf.glsl"
#include "core/kernels/sdf_tree.glsl"
#include "core/kernels/sdf_shading.glsl"
} // namespace nimbus::kern
