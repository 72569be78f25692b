/// @file field.h
/// @brief Scalar density fields: `density(p)`, `bounds()`, `majorant(box)`.
///
/// A Field is a tagged union of small per-kind structs (core/fields/<kind>.h) with one switch
/// per verb (no virtual dispatch): a homogeneous box, the procedural cumulus layer of Olajos
/// 2016, ch. 2, a NanoVDB grid, Gardner's textured ellipsoids, an SDF cloud and Dobashi's
/// cellular automaton. A Field is the state of one
/// frame: the wind offsets for that frame's time are folded in when it is made. Adding a kind = one
/// file in core/fields, one alternative in Field::Kinds and one case per verb in field.cpp.
#pragma once

#include <memory>
#include <variant>

#include "core/fields/advected_field.h"
#include "core/fields/automaton_field.h"
#include "core/fields/cumulus.h"
#include "core/fields/gardner.h"
#include "core/fields/grid.h"
#include "core/fields/homogeneous.h"
#include "core/fields/sdf_cloud.h"
#include "core/scene.h"
#include "core/sim/advect.h"

namespace nimbus {

/// How a field's density moves around the frame's time (motion blur): the density at time
/// t_frame + dt near p is the frame's density at p - v(p) dt (exact for a uniform wind and a
/// layered wind without vertical components). World units per second, in the field's space.
struct FieldMotion {
    sim::VelocityField velocity;                   ///< Uniform zero when still
    std::shared_ptr<const sim::VelocityGrid> grid; ///< owns velocity.grid (Centred, Staggered)
    bool moving = false;
};

struct Field {
    /// Alternatives in FieldKind order.
    using Kinds = std::variant<HomogeneousField, CumulusField, GridField, GardnerField,
                               SdfCloudField, AutomatonField, AdvectedField>;

    FieldKind kind = FieldKind::Homogeneous;
    Box box; ///< bounds(): no density outside
    Kinds data;
    FieldMotion motion; ///< set by makeField from the field's wind

    const Box& bounds() const { return box; }
    float density(vec3 p) const;
    /// Upper bound of density over the box (conservative, rigorous).
    float majorant(const Box& b) const;
    /// A tighter upper bound than majorant() where one is cheap (grids with a dense copy of
    /// their voxels: the voxels the box's stencils read, not the maxima of whole tree nodes);
    /// false for the others.
    bool tightMajorant(const Box& b, float& m) const;
    /// Whether tightMajorant() gives bounds (a grid with a dense copy).
    bool hasTightMajorant() const {
        return kind == FieldKind::Vdb && as<GridField>().grid && as<GridField>().dense;
    }
    /// Grid fields: calls visit(worldBox, maxDensity) for every tree node that holds density
    /// (leaves, and internal nodes with active tiles), boxes grown by the trilinear support.
    /// Returns false for fields that are not grids.
    template <class F> bool forEachDensityNode(F&& visit) const;

    template <class K> const K& as() const { return *std::get_if<K>(&data); }
};

template <class F> bool Field::forEachDensityNode(F&& visit) const {
    if (kind != FieldKind::Vdb) return false;
    as<GridField>().forEachDensityNode(
        [](void* ctx, const Box& b, float m) {
            (*static_cast<std::remove_reference_t<F>*>(ctx))(b, m);
        },
        &visit);
    return true;
}

/// The field of one frame at time `time` (seconds): a VDB field over `grid` (its loaded grid,
/// core/bindings.h). Pass bakes to read baked noise.
Field makeField(const FieldDesc& desc, float time, const GridBinding& grid,
                std::shared_ptr<const NoiseVolume> baseBake = nullptr,
                std::shared_ptr<const NoiseVolume> detailBake = nullptr);
/// The same with no grid bound (procedural fields; a VDB field is then empty).
Field makeField(const FieldDesc& desc, float time,
                std::shared_ptr<const NoiseVolume> baseBake = nullptr,
                std::shared_ptr<const NoiseVolume> detailBake = nullptr);

/// An automaton field's frame from a simulation kept between frames (Renderer::fieldFor);
/// the same bits as makeField(desc, time), which simulates from step 0.
Field makeField(const FieldDesc& desc, float time, AutomatonSequence& sequence);

/// The frame of a field carried by [field.advect] (desc.advect.enabled): from `sequence`, the
/// Renderer's, which was made from this desc's source (core/fields/advected_field.h).
Field makeAdvectedField(const AdvectDesc& desc, float time, AdvectedSequence& sequence,
                        const FieldMotion& wind, const std::atomic<bool>* cancel = nullptr);
/// The source of an advected field: `desc` without its advection, at time 0.
Field makeAdvectSource(const FieldDesc& desc, const GridBinding& grid);

/// The motion of a layered wind table (still when empty or all zero).
FieldMotion layeredMotion(const std::vector<AutomatonWindRow>& rows);

/// A field without density (an unplaced or empty volume).
Field emptyField();

} // namespace nimbus
