/// @file bindings.h
/// @brief What the host loaded for one frame beside the scene's description: the VDB grids of
/// the placed volumes and the geometry backend (Embree) when the scene has surfaces or
/// instances.
///
/// SceneDesc (core/scene.h) holds descriptions only; a Renderer takes these per frame
/// (Renderer::plan, Renderer::render). core/ never reads files: plugin/vdb fills GridBinding
/// (vdb::bindVdbField), plugin/geom the geometry, plugin/host both.
#pragma once

#include <memory>
#include <vector>

#include "core/accel.h"
#include "core/geometry.h"
#include "core/sim/advect.h"

namespace nimbus {

/// One volume's loaded density grid. Type-erased so that core's headers need not include
/// NanoVDB: `grid` is a nanovdb::FloatGrid (core/fields/grid.cpp casts it back).
struct GridBinding {
    std::shared_ptr<const void> owner; ///< keeps the grid's memory alive
    const void* grid = nullptr;        ///< a nanovdb::FloatGrid; null: no density
    Box bounds;                        ///< world bounds of the density (trilinear support)
    /// Subtracted (in double) from the grid's world positions: the frame is rendered relative
    /// to this point when it lies far from the origin (core/rebase.h). `bounds` is then in
    /// that shifted space too.
    glm::dvec3 shift{0.0};
};

/// Everything bound to one frame.
struct FrameBindings {
    /// One entry per volume: 0 = the scene's `field`, i = volumes[i - 1]. Entries of
    /// non-VDB or unplaced volumes stay empty; the vector may be shorter than the volumes.
    std::vector<GridBinding> grids;
    /// Surfaces and the instance query; null: instances are found by a linear scan and there
    /// are no surfaces.
    std::shared_ptr<const GeometryBackend> geometry;
    /// `[field.advect] velocity`: the frame's velocity grid (world units / s, already scaled),
    /// read by plugin/vdb; null when the scene names none.
    std::shared_ptr<const sim::VelocityGrid> velocity;
    bool velocityStaggered = false; ///< the grid's layout (MAC faces) as read
    /// Planned before the frame's files were read (`--explain`): a null velocity means "not
    /// read yet", which the plan states, instead of "missing", which it refuses.
    bool unread = false;

    /// The grid of volume `i` (an empty binding when there is none).
    const GridBinding& grid(int i) const {
        static const GridBinding none;
        return i >= 0 && size_t(i) < grids.size() ? grids[size_t(i)] : none;
    }
};

} // namespace nimbus
