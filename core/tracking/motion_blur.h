/// @file motion_blur.h
/// @brief Motion blur of moving volumes (issue 13, item 3): the density at a time offset dt
/// from the frame's time, and the bounds and majorants that cover it over the shutter.
///
/// A field moves with its FieldMotion velocity v (world units per second in its own space).
/// Its density at time t_frame + dt near q is taken as the frame's density at q - v(q) dt:
/// exact for a uniform wind and for a height-layered wind without vertical components (each
/// layer moves rigidly), first order in dt for a layered wind with vertical components and
/// for a velocity grid (the characteristic is traced as a straight line with the velocity at
/// q). The field's own bounds check applies to the shifted point, so nothing appears outside
/// where the frame's density would be.
///
/// Tracking stays unbiased when every majorant bounds the density over the whole shutter: a
/// cell C's bound is field.majorant(C + D(C)), D(C) the box of every displacement -v(q) dt
/// for q in C and dt in the shutter (interval arithmetic on the velocity's range over C:
/// exact for a uniform wind; for a layered wind its range over C's altitudes, the table rows
/// in between included; for a grid its range over every sample). The region where density
/// can appear at some time of the shutter (sweptBounds) is the field's box moved by
/// +v dt with v over the field's whole velocity range.
///
/// @code
///   Shutter sh{-0.01f, 0.01f};                        // seconds around the frame's time
///   Box b = sweptBounds(field, sh);                   // instance and grid bounds
///   float m = sweptMajorant(field, cellBox, sh);      // >= densityAt(field, q, dt), q in cell
///   float rho = densityAt(field, q, 0.004f);          // the density 4 ms after the frame
/// @endcode
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>

#include "core/fields/field.h"

namespace nimbus {

/// The shutter in seconds from the frame's time; closed when t1 <= t0 (the default).
struct Shutter {
    float t0 = 0.0f;
    float t1 = 0.0f;
    bool open() const { return t1 > t0; }
};

/// The time of camera sample k (motion blur): the shutter at u = frac(vdc(k) + offset), vdc the
/// base-2 radical inverse (van der Corput), `offset` a random shift per pixel (Cranley-Patterson
/// rotation): the first 2^m samples of a pixel fall one in each 2^-m of the shutter, unrelated
/// to their place in the pixel.
inline float sampleTime(const Shutter& s, std::uint32_t k, float offset) {
    k = (k << 16) | (k >> 16);
    k = ((k & 0x00ff00ffu) << 8) | ((k & 0xff00ff00u) >> 8);
    k = ((k & 0x0f0f0f0fu) << 4) | ((k & 0xf0f0f0f0u) >> 4);
    k = ((k & 0x33333333u) << 2) | ((k & 0xccccccccu) >> 2);
    k = ((k & 0x55555555u) << 1) | ((k & 0xaaaaaaaau) >> 1);
    float u = float(k >> 8) * 0x1p-24f + offset;
    if (u >= 1.0f) u -= 1.0f;
    return s.t0 + std::min(u, 0x1.fffffep-1f) * (s.t1 - s.t0);
}

/// The box of velocities of `motion` over the points of `region` (componentwise range):
/// uniform: the wind; layered: the rows' winds over region's altitudes (clamped outside the
/// table); grids: every sample.
Box velocityRange(const FieldMotion& motion, const Box& region);

/// The box of displacements s v dt for v in `velocities` and dt in the shutter (s = +1 or -1).
Box displacementRange(const Box& velocities, const Shutter& shutter, float sign);

/// The field's density at local point q, dt seconds from the frame's time.
inline float densityAt(const Field& f, vec3 q, float dt) {
    if (dt == 0.0f || !f.motion.moving) return f.density(q);
    return f.density(q - sim::velocityAt(f.motion.velocity, q) * dt);
}

/// The sweep of one field over one shutter, with what does not depend on the box computed once
/// (a velocity grid's range over all its samples): builders of majorant grids make one and ask
/// it per cell. The free functions below make one per call.
class MotionSweep {
  public:
    MotionSweep(const Field& f, const Shutter& shutter);
    /// sweptMajorant(f, b, shutter)
    float majorant(const Box& b) const;
    /// sweptNode(f, node, shutter)
    Box node(const Box& n) const;
    /// sweptBounds(f, shutter)
    Box bounds() const { return node(f_.bounds()); }
    bool active() const { return active_; }

  private:
    const Field& f_;
    Shutter shutter_;
    bool active_ = false;   ///< shutter open and the field moving
    bool byRegion_ = false; ///< layered: the velocity range depends on the box's altitudes
    Box all_;               ///< the velocity range over every point
};

/// Where the field can hold density at some time of the shutter (its own space): its box
/// grown by the displacements +v dt (the field's box when still or the shutter is closed).
Box sweptBounds(const Field& f, const Shutter& shutter);

/// An upper bound of densityAt(f, q, dt) over q in b and dt in the shutter.
float sweptMajorant(const Field& f, const Box& b, const Shutter& shutter);

/// A box of grid-node density `node` moved over the shutter: where that density can be seen
/// (node + v dt over the field's whole velocity range).
Box sweptNode(const Field& f, const Box& node, const Shutter& shutter);

/// What moves among the volumes the scene places (for the plan and --explain): "" when nothing
/// does. A cumulus with a non-zero wind, an automaton with a non-zero wind row, a field with
/// [field.advect] and a non-zero wind or a velocity grid.
std::string movingVolumes(const SceneDesc& s);

} // namespace nimbus
