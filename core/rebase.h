/// @file rebase.h
/// @brief Rendering a volume that lies far from the world origin.
///
/// Positions are floats while a frame renders: 1e7 units out a float resolves only 1 unit, so a
/// small volume there would render shifted and blocky. When the field or the camera lies far
/// away compared with the finest length the frame needs, the renderer translates the whole
/// frame by -origin (computed in double, the VDB's own map read in double) and renders it there;
/// nothing in the picture depends on where the world origin is, so the image is the one the
/// same scene gives near the origin.
///
/// Only scenes whose every position can be moved exactly are translated: a homogeneous or VDB
/// `field` placed as it is (no [[volume]], [[instance]], [[scatter]], ground, mesh or solid, no
/// geometry bound). Procedural fields evaluate their noise at world positions, so translating
/// them would change the cloud: for those, and for the others, the plan keeps its warning.
#pragma once

#include <string>

#include "core/bindings.h"
#include "core/scene.h"

namespace nimbus {

/// Where a frame is rendered relative to. `active` false: at the world origin.
struct Rebase {
    bool active = false;
    glm::dvec3 origin{0.0};
    double distance = 0.0; ///< how far the field or the camera lies from the world origin
    /// why a far scene is not translated (empty when it is, or when it is near the origin)
    std::string blocked;
};

/// Decides for scene `s` with `b` bound. Translates when a float's spacing at the farthest
/// position (field bounds or camera) exceeds 1e-3 of the finest length the frame needs
/// (`fineLength`: the march step, or a 64th of the field's largest extent).
Rebase chooseRebase(const SceneDesc& s, const FrameBindings& b, double fineLength);

/// `s` with every world position moved by -origin (camera, homogeneous box).
SceneDesc rebasedScene(const SceneDesc& s, glm::dvec3 origin);

/// `b` with every grid moved by -origin (core/fields/grid.h shiftedGrid).
FrameBindings rebasedBindings(const FrameBindings& b, glm::dvec3 origin);

} // namespace nimbus
