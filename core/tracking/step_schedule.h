/// @file step_schedule.h
/// @brief Where march samples along a ray: a step schedule (fixed, or growing with distance)
/// and the walk of those samples over the non-empty majorant segments, written once for camera
/// and shadow rays.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

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

/// Which steps whose sample lies in an empty stretch marchSegments visits all the same (as a
/// sample of density 0), for render.step_tau's test of the densities around a step
/// (kern::splitDensity: a march that took every step would split them where a neighbour sees
/// density): none, or the step right after one sampled in a non-empty stretch and the step right
/// before one. With kFromStart the first step counts as following one (a shadow ray from a point
/// that sees density).
enum class EdgeSteps { kNone, kEdges, kFromStart };

/// Marches the non-empty majorant segments of a ray (written once, used by camera and shadow
/// rays). Step n covers [t(n), t(n+1)] clipped to [tIn, tOut], the ray's span inside the field;
/// its sample sits at the fraction `jitter` of the clipped step and is visited only if it lies
/// in a non-empty segment (or, with `edges`, if it is an edge step: EdgeSteps), so skipping
/// changes no sample that can see density. The callback gets (t, dt, n, tNext, empty), tNext
/// being the sample of step n + 1 (-infinity where that step is empty: past tOut) for a march
/// that reads ahead, `empty` true for an edge step (its density is 0); it returns false to stop.
/// The walk also stops when the walker is cancelled (core/cancel.h: asked every
/// CancelPoll::kEvery steps, so a 1e-9 step cannot outlast a SIGTERM).
template <class Segments, class F>
void marchSegments(Segments& it, const StepSchedule& sched, double tIn, double tOut, float jitter,
                   EdgeSteps edges, F&& visit) {
    constexpr std::int64_t kNone = std::numeric_limits<std::int64_t>::min();
    // the schedule's t(n), each computed once while the walk goes on (step n ends where n + 1
    // starts; steps n + 1 and n + 2 give the next sample)
    std::int64_t memoN[4] = {kNone, kNone, kNone, kNone};
    double memoT[4] = {};
    const auto tAt = [&](std::int64_t n) {
        const std::size_t slot = std::size_t(n & 3);
        if (memoN[slot] != n) {
            memoN[slot] = n;
            memoT[slot] = sched.t(double(n));
        }
        return memoT[slot];
    };
    // step n clipped to [tIn, tOut] and its sample
    const auto sampleOf = [&](std::int64_t n, double& tA, double& tB) {
        tA = std::max(tAt(n), tIn);
        tB = std::min(tAt(n + 1), tOut);
        return float(tA + double(jitter) * (tB - tA));
    };
    const bool withEdges = edges != EdgeSteps::kNone;
    // whether step n follows a visited step with its sample in a segment (or the start)
    bool anyFollows = edges == EdgeSteps::kFromStart;
    std::int64_t lastFull = kNone;
    const auto follows = [&](std::int64_t n) { return anyFollows || lastFull == n - 1; };
    const auto visitStep = [&](std::int64_t n, float ts, double tA, double tB, bool empty) {
        double tA1, tB1;
        const float tsNext = sampleOf(n + 1, tA1, tB1);
        lastFull = empty ? kNone : n;
        anyFollows = false;
        return visit(ts, float(tB - tA), n,
                     tB1 > tA1 ? tsNext : -std::numeric_limits<float>::infinity(), empty);
    };
    MajorantSegment seg;
    std::int64_t nNext = 0;
    std::int64_t pending = kNone; // an edge step past a segment's end, if the next starts later
    std::uint32_t polls = 0;
    while (it.next(seg)) {
        if (pending != kNone) {
            double tA, tB;
            const float ts = sampleOf(pending, tA, tB);
            if (ts < seg.t0) {
                if (!visitStep(pending, ts, tA, tB, true)) return;
                nNext = pending + 1;
            }
            pending = kNone;
        }
        for (std::int64_t n = std::max(nNext, std::int64_t(std::floor(sched.u(seg.t0))));; ++n) {
            if ((++polls & (CancelPoll::kEvery - 1)) == 0 && walkCancelled(it)) return;
            double tA, tB;
            const float ts = sampleOf(n, tA, tB);
            if (tB <= tA) {
                if (tA >= tOut) return;
                continue;
            }
            if (ts < seg.t0) {
                // in the stretch before the segment: an edge step where it follows a visited
                // one or the next sample lies in the segment
                nNext = n + 1;
                if (withEdges) {
                    double tA1, tB1;
                    const float tsNext = sampleOf(n + 1, tA1, tB1);
                    if ((follows(n) || (tB1 > tA1 && tsNext >= seg.t0)) &&
                        !visitStep(n, ts, tA, tB, true))
                        return;
                }
                continue;
            }
            if (ts >= seg.t1) {
                // past the segment: an edge step if it follows a visited one and the next
                // segment starts after its sample (decided there)
                if (withEdges && follows(n)) pending = n;
                break;
            }
            nNext = n + 1;
            if (!visitStep(n, ts, tA, tB, false)) return;
        }
    }
    if (pending != kNone) {
        double tA, tB;
        const float ts = sampleOf(pending, tA, tB);
        visitStep(pending, ts, tA, tB, true);
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
