// phase.glsl: phase functions, each with eval / sample / pdf; one switch per verb.
//
// Convention: cosTheta is the cosine between the propagation direction before and after the
// scattering event; cosTheta = 1 is forward (no deflection), -1 is straight back. Every phase
// function is normalised over the sphere: the integral of p over all directions is 1 (1/sr).
// Samplers invert the CDF of cosTheta taken from cosTheta = -1: u = 0 -> -1, u -> 1 -> +1.
//
//  - isotropic: 1 / (4 pi).
//  - Henyey & Greenstein 1941 (HG): p = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos)^{3/2}).
//  - dual-lobe HG: p = (1 - w) HG(g1) + w HG(g2).
//  - Draine 2003: p = (1 - g^2)(1 + a cos^2) / (4 pi (1 + a (1 + 2 g^2) / 3)
//                     (1 + g^2 - 2 g cos)^{3/2});
//    a = 0 is HG, g = 0 and a = 1 is Rayleigh 3 (1 + cos^2) / (16 pi).
//  - approximate Mie (Jendersie & d'Eon 2023, "An Approximate Mie Scattering Function for Fog
//    and Cloud Rendering"): p = (1 - w) HG(g_HG) + w Draine(g_D, a), the four parameters fitted
//    to Lorenz-Mie by the droplet diameter d; the fit used here holds for 5 um <= d <= 50 um and
//    d is clamped to that range.
//  - Mie table: a Lorenz-Mie phase function tabulated by core/media/mie.h. Tables live on the host
//    (core/media/phase.h evaluates them); here PHASE_MIE_TABLE is a stand-in HG whose g is the table's
//    mean cosine, for code that has no access to the table.
//
// Sampling is exact: HG by its closed-form inverse CDF (without the 1/g cancellation of the
// textbook form at small |g|), Draine by Newton's method on its closed-form CDF in the variable
// in which HG is uniform (bounded iterations, bisection safeguard; the closed-form quartic root
// of Jendersie & d'Eon cancels catastrophically in float for small g), mixtures by choosing a
// lobe with a second random number. The pdf of every analytic kind is its eval.

const float NB_PI = 3.14159265358979f;
const float NB_INV_4PI = 0.0795774715459f;

const int PHASE_ISOTROPIC = 0;
const int PHASE_HG = 1;
const int PHASE_DUAL_HG = 2;
const int PHASE_DRAINE = 3;
const int PHASE_MIE_APPROX = 4;
const int PHASE_MIE_TABLE = 5;

// Parameters of every kind; the meaning of the fields depends on `kind`:
//   PHASE_HG          g
//   PHASE_DUAL_HG     (1 - blend) HG(g) + blend HG(g2)
//   PHASE_DRAINE      Draine(g, alpha)
//   PHASE_MIE_APPROX  (1 - blend) HG(g) + blend Draine(g2, alpha); all four derived from
//                     `diameter` (micrometres) by phaseParamsMieApprox
//   PHASE_MIE_TABLE   g = mean cosine of the table (stand-in HG, see above)
struct PhaseParams {
    int kind;
    float g;
    float g2;
    float blend;
    float alpha;
    float diameter;
};

// Built field by field: a struct constructor call would need C++20 parenthesised aggregate
// initialisation, which clang 14 (the fuzzing compiler) lacks.
NB_FN PhaseParams makePhaseParams(int kind, float g, float g2, float blend, float alpha,
                                  float diameter) {
    PhaseParams p;
    p.kind = kind;
    p.g = g;
    p.g2 = g2;
    p.blend = blend;
    p.alpha = alpha;
    p.diameter = diameter;
    return p;
}

NB_FN PhaseParams phaseParamsIsotropic() {
    return makePhaseParams(PHASE_ISOTROPIC, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f);
}

NB_FN PhaseParams phaseParamsHG(float g) {
    return makePhaseParams(PHASE_HG, g, 0.0f, 0.0f, 0.0f, 0.0f);
}

NB_FN PhaseParams phaseParamsDualHG(float g1, float g2, float blend) {
    return makePhaseParams(PHASE_DUAL_HG, g1, g2, blend, 0.0f, 0.0f);
}

NB_FN PhaseParams phaseParamsDraine(float g, float alpha) {
    return makePhaseParams(PHASE_DRAINE, g, 0.0f, 0.0f, alpha, 0.0f);
}

// Jendersie & d'Eon 2023, fit for droplet diameters 5-50 um (d in micrometres, clamped):
// g_HG = exp(-0.0990567 / (d - 1.67154)), g_D = exp(-2.20679 / (d + 3.91029) - 0.428934),
// alpha = exp(3.62489 - 8.29288 / (d + 5.52825)), w = exp(-0.599085 / (d - 0.641583) - 0.665888).
NB_FN PhaseParams phaseParamsMieApprox(float diameter) {
    float d = clamp(diameter, 5.0f, 50.0f);
    float gHG = exp(-0.0990567f / (d - 1.67154f));
    float gD = exp(-2.20679f / (d + 3.91029f) - 0.428934f);
    float alpha = exp(3.62489f - 8.29288f / (d + 5.52825f));
    float w = exp(-0.599085f / (d - 0.641583f) - 0.665888f);
    return makePhaseParams(PHASE_MIE_APPROX, gHG, gD, w, alpha, d);
}

// The phase function of a multiple-scattering octave (Wrenninge 2015): every asymmetry
// parameter scaled by `eccentricity` (alpha and blend kept).
NB_FN PhaseParams phaseOctave(IN(PhaseParams) p, float eccentricity) {
    return makePhaseParams(p.kind, p.g * eccentricity, p.g2 * eccentricity, p.blend, p.alpha,
                       p.diameter);
}

// ------------------------------------------------------------------ Henyey-Greenstein

// 1 + g^2 - 2 g cos, written so that it keeps its relative precision near the peak
// ((1 - |g|)^2 when cos = sign(g)): 1 + g^2 - 2 g cos cancels to a few digits in float for
// |g| > 0.95.
NB_FN float phaseHGDenominator(float cosTheta, float g) {
    if (g >= 0.0f) return (1.0f - g) * (1.0f - g) + 2.0f * g * (1.0f - cosTheta);
    return (1.0f + g) * (1.0f + g) - 2.0f * g * (1.0f + cosTheta);
}

NB_FN float phaseHG(float cosTheta, float g) {
    // d is 0 only at the peak of g = +-1 (a delta, which no density represents): 0 there, not
    // 0 / 0; the floor changes nothing while |g| < 1 - 1e-6
    float d = max(phaseHGDenominator(cosTheta, g), 1e-12f);
    return NB_INV_4PI * (1.0f - g) * (1.0f + g) / (d * sqrt(d));
}

// Inverse CDF of HG; u in [0, 1], c = 2u - 1. The textbook form
// cos = (1 + g^2 - s^2) / (2 g), s = (1 - g^2) / (1 + g c), loses digits to the 1/g for small
// |g|; there the equal form cos = c + g (1 - c^2)(3 + 2 g c - g^2) / (2 (1 + g c)^2) is used,
// which has no cancellation while |g| < 1/4 (and is c at g = 0). Accurate to a few float ulps.
NB_FN float phaseHGSampleCos(float g, float u) {
    float c = 2.0f * u - 1.0f;
    float cosTheta;
    if (abs(g) < 0.25f) {
        float q = 1.0f + g * c;
        cosTheta = c + g * (1.0f - c * c) * (3.0f + 2.0f * g * c - g * g) / (2.0f * q * q);
    } else {
        // q = 1 + g c as a sum of two positive terms (it is small where g c -> -1)
        float q = g > 0.0f ? (1.0f - g) + 2.0f * g * u : (1.0f + g) - 2.0f * g * (1.0f - u);
        float s = (1.0f - g) * (1.0f + g) / max(q, 1e-30f); // q = 0 only for g = +-1, u = 0
        cosTheta = (1.0f + g * g - s * s) / (2.0f * g);
    }
    return clamp(cosTheta, -1.0f, 1.0f);
}

// ------------------------------------------------------------------ Draine

NB_FN float phaseDraine(float cosTheta, float g, float alpha) {
    float norm = 1.0f + alpha * (1.0f + 2.0f * g * g) / 3.0f;
    return phaseHG(cosTheta, g) * (1.0f + alpha * cosTheta * cosTheta) / norm;
}

// Integral of t^2 h(t) dt over [-1, mu], h the HG density of t = cos (integrating to 1 over
// [-1, 1]). Written without the 1/g^3 cancellation of the direct antiderivative:
// M2 = (1 - g)(1 + mu) P / (6 s (A s + B (1 + g))), s = sqrt(1 + g^2 - 2 g mu), a = 1 + g^2,
// A = 2 a^2 + 2 a g - g^2, B = 2 a^2 - 2 a g mu - g^2 mu^2 (A, B > 0), and
// P = 4 (mu^2 - mu + 1)(1 + g^4) + (g + g^3)(mu^3 + 7 mu^2 - 7 mu - 1)
//     + 2 g^2 (mu^3 + 3 mu^2 - 3 mu + 4).
// M2(1) = (1 + 2 g^2) / 3; at g = 0 it is (mu^3 + 1) / 6.
NB_FN float phaseDraineM2(float g, float mu) {
    float g2 = g * g;
    float a = 1.0f + g2;
    float s = sqrt(max(phaseHGDenominator(mu, g), 0.0f));
    float A = 2.0f * a * a + 2.0f * a * g - g2;
    float B = 2.0f * a * a - 2.0f * a * g * mu - g2 * mu * mu;
    float mu2 = mu * mu;
    float P = 4.0f * (mu2 - mu + 1.0f) * (1.0f + g2 * g2) +
              (g + g * g2) * (mu2 * mu + 7.0f * mu2 - 7.0f * mu - 1.0f) +
              2.0f * g2 * (mu2 * mu + 3.0f * mu2 - 3.0f * mu + 4.0f);
    float den = 6.0f * s * (A * s + B * (1.0f + g));
    return den > 0.0f ? (1.0f - g) * (1.0f + mu) * P / den : 0.0f;
}

// Exact inverse CDF of Draine. In xi = HG CDF (cos = phaseHGSampleCos(g, xi)) the Draine CDF is
// F(xi) = (xi + alpha M2(cos(xi))) / norm with dF/dxi = (1 + alpha cos^2) / norm in
// [1, 1 + alpha] / norm: smooth and monotone, so Newton's method from the HG sample converges
// quadratically (3.5-5 iterations on average, at most 7-11 in tests with alpha up to 1000); a
// bisection bracket keeps every step inside [0, 1], and a step below the rounding noise of F
// ends it. Near a very sharp peak (g > 0.95) the float cos itself is the limit: adjacent floats
// differ in F by more than the noise and the bracket halves to 1e-7 (at most 24 iterations).
// alpha >= 0.
NB_FN float phaseDraineSampleCos(float g, float alpha, float u) {
    float norm = 1.0f + alpha * (1.0f + 2.0f * g * g) / 3.0f;
    float target = u * norm;
    float lo = 0.0f;
    float hi = 1.0f;
    float xi = u;
    for (int i = 0; i < 24; ++i) {
        float mu = phaseHGSampleCos(g, xi);
        float f = xi + alpha * phaseDraineM2(g, mu) - target;
        if (f > 0.0f) {
            hi = xi;
        } else {
            lo = xi;
        }
        float next = xi - f / (1.0f + alpha * mu * mu);
        if (!(next >= lo && next <= hi)) next = 0.5f * (lo + hi);
        float step = abs(next - xi);
        xi = next;
        if (step <= 2.5e-7f * norm || hi - lo <= 1e-7f) break;
    }
    return phaseHGSampleCos(g, xi);
}

// ------------------------------------------------------------------ one switch per verb

NB_FN float phaseEval(IN(PhaseParams) p, float cosTheta) {
    switch (p.kind) {
    case PHASE_HG:
    case PHASE_MIE_TABLE:
        return phaseHG(cosTheta, p.g);
    case PHASE_DUAL_HG:
        return (1.0f - p.blend) * phaseHG(cosTheta, p.g) + p.blend * phaseHG(cosTheta, p.g2);
    case PHASE_DRAINE:
        return phaseDraine(cosTheta, p.g, p.alpha);
    case PHASE_MIE_APPROX:
        return (1.0f - p.blend) * phaseHG(cosTheta, p.g) +
               p.blend * phaseDraine(cosTheta, p.g2, p.alpha);
    default:
        return NB_INV_4PI;
    }
}

// Density (1/sr) of the directions phaseSample produces: the phase function itself.
NB_FN float phasePdf(IN(PhaseParams) p, float cosTheta) { return phaseEval(p, cosTheta); }

// Samples cos(theta) from u.x; u.y picks the lobe of the two-lobe kinds.
NB_FN float phaseSample(IN(PhaseParams) p, vec2 u) {
    switch (p.kind) {
    case PHASE_HG:
    case PHASE_MIE_TABLE:
        return phaseHGSampleCos(p.g, u.x);
    case PHASE_DUAL_HG:
        return phaseHGSampleCos(u.y < p.blend ? p.g2 : p.g, u.x);
    case PHASE_DRAINE:
        return phaseDraineSampleCos(p.g, p.alpha, u.x);
    case PHASE_MIE_APPROX:
        if (u.y < p.blend) return phaseDraineSampleCos(p.g2, p.alpha, u.x);
        return phaseHGSampleCos(p.g, u.x);
    default:
        return 2.0f * u.x - 1.0f;
    }
}

// The direction at angle acos(cosTheta) from the unit vector wi, at azimuth 2 pi u around it
// (orthonormal basis of Duff et al. 2017).
NB_FN vec3 phaseDirection(vec3 wi, float cosTheta, float u) {
    float sgn = wi.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (sgn + wi.z);
    float b = wi.x * wi.y * a;
    vec3 t = vec3(1.0f + sgn * wi.x * wi.x * a, sgn * b, -sgn * wi.x);
    vec3 bt = vec3(b, sgn + wi.y * wi.y * a, -wi.y);
    float sinTheta = sqrt(max(0.0f, 1.0f - cosTheta * cosTheta));
    float phi = 2.0f * NB_PI * u;
    // renormalised: directions stay unit length along paths of thousands of bounces
    return normalize((sinTheta * cos(phi)) * t + (sinTheta * sin(phi)) * bt + cosTheta * wi);
}

// Samples the propagation direction after scattering, given the one before (wi, unit length);
// its density is phasePdf(p, dot(wi, result)).
NB_FN vec3 phaseSampleDirection(IN(PhaseParams) p, vec3 wi, vec3 u) {
    return phaseDirection(wi, phaseSample(p, vec2(u.x, u.y)), u.z);
}

// Kind-and-g form kept for existing callers (isotropic and HG only).
NB_FN float phaseEval(int kind, float g, float cosTheta) {
    return phaseEval(makePhaseParams(kind, g, 0.0f, 0.0f, 0.0f, 0.0f), cosTheta);
}

NB_FN float phasePdf(int kind, float g, float cosTheta) { return phaseEval(kind, g, cosTheta); }

NB_FN float phaseSampleCos(int kind, float g, float u) {
    return phaseSample(makePhaseParams(kind, g, 0.0f, 0.0f, 0.0f, 0.0f), vec2(u, 0.0f));
}
