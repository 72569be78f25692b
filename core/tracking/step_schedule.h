/// @file step_schedule.h
/// @brief Where march samples along a ray: a step schedule (fixed, or growing with distance)
/// and the walk of those samples over the non-empty majorant segments, written once for camera
/// and shadow rays.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/cancel.h"
#include "core/tracking/majorant.h"

namespace nimbus {

/// Sample positions along a ray as a function of a continuous step coordinate u: samples sit
/// at u = n + jitter. Fixed steps of dt0 up to distance tg = ceil(1 / growth) dt0, then steps that
/// grow geometrically (dt ~ growth * t). Closed form in both directions, so skipping a stretch of
/// empty space lands on exactly the samples a full march would have taken.
struct StepSchedule {
    double dt0 = 1.0, growth = 0.0, tg = 0.0, logG = 0.0;

    StepSchedule(double step, double grow) : dt0(step), growth(grow) {
        if (growth > 0.0) {
            // start growing at a whole step index, where growth * t >= dt0 already holds
            tg = std::ceil(1.0 / growth) * dt0;
            logG = std::log1p(growth);
        }
    }
    double u(double t) const {
        if (growth <= 0.0 || t <= tg) return t / dt0;
        return tg / dt0 + std::log(t / tg) / logG;
    }
    double t(double u) const {
        const double ug = growth > 0.0 ? tg / dt0 : 0.0;
        if (growth <= 0.0 || u <= ug) return u * dt0;
        return tg * std::exp((u - ug) * logG);
    }
};

/// Marches the non-empty majorant segments of a ray (written once, used by camera and shadow
/// rays). Step n covers [t(n), t(n+1)] clipped to [tIn, tOut], the ray's span inside the field;
/// its sample sits at the fraction `jitter` of the clipped step and is visited only if it lies
/// in a non-empty segment, so skipping changes no sample that can see density. The callback
/// gets (t, dt, n) and returns false to stop. The walk also stops when the walker is cancelled
/// (core/cancel.h: asked every CancelPoll::kEvery steps, so a 1e-9 step cannot outlast a
/// SIGTERM).
template <class Segments, class F>
void marchSegments(Segments& it, const StepSchedule& sched, double tIn, double tOut, float jitter,
                   F&& visit) {
    MajorantSegment seg;
    std::int64_t nNext = 0;
    std::uint32_t polls = 0;
    while (it.next(seg)) {
        for (std::int64_t n = std::max(nNext, std::int64_t(std::floor(sched.u(seg.t0))));; ++n) {
            if ((++polls & (CancelPoll::kEvery - 1)) == 0 && walkCancelled(it)) return;
            const double tA = std::max(sched.t(double(n)), tIn);
            const double tB = std::min(sched.t(double(n + 1)), tOut);
            if (tB <= tA) {
                if (tA >= tOut) return;
                continue;
            }
            const float ts = float(tA + double(jitter) * (tB - tA));
            if (ts < seg.t0) {
                nNext = n + 1;
                continue;
            }
            if (ts >= seg.t1) break;
            nNext = n + 1;
            if (!visit(ts, float(tB - tA), n)) return;
        }
    }
}

/// The index (the key of its random numbers) of sub-step j of march step n when a thick step is
/// split (render.step_tau): a hash of (n, j), so that its low 32 bits, which the random keys
/// keep, differ from step to step and from sub-step to sub-step.
inline std::int64_t substepIndex(std::int64_t n, int j) {
    return std::int64_t(std::uint64_t(n) * 0x9e3779b97f4a7c15ull +
                        std::uint64_t(j + 1) * 0xbf58476d1ce4e5b9ull);
}

} // namespace nimbus
