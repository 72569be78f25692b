/// @file cumulus.h
/// @brief The procedural cumulus layer of Olajos 2016, ch. 2: the shaping and the noise are the
/// kernels of core/kernels/cloud.glsl (cumulusDensity and its bounds); this wraps them with the
/// optional baked noise tiles the frame plan may choose.
///
/// The noise is either evaluated directly from the kernels or read from tileable noise volumes
/// baked once per sequence (NoiseVolume). A CumulusField is the state of one frame: the wind
/// offsets for that frame's time are folded into its kernel parameters when it is made.
#pragma once

#include <atomic>

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

/// The kernel parameters of a cumulus layer at time `time` (seconds).
kern::CumulusParams cumulusParams(const CumulusDesc& c, float time);
/// Bakes one tile of the base / detail noise (TBB-parallel).
/// (Both stop early, the tile incomplete, once `cancel` is set: core/cancel.h.)
std::shared_ptr<const NoiseVolume> bakeCumulusBase(const CumulusDesc& c,
                                                   const std::atomic<bool>* cancel = nullptr);
std::shared_ptr<const NoiseVolume> bakeCumulusDetail(const CumulusDesc& c,
                                                     const std::atomic<bool>* cancel = nullptr);

struct CumulusField {
    kern::CumulusParams params{};
    std::shared_ptr<const NoiseVolume> baseBake;   ///< null: evaluate directly
    std::shared_ptr<const NoiseVolume> detailBake; ///< null: evaluate directly

    /// Density at p (p inside the layer's box).
    float density(vec3 p) const;
    /// Upper bound of the density over the box b (inside the layer's box).
    float majorant(const Box& b) const;
};

} // namespace nimbus
