// lighting.glsl: transmittance and in-scattering terms for single-scattering ray marching.

// Beer-Lambert transmittance over an optical depth tau = sigma_t * distance.
NB_FN vec3 beerLambert(vec3 tau) { return exp(-tau); }

// Olajos 2016 in-scatter probability S(d) = 1 - e^{-c d}.
NB_FN float inScatterOlajos(float d, float c) { return 1.0f - exp(-c * d); }

// Schneider 2015 Beer-powder: E = 2 e^{-d} (1 - e^{-2 d}).
NB_FN float beerPowder(float d) { return 2.0f * exp(-d) * (1.0f - exp(-2.0f * d)); }

// Integral over a step of length dt of S * e^{-sigma_t s} ds: (S - S e^{-sigma_t dt}) / sigma_t.
NB_FN float stepIntegral(float S, float sigma_t, float dt) {
    if (sigma_t < 1e-6f) return S * dt;
    return (S - S * exp(-sigma_t * dt)) / sigma_t;
}

// Hillaire 2016 energy-conserving step: L += T * S_int; T *= e^{-sigma_t dt}.
NB_FN void integrateStep(vec3 S, vec3 sigma_t, float dt, INOUT(vec3) L, INOUT(vec3) T) {
    vec3 Sint = vec3(stepIntegral(S.x, sigma_t.x, dt), stepIntegral(S.y, sigma_t.y, dt),
                     stepIntegral(S.z, sigma_t.z, dt));
    L += T * Sint;
    T *= exp(-sigma_t * dt);
}

// Share of the upper hemisphere in the sky a sample sees, from the transport optical depths of
// the vertical column above (tu) and below (td) it: 1 / (1 + e^{k (tu - td)}), the weights
// e^{-k tu} and e^{-k td} normalised (so a uniform sky is returned unchanged).
NB_FN float skyUpperShare(float tu, float td, float k) {
    return 1.0f / (1.0f + exp(min(k * (tu - td), 80.0f)));
}
