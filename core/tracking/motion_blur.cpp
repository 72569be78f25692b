#include "core/tracking/motion_blur.h"

#include <algorithm>
#include <cstdio>
#include <limits>

#include "core/tracking/volumes.h" // isPlaced

namespace nimbus {

namespace {

constexpr float kInf = std::numeric_limits<float>::max();

void include(Box& b, vec3 v) {
    b.lo = glm::min(b.lo, v);
    b.hi = glm::max(b.hi, v);
}

/// The sum of two boxes (every a + d).
Box minkowski(const Box& a, const Box& d) {
    return Box{a.lo + d.lo, a.hi + d.hi};
}

/// A little more than the float rounding of a shifted coordinate: the swept boxes are grown by
/// it so that q - v dt computed in float never lands outside them.
Box roundingSlack(const Box& b) {
    const vec3 m = glm::max(glm::abs(b.lo), glm::abs(b.hi));
    const vec3 e = m * 4.0f * std::numeric_limits<float>::epsilon() + vec3(1e-30f);
    return Box{b.lo - e, b.hi + e};
}

bool anyWind(const std::vector<AutomatonWindRow>& rows) {
    return std::any_of(rows.begin(), rows.end(),
                       [](const AutomatonWindRow& r) { return r.wind != vec3(0.0f); });
}

std::string vecText(vec3 v) {
    char b[96];
    std::snprintf(b, sizeof b, "(%g, %g, %g)", double(v.x), double(v.y), double(v.z));
    return b;
}

/// What moves a field, "" when still.
std::string fieldMotion(const FieldDesc& d) {
    if (d.advect.enabled) {
        const AdvectDesc& a = d.advect;
        switch (a.wind) {
        case AdvectWind::Uniform:
            if (a.uniform != vec3(0.0f)) return "advected by the wind " + vecText(a.uniform);
            break;
        case AdvectWind::Layered:
            if (anyWind(a.layers)) return "advected by a layered wind";
            break;
        case AdvectWind::Grid:
            if (!a.velocityPath.empty())
                return "advected by the velocity grid of " + a.velocityPath;
            break;
        }
    }
    if (d.kind == FieldKind::Cumulus && d.cumulus.wind != vec3(0.0f))
        return "cumulus wind " + vecText(d.cumulus.wind);
    if (d.kind == FieldKind::Automaton && anyWind(d.automaton.wind))
        return "automaton layered wind";
    return "";
}

} // namespace

std::string movingVolumes(const SceneDesc& s) {
    std::string out;
    auto add = [&](const std::string& name, const std::string& what) {
        if (what.empty()) return;
        out += (out.empty() ? "" : "; ") + name + " (" + what + ")";
    };
    if (isPlaced(s, 0)) add("field", fieldMotion(s.field));
    for (size_t i = 0; i < s.volumes.size(); ++i)
        if (isPlaced(s, int(i) + 1))
            add("volume " + s.volumes[i].name, fieldMotion(s.volumes[i].field));
    return out;
}

Box velocityRange(const FieldMotion& motion, const Box& region) {
    const sim::VelocityField& v = motion.velocity;
    Box r{vec3(kInf), vec3(-kInf)};
    switch (v.kind) {
    case sim::VelocityKind::Uniform:
        return Box{v.uniform, v.uniform};
    case sim::VelocityKind::Layered: {
        // piecewise linear in altitude, clamped outside the table: its range over [y0, y1] is
        // reached at the ends or at the rows in between
        const float y0 = region.lo.y, y1 = region.hi.y;
        include(r, sim::velocityAt(v, vec3(0.0f, y0, 0.0f)));
        include(r, sim::velocityAt(v, vec3(0.0f, y1, 0.0f)));
        for (const sim::WindLayer& l : v.layers)
            if (l.altitude > y0 && l.altitude < y1) include(r, l.wind);
        return r;
    }
    case sim::VelocityKind::Centred:
    case sim::VelocityKind::Staggered:
        // outside its samples the velocity is the nearest sample's: every value is a sample's
        if (!v.grid || v.grid->v.empty()) return Box{vec3(0.0f), vec3(0.0f)};
        for (const vec3& s : v.grid->v) include(r, s);
        return r;
    }
    return Box{vec3(0.0f), vec3(0.0f)};
}

Box displacementRange(const Box& velocities, const Shutter& shutter, float sign) {
    // interval product: {s v dt} over v in [lo, hi], dt in [t0, t1] per axis
    Box r{vec3(kInf), vec3(-kInf)};
    for (const float dt : {shutter.t0, shutter.t1}) {
        include(r, sign * velocities.lo * dt);
        include(r, sign * velocities.hi * dt);
    }
    return r;
}

MotionSweep::MotionSweep(const Field& f, const Shutter& shutter)
    : f_(f), shutter_(shutter), active_(shutter.open() && f.motion.moving) {
    if (!active_) return;
    byRegion_ = f.motion.velocity.kind == sim::VelocityKind::Layered;
    all_ = velocityRange(f.motion, Box{vec3(-kInf), vec3(kInf)});
}

float MotionSweep::majorant(const Box& b) const {
    if (!active_) return f_.majorant(b);
    // densityAt(q, dt) = density(q - v(q) dt) with q in b: the source lies in b + D, D the
    // displacements -v dt with v over b's velocity range
    const Box v = byRegion_ ? velocityRange(f_.motion, b) : all_;
    return f_.majorant(roundingSlack(minkowski(b, displacementRange(v, shutter_, -1.0f))));
}

Box MotionSweep::node(const Box& n) const {
    if (!active_ || n.empty()) return n;
    // q can see the density of n at dt when q - v(q) dt lies in n: q in n + v dt, v over every
    // value (v is taken at q, which can lie anywhere)
    return roundingSlack(minkowski(n, displacementRange(all_, shutter_, 1.0f)));
}

Box sweptBounds(const Field& f, const Shutter& shutter) {
    return MotionSweep(f, shutter).bounds();
}

float sweptMajorant(const Field& f, const Box& b, const Shutter& shutter) {
    return MotionSweep(f, shutter).majorant(b);
}

Box sweptNode(const Field& f, const Box& node, const Shutter& shutter) {
    return MotionSweep(f, shutter).node(node);
}

} // namespace nimbus
