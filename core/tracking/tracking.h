/// @file tracking.h
/// @brief Delta and ratio tracking written once: tentative collisions sampled over majorant
/// segments, each stretch at its own majorant (pbrt-v4's SampleT_maj; Woodcock et al. 1965,
/// Novák et al. 2014). Every integrator passes a callback that decides what a collision means
/// (pathtrace: real or null event with spectral MIS; ratio tracking: a transmittance factor;
/// photons: a deposit and an event).
#pragma once

#include <cmath>
#include <cstdint>

#include "core/cancel.h"
#include "core/kernels/kernels.h"
#include "core/tracking/majorant.h"

namespace nimbus {

/// Walks `segments` (anything with `bool next(MajorantSegment&)`) and samples exponential free
/// flights at rate sigma_maj = seg.sigma_maj * sigmaScale on each (the tracking step,
/// kern::freeFlight, one random number per flight). Calls visit(t, seg, sigmaMaj) at every
/// tentative collision; visit returns false to stop. Returns false when visit stopped, true
/// when the segments ran out (the ray left the medium). A cancelled walker (core/cancel.h,
/// asked every CancelPoll::kEvery flights) ends the walk as if the ray had left.
template <class Segments, class Rng, class F>
bool sampleTmaj(Segments& segments, float sigmaScale, Rng& rng, F&& visit) {
    MajorantSegment seg;
    std::uint32_t polls = 0, stalled = 0;
    while (segments.next(seg)) {
        const float sigmaMaj = seg.sigma_maj * sigmaScale;
        float t = seg.t0;
        for (;;) {
            if ((++polls & (CancelPoll::kEvery - 1)) == 0 && walkCancelled(segments)) return true;
            // A flight shorter than half an ulp of t leaves t where it stands: at a density
            // scale of 1e12 every flight does, and where the density is 0 inside the majorant's
            // cell the walk would never end. After 8 such flights in a row (never at ordinary
            // densities: each has a chance of about sigma_maj ulp(t)) the walk moves on by one
            // ulp, as far as the float position can resolve: at most ~2^26 flights per binade
            // of t.
            float tn = kern::freeFlight(t, sigmaMaj, rng.next());
            if (tn > t) {
                stalled = 0;
            } else if (++stalled == 8) {
                tn = std::nextafter(t, INFINITY);
                stalled = 0;
            }
            t = tn;
            if (t >= seg.t1) break;
            if (!visit(t, seg, sigmaMaj)) return false;
        }
    }
    return true;
}

} // namespace nimbus
