/// @file medium.h
/// @brief A participating medium: coefficients per unit density with the density scale folded
/// in once, and the phase function (Mitsuba's split: the Field gives the density, the Medium the
/// optical properties per unit of it).
#pragma once

#include <algorithm>

#include "core/media/phase.h"
#include "core/scene.h"

namespace nimbus {

struct Medium {
    vec3 sigma_s{0.0f};       ///< scattering per unit density, density scale folded in
    vec3 sigma_a{0.0f};       ///< absorption per unit density, density scale folded in
    vec3 sigma_t{0.0f};       ///< sigma_s + sigma_a
    float sigma_t_max = 0.0f; ///< max channel of sigma_t: turns density bounds into majorants
    /// Transport (similarity-reduced) extinction sigma_a + sigma_s (1 - g) per unit density: how
    /// multiply scattered light, which sees the medium as isotropic, is attenuated.
    vec3 sigma_tr{0.0f};
    vec3 sigma_sr{0.0f}; ///< transport scattering sigma_s (1 - g) per unit density
    PhaseFunction phase;
    float g = 0.0f; ///< mean cosine of the phase function

    static Medium fromDesc(const MediumDesc& m) {
        Medium r;
        r.sigma_s = m.sigma_s * m.densityScale;
        r.sigma_a = m.sigma_a * m.densityScale;
        r.sigma_t = r.sigma_s + r.sigma_a;
        r.sigma_t_max = std::max(r.sigma_t.x, std::max(r.sigma_t.y, r.sigma_t.z));
        r.phase = PhaseFunction::fromMedium(m);
        r.g = r.phase.meanCosine();
        r.sigma_sr = m.sigma_s * (1.0f - r.g) * m.densityScale;
        r.sigma_tr = r.sigma_sr + m.sigma_a * m.densityScale;
        return r;
    }
};

} // namespace nimbus
