// lighting.glsl: transmittance and in-scattering terms for single-scattering ray marching.

// Beer-Lambert transmittance over an optical depth tau = sigma_t * distance.
NB_FN vec3 beerLambert(vec3 tau) { return exp(-tau); }

// Olajos 2016 in-scatter probability S(d) = 1 - e^{-c d}.
NB_FN float inScatterOlajos(float d, float c) { return 1.0f - exp(-c * d); }

// Schneider 2015 powder factor on its own: beerPowder(d) = e^{-d} powderFactor(d) exactly (the
// factor 2 is a power of two, so both orders of the product round alike).
NB_FN float powderFactor(float d) { return 2.0f * (1.0f - exp(-2.0f * d)); }

// Schneider 2015 Beer-powder: E = 2 e^{-d} (1 - e^{-2 d}).
NB_FN float beerPowder(float d) { return exp(-d) * powderFactor(d); }

// Integral over a step of length dt of S * e^{-sigma_t s} ds: (S - S e^{-sigma_t dt}) / sigma_t.
// For x = sigma_t dt < 0.01 the difference S - S e^{-x} cancels (at x = 1e-9 it rounds to 0 or
// to several times S dt); there the series S dt (1 - x/2 + x^2/6 - x^3/24) is used, whose
// truncation error x^4/120 is below 1e-10 relative (no expm1 in GLSL).
NB_FN float stepIntegral(float S, float sigma_t, float dt) {
    float x = sigma_t * dt;
    if (x < 0.01f) return S * dt * (1.0f - x * (0.5f - x * (1.0f / 6.0f - x * (1.0f / 24.0f))));
    return (S - S * exp(-x)) / sigma_t;
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


// Free-flight step of delta tracking (the tracking step): from t, the next tentative collision
// at rate sigmaMaj for a uniform u in [0, 1): t - ln(1 - u) / sigmaMaj.
NB_FN float freeFlight(float t, float sigmaMaj, float u) { return t - log(1.0f - u) / sigmaMaj; }

// --- the march step (core/integrators/march.cpp) ----------------------------------------------

// In-scatter models on the sun term (values = the InScatter enum of core/scene.h).
const int INSCATTER_NONE = 0;
const int INSCATTER_OLAJOS = 1; // Olajos 2016: S(d) = 1 - e^{-c d} of the local density
const int INSCATTER_POWDER = 2; // Schneider 2015: the powder factor of the mean optical depth

// Multiplier of the sun term at a sample of density rho whose density integral toward the sun is
// tau: 1 blended toward the model's value by `strength`.
NB_FN float inScatterFactor(int mode, float rho, float tau, vec3 sigmaT, float c,
                            float strength) {
    if (mode == INSCATTER_OLAJOS) return mix(1.0f, inScatterOlajos(rho, c), strength);
    if (mode == INSCATTER_POWDER) {
        float d = tau * (sigmaT.x + sigmaT.y + sigmaT.z) / 3.0f;
        return mix(1.0f, powderFactor(d), strength);
    }
    return 1.0f;
}

// One multiple-scattering octave of the sun term (Wrenninge 2015; Hillaire 2016): its weight
// b^i times its phase function's value times the sun's transmittance through the optical depth
// scaled by a^i (extinction = a^i).
NB_FN vec3 octaveSun(vec3 phaseValue, vec3 sigmaT, float tau, float weight, float extinction) {
    return weight * phaseValue * beerLambert(sigmaT * (tau * extinction));
}

// The octave gate (render.octave_gate): octaves above the first weighted by the chance that
// light scatters again along the sun's line through the sample, 1 - exp(-gate sigma_s tauLine),
// tauLine the density integral toward the sun plus the one away from it.
NB_FN vec3 octaveGateFactor(vec3 sigmaS, float gate, float tauLine) {
    return vec3(1.0f) - beerLambert(sigmaS * (gate * tauLine));
}

// Whether the density integral away from the sun is needed (1) or not (0): not once the one
// toward the sun alone takes the gate's factor within 0.1% of 1 (gate sigma_s tau >= 7 in every
// channel), which spares the second shadow march deep in a thick cloud.
NB_FN float octaveGateNeedsAway(vec3 sigmaS, float gate, float tauSun) {
    return gate * min(sigmaS.x, min(sigmaS.y, sigmaS.z)) * tauSun < 7.0f ? 1.0f : 0.0f;
}

// The point where the line from p, inside the box lo..hi, along the direction w leaves the box.
// A light volume over the box (its density integral toward the sun at each point) read there,
// with w pointing away from the sun, holds the integral along the sun's whole line through p:
// the octave gate's tauLine in one lookup instead of a second shadow march.
NB_FN vec3 boxExitPoint(vec3 p, vec3 w, vec3 lo, vec3 hi) {
    float t = 3.0e38f;
    if (w.x != 0.0f) t = min(t, ((w.x > 0.0f ? hi.x : lo.x) - p.x) / w.x);
    if (w.y != 0.0f) t = min(t, ((w.y > 0.0f ? hi.y : lo.y) - p.y) / w.y);
    if (w.z != 0.0f) t = min(t, ((w.z > 0.0f ? hi.z : lo.z) - p.z) / w.z);
    return t < 3.0e38f ? p + w * max(t, 0.0f) : p;
}

// The P1 radiance of a diffusion solution scattered toward direction wo (one channel): fluence
// phi, its gradient grad, F = -grad / (3 sigma_tr rho) the net flux limited to |F| <= phi, and
// (phi + 3 g p1 F.wo) with the phase function's first moment g and the flux weight p1. The caller
// divides by 4 pi.
NB_FN float p1Radiance(float phi, vec3 grad, float sigmaTr, float rho, float g, float p1,
                       vec3 wo) {
    vec3 F = -grad / (3.0f * sigmaTr * rho + 1e-30f);
    float len = length(F);
    if (len > phi) F *= phi / len;
    return max(0.0f, phi + 3.0f * g * p1 * dot(F, wo));
}

// Sky in-scattering by the column model: each hemisphere's mean sky weighted by the openness of
// the vertical column above (density integral up) and below (down) the sample, the weights
// normalised (a uniform sky comes back unchanged: the white furnace), and the light decayed by
// kappa per transport optical depth to the nearer open side.
NB_FN vec3 skyColumnInScatter(float up, float down, vec3 sigmaTr, vec3 kappa, vec3 skyUp,
                              vec3 skyDown, float openness) {
    vec3 L = vec3(0.0f);
    for (int c = 0; c < 3; c++) {
        float tu = sigmaTr[c] * up;
        float td = sigmaTr[c] * down;
        float share = skyUpperShare(tu, td, openness);
        L[c] = mix(skyDown[c], skyUp[c], share) * exp(-kappa[c] * min(tu, td));
    }
    return L;
}

// Sky kinds (values = the SkyKind enum of core/scene.h; core/kernels/enum_mirrors.h checks them).
const int SKY_NONE = 0;
const int SKY_UNIFORM = 1;
const int SKY_GRADIENT = 2;

// Sky radiance toward the unit direction d (skyRadiance of core/media/sky.h, every integrator's
// sky): none; uniform, the zenith radiance everywhere; or a gradient from the horizon radiance
// (at and below the horizon) to the zenith's, mixed by sqrt(d.y).
NB_FN vec3 skyRadianceToward(int kind, vec3 zenith, vec3 horizon, vec3 d) {
    if (kind == SKY_UNIFORM) return zenith;
    if (kind == SKY_GRADIENT) return mix(horizon, zenith, sqrt(clamp(d.y, 0.0f, 1.0f)));
    return vec3(0.0f);
}

// Sky in-scattering by height (Olajos 2016): the sphere's mean sky at the top of the layer, a
// share `ground` of it at the base (h = 0), where half the sphere sees the darker ground.
NB_FN vec3 skyHeightInScatter(vec3 ambient, float h, float ground) {
    return ambient * (ground + (1.0f - ground) * h);
}

// The energy-conserving step of a march sample of density rho over dt (Hillaire 2016): source S
// (in-scattered radiance per unit phase-normalised scattering), coefficients per unit density.
NB_FN void marchStep(vec3 S, vec3 sigmaS, vec3 sigmaT, float rho, float dt, INOUT(vec3) L,
                     INOUT(vec3) T) {
    integrateStep(S * (sigmaS * rho), sigmaT * rho, dt, L, T);
}

// The sub-steps a march step is split into so that none has a weight above tauMax
// (render.step_tau; 0 = never split), the weight being the step's optical depth tau times the
// transmittance in front of it (march.cpp): a step several mean free paths thick, sampled once,
// lets one point stand for light that comes from its first mean free path alone. At most
// MAX_SUBSTEPS, each sampled at substepOffset.
const int MAX_SUBSTEPS = 64;
NB_FN int substeps(float tau, float tauMax) {
    if (!(tauMax > 0.0f) || !(tau > tauMax)) return 1;
    return int(min(ceil(tau / tauMax), float(MAX_SUBSTEPS)));
}

// The density render.step_tau's test takes for a step: the largest of its sample's and its
// neighbours' (`around`: the sample before, or a shadow ray's start, and the next step's). A
// step across a cloud's rising or falling edge often has its own sample on the thin side (or
// outside, at 0) and would stay whole, its optical depth all or nothing with the jitter, and the
// exponential of that too bright on average.
NB_FN float splitDensity(float rho, float around) { return max(rho, around); }

// Where in sub-step j of a split step its sample sits, as a fraction of the sub-step: the step's
// jitter turned by the golden ratio per sub-step. Each is uniform when the jitter is, so frames
// and passes with other jitters average to the step's integral; within one ray the sub-steps'
// errors cancel, as a shared fraction's would not (the same offset in every sub-step errs the
// same way in all of them). Without jitter (0.5) it still varies from sub-step to sub-step.
NB_FN float substepOffset(int j, float jitter) {
    return fract(jitter + float(j) * 0.618033989f);
}

// Where along the ray sub-step j of a step split into sub-steps of length h from t0 is sampled.
NB_FN float substepT(float t0, float h, int j, float jitter) {
    return t0 + (float(j) + substepOffset(j, jitter)) * h;
}

// Where in a step the light it scatters is looked at, as a fraction of the step, for a uniform
// fraction f (the step's jitter, or a sub-step's substepOffset): the inverse of the step's
// transmittance as a distribution, s = -ln(1 - f (1 - e^-tau)) / tau, tau the step's optical
// depth. marchStep weights the light by the step's opacity, 1 - e^-tau; looked at here, the
// light of a step of constant density is integrated without bias whatever tau, however fast it
// falls within the step (a sunlit skin: the light comes from its first mean free path). A
// uniform fraction lets a point tau f deep stand for all of it: 0.95 of the sun's single
// scattering on a box 10 mean free paths a step (render.step_tau 0.5), 0.03 at 3.9e2 (a step of
// 2.5e4 split into MAX_SUBSTEPS). Below tau = 0.01 the series of the logarithm, s -> f. The
// forward beam (render.forward_scattering = "delta"), whose extinction is lower, is read at the
// same point: right to first order in steps split to render.step_tau, too bright in the mean
// where a step stays many mean free paths deep (at most by sigma_t / sigma_t,forward).
NB_FN float lightFraction(float f, float tau) {
    if (!(tau > 0.0f)) return f;
    if (tau < 0.01f) {
        float a = 1.0f - tau * (0.5f - tau * (1.0f / 6.0f)); // (1 - e^-tau) / tau
        float u = f * tau * a;
        return f * a * (1.0f + u * (0.5f + u * (1.0f / 3.0f)));
    }
    float s = -log(max(1.0f - f * (1.0f - exp(-tau)), 1e-30f)) / tau;
    return min(max(s, 0.0f), 1.0f);
}

// --- single-scattered sky light (core/lighting/sky_volume.h) ----------------------------------

// Point i of n of a 2D Fibonacci lattice ((i + 1/2) / n, i / golden ratio) in the unit square,
// shifted by `offset` modulo 1 (a Cranley-Patterson rotation: each point uniform, the set
// stratified).
NB_FN vec2 fibonacciPoint(int i, int n, vec2 offset) {
    return vec2(fract((float(i) + 0.5f) / float(n) + offset.x),
                fract(float(i) * 0.618033989f + offset.y));
}

// Direction i of n spread evenly over the sphere (a Fibonacci lattice; Gonzalez 2010): equal
// areas in height y = 1 - (2 i + 1) / n, turning by the golden angle from one to the next (the
// angle taken as 2 pi fract(i (2 - phi)), so cos and sin see arguments in [0, 2 pi) only).
NB_FN vec3 fibonacciDirection(int i, int n) {
    float y = 1.0f - (2.0f * float(i) + 1.0f) / float(n);
    float r = sqrt(max(0.0f, 1.0f - y * y));
    float a = 6.28318530718f * fract(float(i) * 0.381966011f);
    return vec3(r * cos(a), y, r * sin(a));
}
