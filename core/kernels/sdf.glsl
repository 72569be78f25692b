// sdf.glsl: signed distance functions (SDFs) of primitives, their CSG combinations and noise
// displacement, after Thomann 2020, ch. 3-4 (sphere tracing and smooth blending of SDFs, Hart
// 1996's Lipschitz argument) and the usual closed forms of Inigo Quilez's catalogue (written
// here from the geometry).
//
// Convention: negative inside, positive outside, in the units of p. Every function below is
// 1-Lipschitz in p (|f(p) - f(q)| <= |p - q|), which is all sphere tracing needs: a 1-Lipschitz
// f with f(p) > c has no point of the level set {f = c} within f(p) - c of p (Hart 1996). The
// primitives are EXACT distances except sdEllipsoid, a bound (|value| <= true distance, same
// sign). min/max (union, intersection, subtraction) and the smooth versions keep the Lipschitz
// constant 1 but not exactness: inside a union and near the seams of intersections they
// underestimate the distance, which only makes sphere tracing take more, shorter steps.

// Sphere of radius r about the origin. Exact.
NB_FN float sdSphere(vec3 p, float r) { return length(p) - r; }

// Box with half-extents b (all > 0) about the origin. Exact.
NB_FN float sdBox(vec3 p, vec3 b) {
    vec3 q = abs(p) - b;
    return length(max(q, vec3(0.0f))) + min(max(q.x, max(q.y, q.z)), 0.0f);
}

// Box with half-extents b and edges rounded with radius r (0 <= r <= min(b)): the outer size is
// still b. Exact: the offset surface of a box with half-extents b - r.
NB_FN float sdRoundBox(vec3 p, vec3 b, float r) { return sdBox(p, b - vec3(r)) - r; }

// Ellipsoid with semi-axes r (all > 0) about the origin: a BOUND, not the distance (the exact
// distance to an ellipsoid is the root of a sextic). The maximum of three 1-Lipschitz functions,
// each at most the true distance outside and at least minus the true distance inside:
//   (|p / r| - 1) min(r): |p / r| is (1 / min(r))-Lipschitz and equals 1 on the surface;
//   |p| - max(r): the ellipsoid lies in the ball of radius max(r);
//   sdBox(p, r): the ellipsoid lies in its bounding box.
// So the value has the sign of the true distance, its magnitude never exceeds it, and it is
// 1-Lipschitz (a maximum of 1-Lipschitz functions). Exact for a sphere; along an axis the box
// term is exact; the worst case is near the surface off the axes of a flat ellipsoid.
NB_FN float sdEllipsoid(vec3 p, vec3 r) {
    float rmin = min(r.x, min(r.y, r.z));
    float rmax = max(r.x, max(r.y, r.z));
    float scaled = (length(p / r) - 1.0f) * rmin;
    return max(scaled, max(length(p) - rmax, sdBox(p, r)));
}

// Distance from p to the segment [a, b] (2D). Exact.
NB_FN float sdSegment2(vec2 p, vec2 a, vec2 b) {
    vec2 pa = p - a;
    vec2 ba = b - a;
    float h = clamp(dot(pa, ba) / dot(ba, ba), 0.0f, 1.0f);
    return length(pa - ba * h);
}

// Capsule: the points within r of the segment [a, b]. Exact.
NB_FN float sdCapsule(vec3 p, vec3 a, vec3 b, float r) {
    vec3 pa = p - a;
    vec3 ba = b - a;
    float bb = dot(ba, ba);
    float h = bb > 0.0f ? clamp(dot(pa, ba) / bb, 0.0f, 1.0f) : 0.0f;
    return length(pa - ba * h) - r;
}

// Torus about the y axis: a tube of radius r around the circle of radius R in the xz plane
// (R >= r >= 0 keeps the distance exact). Exact.
NB_FN float sdTorus(vec3 p, float R, float r) {
    vec2 q = vec2(length(vec2(p.x, p.z)) - R, p.y);
    return length(q) - r;
}

// Solid right circular cone: base disc of radius r in the plane y = 0, apex at (0, h, 0)
// (r, h > 0). Exact: a solid of revolution, so the distance is the 2D distance in the meridian
// plane (rho = distance from the axis, y) to the triangle (-r, 0), (r, 0), (0, h), whose edges
// nearest to rho >= 0 are the base half [(0,0), (r,0)] and the slant [(r,0), (0,h)].
NB_FN float sdCone(vec3 p, float r, float h) {
    vec2 q = vec2(length(vec2(p.x, p.z)), p.y);
    float d = min(sdSegment2(q, vec2(0.0f, 0.0f), vec2(r, 0.0f)),
                  sdSegment2(q, vec2(r, 0.0f), vec2(0.0f, h)));
    bool inside = q.y > 0.0f && q.x * h + q.y * r < r * h;
    return inside ? -d : d;
}

// Half-space below the plane through n * offset with unit normal n: dot(p, n) - offset
// (negative on the side opposite n). Exact.
NB_FN float sdPlane(vec3 p, vec3 n, float offset) { return dot(p, n) - offset; }

// CSG on distance values: union min, intersection max, subtraction a minus b = max(a, -b).
// Each is 1-Lipschitz in the sup norm of its inputs (|op(a,b) - op(a',b')| <= max(|a-a'|,
// |b-b'|)), so it keeps the Lipschitz constant of its children.
NB_FN float sdfUnion(float a, float b) { return min(a, b); }
NB_FN float sdfIntersection(float a, float b) { return max(a, b); }
NB_FN float sdfSubtraction(float a, float b) { return max(a, -b); }

// Polynomial (quadratic) smooth minimum with blend width k > 0:
//   h = max(k - |a - b|, 0) / k,  smin = min(a, b) - k h^2 / 4.
// Properties used by the tests and the bounds: smin <= min(a, b); smin = min(a, b) where
// |a - b| >= k; min(a, b) - smin <= k / 4; its partial derivatives are (k + x) / 2k and
// (k - x) / 2k (x = |a - b| < k), non-negative and summing to 1, so smin is 1-Lipschitz in the
// sup norm of (a, b) like min. k <= 0 gives the hard min.
NB_FN float sdfSmoothMin(float a, float b, float k) {
    if (k <= 0.0f) return min(a, b);
    float h = max(k - abs(a - b), 0.0f) / k;
    return min(a, b) - h * h * k * 0.25f;
}

// Smooth maximum: -smin(-a, -b); >= max(a, b), equal to it where |a - b| >= k.
NB_FN float sdfSmoothMax(float a, float b, float k) { return -sdfSmoothMin(-a, -b, k); }

NB_FN float sdfSmoothUnion(float a, float b, float k) { return sdfSmoothMin(a, b, k); }
NB_FN float sdfSmoothIntersection(float a, float b, float k) { return sdfSmoothMax(a, b, k); }
NB_FN float sdfSmoothSubtraction(float a, float b, float k) { return sdfSmoothMax(a, -b, k); }

// Displacement noise in [-1, 1] at p (units of the node), frequency `freq` per unit, fBm of
// `octaves` octaves with amplitude ratio `gain`: kind 0 = Perlin fBm (noise.glsl's perlinFbm),
// kind 1 = Worley fBm mapped to 1 - 2 w (billows: positive away from the cells' feature points).
// The lattice period is large (SDF_NOISE_PERIOD cells): no visible repetition.
const int SDF_NOISE_PERLIN = 0;
const int SDF_NOISE_WORLEY = 1;
const int SDF_NOISE_PERIOD = 4096;

NB_FN float sdfNoise(vec3 p, int kind, float freq, int octaves, float gain, uint seed) {
    vec3 q = p * freq;
    if (kind == SDF_NOISE_WORLEY)
        return 1.0f - 2.0f * worleyFbm(q, SDF_NOISE_PERIOD, octaves, gain, seed);
    return perlinFbm(q, SDF_NOISE_PERIOD, octaves, gain, seed);
}

// A displaced distance d + A n (|n| <= 1) is no longer 1-Lipschitz (the noise's gradient is
// unbounded in the octaves), but it differs from d by at most A. With d 1-Lipschitz, every
// point q within sdfSkipDistance(d(p), A, c) of p has d(q) + A n(q) > c: sphere tracing by
// this distance never steps over the level set c of the displaced field. <= 0: no safe step.
NB_FN float sdfSkipDistance(float d, float amplitude, float level) {
    return d - amplitude - level;
}

// Cloud density from a (displaced) signed distance: 1 deeper inside than `falloff`, 0 outside
// the surface, a smoothstep in between: density = smoothstep(0, w, -d). Non-increasing in d, so
// the density over a ball where d >= dmin is at most sdfDensityFromDistance(dmin, w).
NB_FN float sdfDensityFromDistance(float d, float falloff) {
    if (falloff <= 0.0f) return d < 0.0f ? 1.0f : 0.0f;
    float x = clamp(-d / falloff, 0.0f, 1.0f);
    return x * x * (3.0f - 2.0f * x);
}
