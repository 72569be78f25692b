/// @file enum_mirrors.h
/// @brief Host enums that the kernels mirror as int constants, checked value by value at compile
///        time (GLSL has no enums; the kernels switch on ints).
///
/// Mirrored today: PhaseKind (core/scene.h) = PHASE_* (core/kernels/phase.glsl); PhaseParams::kind
/// holds int(PhaseKind); SkyKind = SKY_* (core/kernels/lighting.glsl). To mirror another: a
/// constexpr switch with one case per enumerator and no default (a missing case is an error,
/// -Wswitch is made an error below), one static_assert per value, and the all-values check.
#pragma once

#include "core/kernels/kernels.h"
#include "core/scene.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic error "-Wswitch"

namespace nimbus {

/// The phase.glsl constant of each PhaseKind; -1 for an int that is no enumerator.
constexpr int glslPhaseKind(PhaseKind k) {
    switch (k) {
    case PhaseKind::Isotropic:
        return kern::PHASE_ISOTROPIC;
    case PhaseKind::HenyeyGreenstein:
        return kern::PHASE_HG;
    case PhaseKind::DualHG:
        return kern::PHASE_DUAL_HG;
    case PhaseKind::Draine:
        return kern::PHASE_DRAINE;
    case PhaseKind::MieApprox:
        return kern::PHASE_MIE_APPROX;
    case PhaseKind::MieTable:
        return kern::PHASE_MIE_TABLE;
    }
    return -1;
}

static_assert(int(PhaseKind::Isotropic) == kern::PHASE_ISOTROPIC);
static_assert(int(PhaseKind::HenyeyGreenstein) == kern::PHASE_HG);
static_assert(int(PhaseKind::DualHG) == kern::PHASE_DUAL_HG);
static_assert(int(PhaseKind::Draine) == kern::PHASE_DRAINE);
static_assert(int(PhaseKind::MieApprox) == kern::PHASE_MIE_APPROX);
static_assert(int(PhaseKind::MieTable) == kern::PHASE_MIE_TABLE);

/// Every enumerator (the switch above has them all) equals its GLSL constant, so an
/// enumerator added with its case but without a static_assert is still checked.
constexpr bool phaseKindsMirrored() {
    for (int v = -64; v < 64; ++v) {
        const int glsl = glslPhaseKind(PhaseKind(v));
        if (glsl != -1 && glsl != v) return false;
    }
    return true;
}
static_assert(phaseKindsMirrored(), "a PhaseKind differs from its PHASE_* in phase.glsl");

/// The lighting.glsl constant of each SkyKind; -1 for an int that is no enumerator.
constexpr int glslSkyKind(SkyKind k) {
    switch (k) {
    case SkyKind::None:
        return kern::SKY_NONE;
    case SkyKind::Uniform:
        return kern::SKY_UNIFORM;
    case SkyKind::Gradient:
        return kern::SKY_GRADIENT;
    }
    return -1;
}

static_assert(int(SkyKind::None) == kern::SKY_NONE);
static_assert(int(SkyKind::Uniform) == kern::SKY_UNIFORM);
static_assert(int(SkyKind::Gradient) == kern::SKY_GRADIENT);

constexpr bool skyKindsMirrored() {
    for (int v = -64; v < 64; ++v) {
        const int glsl = glslSkyKind(SkyKind(v));
        if (glsl != -1 && glsl != v) return false;
    }
    return true;
}
static_assert(skyKindsMirrored(), "a SkyKind differs from its SKY_* in lighting.glsl");

/// The sdf_tree.glsl constant of each SdfKind (core/sdf/sdf.h); SdfTreeNode::kind holds
/// int(SdfKind) and the kernel tests `kind < SDF_KIND_UNION` for a primitive as sdfIsPrimitive.
constexpr int glslSdfKind(SdfKind k) {
    switch (k) {
    case SdfKind::Sphere:
        return kern::SDF_KIND_SPHERE;
    case SdfKind::Ellipsoid:
        return kern::SDF_KIND_ELLIPSOID;
    case SdfKind::Box:
        return kern::SDF_KIND_BOX;
    case SdfKind::RoundBox:
        return kern::SDF_KIND_ROUND_BOX;
    case SdfKind::Capsule:
        return kern::SDF_KIND_CAPSULE;
    case SdfKind::Torus:
        return kern::SDF_KIND_TORUS;
    case SdfKind::Cone:
        return kern::SDF_KIND_CONE;
    case SdfKind::Plane:
        return kern::SDF_KIND_PLANE;
    case SdfKind::Union:
        return kern::SDF_KIND_UNION;
    case SdfKind::Intersection:
        return kern::SDF_KIND_INTERSECTION;
    case SdfKind::Subtraction:
        return kern::SDF_KIND_SUBTRACTION;
    }
    return -1;
}

constexpr bool sdfKindsMirrored() {
    for (int v = int(SdfKind::Sphere); v <= int(SdfKind::Subtraction); ++v)
        if (glslSdfKind(SdfKind(v)) != v) return false;
    return true;
}
static_assert(sdfKindsMirrored(), "an SdfKind differs from its SDF_KIND_* in sdf_tree.glsl");
static_assert(int(SdfKind::Union) == kern::SDF_KIND_UNION); // the first operator
static_assert(int(SdfNoise::Worley) == kern::SDF_NOISE_WORLEY);

} // namespace nimbus

#pragma GCC diagnostic pop
