// sdf_shading.glsl: shading terms of opaque SDF solids (Thomann 2020, ch. 3), shared by the C++
// sphere tracer (core/sdf/solid.cpp) and the GLSL port. The distance function itself is the
// caller's: these are the per-sample terms of the soft shadow, the ambient occlusion and the
// tetrahedral normal.

// Classic penumbra estimate of a shadow ray that passed at distance h from the solid at ray
// parameter t: k h / t, clamped to [0, 1] (the visibility is the minimum over the samples).
// The sine of the half-angle of the unoccluded cone is about h / t; k is the sharpness
// (k ~ 1 / sin of the sun's angular radius makes the estimate linear across the true penumbra).
NB_FN float sdfPenumbraClassic(float h, float t, float k) {
    return clamp(k * h / max(t, 1e-20f), 0.0f, 1.0f);
}

// Quilez's improved estimate (2018): the previous sample, a step s back, had distance ph; the
// spheres of radii ph and h around the two samples meet on a circle at y = (h^2 - ph^2 + s^2) /
// (2 s) back from the current sample, of radius sqrt(h^2 - y^2): the estimated closest approach
// of the ray to the solid, k dd / (t - y). (Quilez steps by s = ph, where y = h^2 / (2 ph).) When
// that circle is not between the samples (0 < y < s fails: the first sample, or a ray moving
// straight away from the surface, where the formula would give 0 / 0) the classic estimate of
// the current sample is used. Fewer banding artefacts at sharp features than the classic form.
NB_FN float sdfPenumbraImproved(float h, float t, float ph, float s, float k) {
    if (!(s > 0.0f) || ph >= 1e19f) return sdfPenumbraClassic(h, t, k);
    float y = (h * h - ph * ph + s * s) / (2.0f * s);
    if (!(y > 0.0f && y < s)) return sdfPenumbraClassic(h, t, k);
    float dd = sqrt(max(h * h - y * y, 0.0f));
    return clamp(k * dd / max(t - y, 1e-20f), 0.0f, 1.0f);
}

// Ambient occlusion from the distance field: the sample i (0-based) lies at delta_i = (i + 1)
// step along the normal.
NB_FN float sdfAoDelta(int i, float step) { return step * float(i + 1); }

// Its weight w_i = strength 2^-(i+1) / step: with d = 0 at every sample (a surface folded
// flat onto itself) the sum w_i delta_i tends to 2 strength.
NB_FN float sdfAoWeight(int i, float step, float strength) {
    return strength * exp2(-float(i + 1)) / step;
}

// One term w_i (delta_i - d(p + n delta_i)) of the occlusion sum (never negative: a field that
// grows faster than the distance adds nothing).
NB_FN float sdfAoTerm(float delta, float d, float w) { return w * max(delta - d, 0.0f); }

// AO = 1 - sum, clamped to [0, 1].
NB_FN float sdfAoFinish(float occlusion) { return clamp(1.0f - occlusion, 0.0f, 1.0f); }

// The i-th vertex (0..3) of the tetrahedron of the tetrahedral normal: the gradient is
// sum_i v_i d(p + e v_i) (normalised), four evaluations instead of six.
NB_FN vec3 sdfTetraVertex(int i) {
    if (i == 0) return vec3(1.0f, -1.0f, -1.0f);
    if (i == 1) return vec3(-1.0f, -1.0f, 1.0f);
    if (i == 2) return vec3(-1.0f, 1.0f, -1.0f);
    return vec3(1.0f, 1.0f, 1.0f);
}
