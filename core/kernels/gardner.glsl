// gardner.glsl: Gardner's textured ellipsoids (G. Y. Gardner, "Visual simulation of clouds",
// SIGGRAPH 1985; P. Elinas and W. Stuerzlinger, "Real-time rendering of 3D clouds", JGT 2000),
// evaluated in 3D as a density field.
//
// Texture (Gardner's spectral sum of sines, not noise). One sum along axis x, with its phase
// driven by the coordinate y:
//     S(x; y) = sum_{i=1..n} [ C_i sin(F_i x + P_i) + T0 ]
//     F_1 = 2 pi f,  F_{i+1} = 2 F_i,  C_1 = 1,  C_{i+1} = C_i / sqrt(2),
//     P_1 = A sin(F_1 y / 2),  P_i = A sin(F_{i-1} y)  (i > 1),  A = pi/2 in Gardner's paper.
// (Gardner writes the brackets as [C_i sin(...) + T0]: T0 is added once per term, not scaled
// by C_i.) In 2D Gardner multiplies the sum along x, phased by y, with the sum along y, phased
// by x. The 3D extension used here multiplies three sums whose phases go round the axes,
//     I(p) = k S(x; y) S(y; z) S(z; x) / S_max^3,    S_max = sum_i C_i + n T0,
// with p = world point + offset. Dividing by S_max^3 makes k the texture's maximum (with
// T0 >= 0 every |S| <= S_max, so |I| <= k): k = 1 gives I in [-1, 1], in [0, 1] when
// T0 >= sum_i C_i / n (every sum non-negative).
//
// Shape: g = 1 - r^2 (r^2 = the ellipsoid's quadric, 0 at the centre, 1 on the surface) is the
// normalised falloff, 1 at the centre and 0 on the surface. Gardner's transparency
//     a = 1 - (I - T1 - (T2 - T1)(1 - g)) / D,  clamped to [0, 1],
// gives the density 1 - a inside the ellipsoid (g > 0), times a density scale; 0 outside.
// T1 is the texture threshold at the centre, T2 (>= T1) at the surface, D the ramp width.

struct GardnerTexture {
    float frequency; // f: cycles per world unit of the first term (F_1 = 2 pi f)
    int terms;       // n
    float k;         // the texture's maximum (Gardner's k, normalised by S_max^3)
    float t0;        // T0: offset of each term (>= 0; larger = less contrast)
    float phase;     // A: amplitude of the phase shifts (Gardner: pi / 2)
    vec3 offset;     // added to the world point before the sums
};

struct GardnerEllipsoid {
    vec3 center;
    vec3 axisX; // local x = dot(axisX, p - center): the ellipsoid's x axis / its x radius
    vec3 axisY;
    vec3 axisZ;
    float t1;      // T1: texture threshold at the centre
    float t2;      // T2: texture threshold at the surface (>= T1)
    float d;       // D: width of the ramp from transparent to opaque (> 0)
    float density; // density scale (the density of an opaque point)
};

const float GARDNER_TWO_PI = 6.28318530718f;
const float GARDNER_C_RATIO = 0.70710678118f; // C_{i+1} / C_i = 1 / sqrt(2)

// One sum S(x; y): the terms along x, phased by y.
NB_FN float gardnerSum(IN(GardnerTexture) t, float x, float y) {
    float F = GARDNER_TWO_PI * t.frequency;
    float C = 1.0f;
    float P = t.phase * sin(0.5f * F * y);
    float s = 0.0f;
    for (int i = 0; i < t.terms; ++i) {
        s += C * sin(F * x + P) + t.t0;
        P = t.phase * sin(F * y);
        F *= 2.0f;
        C *= GARDNER_C_RATIO;
    }
    return s;
}

// S_max = sum_i C_i + n T0: the largest value a sum can take.
NB_FN float gardnerSumMax(IN(GardnerTexture) t) {
    float C = 1.0f;
    float s = 0.0f;
    for (int i = 0; i < t.terms; ++i) {
        s += C + t.t0;
        C *= GARDNER_C_RATIO;
    }
    return s;
}

// The texture I(p) = k S(x; y) S(y; z) S(z; x) / S_max^3.
NB_FN float gardnerTexture(IN(GardnerTexture) t, vec3 p) {
    vec3 q = p + t.offset;
    float m = gardnerSumMax(t);
    float sx = gardnerSum(t, q.x, q.y) / m;
    float sy = gardnerSum(t, q.y, q.z) / m;
    float sz = gardnerSum(t, q.z, q.x) / m;
    return t.k * sx * sy * sz;
}

// Normalised falloff g = 1 - r^2 at local point q (r^2 = |q|^2): 1 at the centre, 0 on the
// surface, negative outside.
NB_FN float gardnerFalloff(vec3 q) { return 1.0f - dot(q, q); }

// Gardner's transparency a = 1 - (I - T1 - (T2 - T1)(1 - g)) / D, clamped to [0, 1].
NB_FN float gardnerTransparency(float I, float g, float t1, float t2, float d) {
    return clamp(1.0f - (I - t1 - (t2 - t1) * (1.0f - g)) / d, 0.0f, 1.0f);
}

// The ellipsoid's local coordinates of p (the unit ball is the ellipsoid).
NB_FN vec3 gardnerLocal(IN(GardnerEllipsoid) e, vec3 p) {
    vec3 r = p - e.center;
    return vec3(dot(e.axisX, r), dot(e.axisY, r), dot(e.axisZ, r));
}

// Density of one ellipsoid at p for texture value I: density (1 - a) inside, 0 outside.
NB_FN float gardnerEllipsoidDensity(IN(GardnerEllipsoid) e, float I, vec3 p) {
    float g = gardnerFalloff(gardnerLocal(e, p));
    if (g <= 0.0f) return 0.0f;
    return e.density * (1.0f - gardnerTransparency(I, g, e.t1, e.t2, e.d));
}

// ---------------------------------------------------------------- bounds (for majorants)

// Rounding allowance of sin(x) for |x| up to m: the argument's own rounding (a few ulp of m)
// plus sin's error.
NB_FN float gardnerSinSlack(float m) { return 1e-6f + 1e-6f * m; }

// Upper bound of sin over [a, b] (a <= b): 1 when a crest pi/2 + 2 pi j lies inside, else the
// larger end (sin is monotone between a crest and a trough).
NB_FN float gardnerSinMax(float a, float b) {
    float slack = gardnerSinSlack(max(abs(a), abs(b)));
    if (b - a >= GARDNER_TWO_PI) return 1.0f;
    float crest = 1.57079632679f + GARDNER_TWO_PI * ceil((a - 1.57079632679f) / GARDNER_TWO_PI);
    if (crest <= b + slack || crest - GARDNER_TWO_PI >= a - slack) return 1.0f;
    return min(1.0f, max(sin(a), sin(b)) + slack);
}

// Lower bound of sin over [a, b]: -max of sin over [a + pi, b + pi].
NB_FN float gardnerSinMin(float a, float b) {
    return -gardnerSinMax(a + 3.14159265359f, b + 3.14159265359f);
}

// Range (lo, hi) of S(x; y) for x in [x0, x1] and any y (every |P_i| <= |A|).
NB_FN vec2 gardnerSumRange(IN(GardnerTexture) t, float x0, float x1) {
    float F = GARDNER_TWO_PI * t.frequency;
    float C = 1.0f;
    float A = abs(t.phase);
    float lo = 0.0f;
    float hi = 0.0f;
    for (int i = 0; i < t.terms; ++i) {
        float a = min(F * x0, F * x1) - A;
        float b = max(F * x0, F * x1) + A;
        lo += C * gardnerSinMin(a, b) + t.t0;
        hi += C * gardnerSinMax(a, b) + t.t0;
        F *= 2.0f;
        C *= GARDNER_C_RATIO;
    }
    return vec2(lo, hi);
}

// Product of two intervals (lo, hi).
NB_FN vec2 gardnerIntervalProduct(vec2 u, vec2 v) {
    float a = u.x * v.x;
    float b = u.x * v.y;
    float c = u.y * v.x;
    float d = u.y * v.y;
    return vec2(min(min(a, b), min(c, d)), max(max(a, b), max(c, d)));
}

// Upper bound of the texture I over the box [lo, hi].
NB_FN float gardnerTextureBound(IN(GardnerTexture) t, vec3 lo, vec3 hi) {
    vec3 a = lo + t.offset;
    vec3 b = hi + t.offset;
    float m = gardnerSumMax(t);
    vec2 sx = gardnerSumRange(t, a.x, b.x) / m;
    vec2 sy = gardnerSumRange(t, a.y, b.y) / m;
    vec2 sz = gardnerSumRange(t, a.z, b.z) / m;
    vec2 r = gardnerIntervalProduct(gardnerIntervalProduct(sx, sy), sz) * t.k;
    float top = max(r.x, r.y);
    return top + 1e-5f * abs(t.k); // rounding of the products and the normalisation
}

// Lower bound of r^2 over the box [lo, hi]: the box in local coordinates lies within the
// axis-aligned local box around its centre with half-widths sum_j |axis_aj| h_j, and the
// quadric's minimum over that box is the sum over axes of the nearest distance squared.
NB_FN float gardnerR2Min(IN(GardnerEllipsoid) e, vec3 lo, vec3 hi) {
    vec3 h = 0.5f * (hi - lo);
    vec3 c = gardnerLocal(e, 0.5f * (lo + hi));
    vec3 w = vec3(dot(abs(e.axisX), h), dot(abs(e.axisY), h), dot(abs(e.axisZ), h));
    vec3 gap = max(abs(c) - w, vec3(0.0f));
    return dot(gap, gap) * (1.0f - 1e-5f); // rounding of the local coordinates
}

// Upper bound of one ellipsoid's density over the box [lo, hi], given an upper bound Imax of
// the texture there: 0 when the box misses the ellipsoid, else the density at the largest
// falloff over the box (the density grows with I and with g since T2 >= T1).
NB_FN float gardnerEllipsoidBound(IN(GardnerEllipsoid) e, float Imax, vec3 lo, vec3 hi) {
    float r2 = gardnerR2Min(e, lo, hi);
    if (r2 >= 1.0f) return 0.0f;
    return e.density * (1.0f - gardnerTransparency(Imax, 1.0f - r2, e.t1, e.t2, e.d));
}
