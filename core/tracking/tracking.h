/// @file tracking.h
/// @brief Delta and ratio tracking written once: tentative collisions sampled over majorant
/// segments, each stretch at its own majorant (pbrt-v4's SampleT_maj; Woodcock et al. 1965,
/// Novák et al. 2014). Every integrator passes a callback that decides what a collision means
/// (pathtrace: real or null event with spectral MIS; ratio tracking: a transmittance factor;
/// photons: a deposit and an event).
#pragma once

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
    std::uint32_t polls = 0;
    while (segments.next(seg)) {
        const float sigmaMaj = seg.sigma_maj * sigmaScale;
        float t = seg.t0;
        for (;;) {
            if ((++polls & (CancelPoll::kEvery - 1)) == 0 && walkCancelled(segments)) return true;
            t = kern::freeFlight(t, sigmaMaj, rng.next());
            if (t >= seg.t1) break;
            if (!visit(t, seg, sigmaMaj)) return false;
        }
    }
    return true;
}

} // namespace nimbus
