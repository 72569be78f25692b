/// @file field.h
/// @brief Scalar density fields: `density(p)`, `bounds()`, `majorant(box)`.
///
/// A closed set of kinds with one switch each (no virtual dispatch): a homogeneous box and the
/// procedural cumulus layer of Olajos 2016, ch. 2. A Field is the state of one frame: the wind
/// offsets for that frame's time are folded in when it is made. The cumulus noise is either
/// evaluated directly from the kernels or read from tileable noise volumes baked once per
/// sequence (NoiseVolume); the frame plan decides which.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/kernels/kernels.h"
#include "core/scene.h"

namespace nimbus {

/// A periodic noise tile sampled on res^3 nodes; trilinear lookups wrap around.
struct NoiseVolume {
    int res = 0;
    std::vector<float> values;

    /// Trilinear lookup; u is in voxel units (u and u + res give the same value).
    float sample(vec3 u) const;
    /// Max of sample() over the box [lo, hi] (voxel units): the max over the nodes it touches,
    /// exact for trilinear interpolation.
    float maxOver(vec3 lo, vec3 hi) const;
};

/// Base-shape noise of a cumulus layer at noise-domain point q (world / basePeriod), in [0,1].
float cumulusBaseNoise(const CumulusDesc& c, vec3 q);
/// Detail (erosion) noise at q (world / detailPeriod), in [0,1].
float cumulusDetailNoise(const CumulusDesc& c, vec3 q);
/// Bakes one tile of the base / detail noise (TBB-parallel).
std::shared_ptr<const NoiseVolume> bakeCumulusBase(const CumulusDesc& c);
std::shared_ptr<const NoiseVolume> bakeCumulusDetail(const CumulusDesc& c);

kern::CloudLayer cloudLayerFrom(const CumulusDesc& c);

struct Field {
    FieldKind kind = FieldKind::Homogeneous;
    Box box; ///< bounds(): no density outside
    HomogeneousDesc homogeneous;
    CumulusDesc cumulus;
    kern::CloudLayer layer{};
    vec3 baseOffset{0.0f};                         ///< wind * time: the whole field drifts
    vec3 detailOffset{0.0f};                       ///< (wind + detailWind) * time
    std::shared_ptr<const NoiseVolume> baseBake;   ///< null: evaluate directly
    std::shared_ptr<const NoiseVolume> detailBake; ///< null: evaluate directly
    VdbFieldDesc vdb;
    std::uint64_t serial = 0; ///< unique per makeField() of a grid: keys per-thread accessors

    const Box& bounds() const { return box; }
    float density(vec3 p) const;
    /// Upper bound of density over the box (conservative, rigorous).
    float majorant(const Box& b) const;
    /// Grid fields: calls visit(worldBox, maxDensity) for every tree node that holds density
    /// (leaves, and internal nodes with active tiles), boxes grown by the trilinear support.
    /// Returns false for fields that are not grids.
    template <class F> bool forEachDensityNode(F&& visit) const;
    bool forEachDensityNodeImpl(void (*fn)(void*, const Box&, float), void* ctx) const;
};

template <class F> bool Field::forEachDensityNode(F&& visit) const {
    return forEachDensityNodeImpl(
        [](void* ctx, const Box& b, float m) { (*static_cast<F*>(ctx))(b, m); }, &visit);
}

/// The field of one frame at time `time` (seconds). Pass bakes to read baked noise.
Field makeField(const FieldDesc& desc, float time,
                std::shared_ptr<const NoiseVolume> baseBake = nullptr,
                std::shared_ptr<const NoiseVolume> detailBake = nullptr);

} // namespace nimbus
