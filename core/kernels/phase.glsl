// phase.glsl: phase functions, each with eval / sample / pdf; one switch over the kind.
// Henyey & Greenstein 1941: p(cos) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos)^{3/2}).

const float NB_PI = 3.14159265358979f;
const float NB_INV_4PI = 0.0795774715459f;

const int PHASE_ISOTROPIC = 0;
const int PHASE_HG = 1;

NB_FN float phaseHG(float cosTheta, float g) {
    float d = 1.0f + g * g - 2.0f * g * cosTheta;
    return NB_INV_4PI * (1.0f - g * g) / (d * sqrt(max(d, 1e-12f)));
}

// Inverse-CDF sample of cos(theta) for HG; u in [0, 1). Convention: cos = 1 is forward.
NB_FN float phaseHGSampleCos(float g, float u) {
    if (abs(g) < 1e-3f) return 1.0f - 2.0f * u;
    float s = (1.0f - g * g) / (1.0f - g + 2.0f * g * u);
    return clamp((1.0f + g * g - s * s) / (2.0f * g), -1.0f, 1.0f);
}

NB_FN float phaseEval(int kind, float g, float cosTheta) {
    switch (kind) {
    case PHASE_HG:
        return phaseHG(cosTheta, g);
    default:
        return NB_INV_4PI;
    }
}

NB_FN float phasePdf(int kind, float g, float cosTheta) { return phaseEval(kind, g, cosTheta); }

// Samples cos(theta) relative to the propagation direction.
NB_FN float phaseSampleCos(int kind, float g, float u) {
    switch (kind) {
    case PHASE_HG:
        return phaseHGSampleCos(g, u);
    default:
        return 1.0f - 2.0f * u;
    }
}
