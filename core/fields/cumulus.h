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
#include <cstdint>

#include <memory>
#include <vector>

#include "core/kernels/kernels.h"
#include "core/scene.h"

namespace nimbus {

/// A periodic noise tile sampled on res^3 nodes; trilinear lookups wrap around. Either one float
/// per node (`values`: the noise with its octaves summed) or four bytes per node (`rgba`:
/// Olajos' channel layout, kern::cumulusBaseChannels / cumulusDetailChannels, each channel
/// quantised to k / 255 as an RGBA8 texture holds it); nodes x fastest, then y, then z.
struct NoiseVolume {
    int res = 0;
    std::vector<float> values;
    std::vector<std::uint8_t> rgba;

    bool channels() const { return !rgba.empty(); }
    /// Trilinear lookup; u is in voxel units (u and u + res give the same value).
    float sample(vec3 u) const;
    /// The same for the four channels (each k / 255, interpolated apart), of an rgba tile.
    vec4 sample4(vec3 u) const;
    /// Max of sample() over the box [lo, hi] (voxel units): the max over the nodes it touches,
    /// exact for trilinear interpolation.
    float maxOver(vec3 lo, vec3 hi) const;
    /// Per channel of an rgba tile, the min and max of sample4() over the box [lo, hi] (voxel
    /// units): over the nodes it touches.
    void rangeOver(vec3 lo, vec3 hi, vec4& lowest, vec4& highest) const;
};

/// The kernel parameters of a cumulus layer at time `time` (seconds).
kern::CumulusParams cumulusParams(const CumulusDesc& c, float time);
/// Bakes one tile of the base / detail noise (TBB-parallel): floats, or RGBA8 channels when
/// c.eval is NoiseEval::Rgba.
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
