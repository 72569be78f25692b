/// @file march_params.h
/// @brief The parameter block of the GLSL march pass (plugin/realtime/march_params.glsl) compiled
/// as C++, and how the host fills it from a scene and its frame plan.
///
/// The block is defined once, in the kernels' GLSL/C++ subset; this header includes it inside
/// namespace nimbus::kern after the kernels (core/kernels/kernels.h), so C++ and the shader
/// share the struct, its layout (vec4 members first, then 4-byte scalars: std430 and C++ agree)
/// and the functions that rebuild the kernel structs from it (rtCumulusParams, rtPhaseParams).
#pragma once

#include <cstddef>

#include "core/kernels/kernels.h"
#include "core/plan.h"
#include "core/render.h"
#include "core/scene.h"

namespace nimbus::kern {
#include "plugin/realtime/march_params.glsl"
} // namespace nimbus::kern

namespace nimbus::rt {

using kern::RtMarchParams;

// the layout rule of march_params.glsl: std430 puts the vec4s at multiples of 16 and packs the
// scalars after them; so does C++ when the vec4s come first and are 16 bytes each
static_assert(sizeof(glm::vec4) == 16);
static_assert(offsetof(RtMarchParams, majorantCell) == 23 * 16);
static_assert(offsetof(RtMarchParams, layerBottom) == 29 * 16);
static_assert(sizeof(RtMarchParams) % 4 == 0);

/// The block for frame `plan` of `scene`: camera, field bounds, sun, medium (density scale
/// folded in), sky, the cumulus layer at the plan's time, the phase function, the step
/// schedules of the plan and the march settings. The scene's field must be a cumulus layer or a
/// VDB grid.
/// With `grids` (Renderer::marchGrids), the geometry of its diffusion and photon grids too. For a
/// VDB field (field.kind = "vdb") the box is the bounds of the grid `bindings` holds (the field's
/// box on the CPU, Field::box) and the density scale is field.density.
/// With `majorant` (rt::majorantGrid) where the pass skips with it (rt::skipsWith), the majorant
/// grid's box corner, cell size and cells per axis (RT_SKIP); zeros otherwise.
RtMarchParams marchParams(const SceneDesc& scene, const FramePlan& plan,
                          const MarchGrids* grids = nullptr,
                          const FrameBindings* bindings = nullptr,
                          const MajorantGrid* majorant = nullptr);

} // namespace nimbus::rt
