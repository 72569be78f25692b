// The SDF library (core/kernels/sdf.glsl, core/sdf/sdf.h): primitives against distances
// computed independently (closest points found by dense search in double precision), the
// ellipsoid bound against the true distance, 1-Lipschitz on random pairs, the smooth operators'
// inequalities, sphere tracing against dense sampling on 10^4 rays, the displacement bound, the
// support box.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <stdexcept>

#include "core/kernels/kernels.h"
#include "core/sdf/sdf.h"

using namespace nimbus;
using glm::dvec2;
using glm::dvec3;

namespace {

struct Rng {
    std::mt19937 g{12345};
    float u(float lo, float hi) { return std::uniform_real_distribution<float>(lo, hi)(g); }
    vec3 v3(float lo, float hi) { return vec3(u(lo, hi), u(lo, hi), u(lo, hi)); }
    vec3 dir() {
        for (;;) {
            const vec3 v = v3(-1.0f, 1.0f);
            const float l = glm::length(v);
            if (l > 0.1f && l <= 1.0f) return v / l;
        }
    }
};

/// Minimum of a unimodal function of t in [lo, hi] (golden-section search, double).
double minimise(const std::function<double(double)>& f, double lo, double hi) {
    const double r = 0.6180339887498949;
    double a = lo, b = hi, c = b - r * (b - a), d = a + r * (b - a);
    for (int i = 0; i < 200; ++i) {
        if (f(c) < f(d))
            b = d;
        else
            a = c;
        c = b - r * (b - a);
        d = a + r * (b - a);
    }
    return f(0.5 * (a + b));
}

/// Distance from q to the segment [a, b] in 2D or 3D, by search along the segment.
template <class V> double segmentDistance(V q, V a, V b) {
    return minimise([&](double t) { return glm::length(q - (a + (b - a) * t)); }, 0.0, 1.0);
}

/// Exact distance to a solid box by its closest point (independent of sdBox's formula).
double boxDistance(dvec3 p, dvec3 b) {
    const dvec3 c = glm::clamp(p, -b, b);
    const double out = glm::length(p - c);
    if (out > 0.0) return out;
    return -std::min({b.x - std::abs(p.x), b.y - std::abs(p.y), b.z - std::abs(p.z)});
}

/// True distance to an ellipsoid surface: dense search over (theta, phi), then refinement.
double ellipsoidSurfaceDistance(dvec3 p, dvec3 r) {
    auto at = [&](double th, double ph) {
        return glm::length(p - dvec3(r.x * std::sin(th) * std::cos(ph), r.y * std::cos(th),
                                     r.z * std::sin(th) * std::sin(ph)));
    };
    double best = 1e30, bt = 0, bp = 0;
    const int n = 200;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; j < 2 * n; ++j) {
            const double th = M_PI * i / n, ph = M_PI * j / n, d = at(th, ph);
            if (d < best) best = d, bt = th, bp = ph;
        }
    double step = M_PI / n;
    for (int it = 0; it < 60; ++it) {
        bool moved = false;
        for (int di = -1; di <= 1; ++di)
            for (int dj = -1; dj <= 1; ++dj) {
                const double d = at(bt + di * step, bp + dj * step);
                if (d < best) best = d, bt += di * step, bp += dj * step, moved = true;
            }
        if (!moved) step *= 0.5;
    }
    return best;
}

constexpr float kTol = 2e-5f; // float rounding of values of order 1-10

} // namespace

TEST(SdfPrimitive, SphereBoxRoundBoxPlaneAreExact) {
    Rng rng;
    for (int i = 0; i < 2000; ++i) {
        const vec3 p = rng.v3(-4.0f, 4.0f);
        const float r = rng.u(0.1f, 3.0f);
        EXPECT_NEAR(kern::sdSphere(p, r), glm::length(dvec3(p)) - r, kTol);
        const vec3 b = rng.v3(0.1f, 3.0f);
        EXPECT_NEAR(kern::sdBox(p, b), boxDistance(dvec3(p), dvec3(b)), kTol) << i;
        const float rr = rng.u(0.0f, minComponent(b));
        // a rounded box is the set within rr of the box shrunk by rr
        EXPECT_NEAR(kern::sdRoundBox(p, b, rr), boxDistance(dvec3(p), dvec3(b - vec3(rr))) - rr,
                    kTol);
        const vec3 n = rng.dir();
        const float o = rng.u(-2.0f, 2.0f);
        // distance to the plane's closest point, signed by side
        const dvec3 foot = dvec3(p) - dvec3(n) * (glm::dot(dvec3(p), dvec3(n)) - o);
        const double side = glm::dot(dvec3(p), dvec3(n)) > o ? 1.0 : -1.0;
        EXPECT_NEAR(kern::sdPlane(p, n, o), side * glm::length(dvec3(p) - foot), kTol);
    }
}

TEST(SdfPrimitive, CapsuleTorusConeAreExact) {
    Rng rng;
    for (int i = 0; i < 1000; ++i) {
        const vec3 p = rng.v3(-4.0f, 4.0f);
        const vec3 a = rng.v3(-2.0f, 2.0f), b = rng.v3(-2.0f, 2.0f);
        const float r = rng.u(0.1f, 1.5f);
        EXPECT_NEAR(kern::sdCapsule(p, a, b, r), segmentDistance(dvec3(p), dvec3(a), dvec3(b)) - r,
                    1e-4f);
        // torus: distance to the ring circle by search over its angle, minus the tube
        const float R = rng.u(0.5f, 2.5f), rt = rng.u(0.05f, R);
        const double ring = std::min(
            minimise(
                [&](double th) {
                    return glm::length(dvec3(p) - dvec3(R * std::cos(th), 0, R * std::sin(th)));
                },
                -M_PI, 0.0),
            minimise(
                [&](double th) {
                    return glm::length(dvec3(p) - dvec3(R * std::cos(th), 0, R * std::sin(th)));
                },
                0.0, M_PI));
        EXPECT_NEAR(kern::sdTorus(p, R, rt), ring - rt, 1e-4f) << i;
        // cone: in the meridian plane, the distance to the triangle's three edges, signed by a
        // barycentric inside test
        const float cr = rng.u(0.2f, 2.0f), ch = rng.u(0.2f, 3.0f);
        const dvec2 q(std::hypot(double(p.x), double(p.z)), p.y);
        const dvec2 A(-cr, 0), B(cr, 0), C(0, ch);
        const double dist = std::min(
            {segmentDistance(q, A, B), segmentDistance(q, B, C), segmentDistance(q, C, A)});
        auto cross = [](dvec2 u, dvec2 v) { return u.x * v.y - u.y * v.x; };
        const bool inside =
            cross(B - A, q - A) > 0 && cross(C - B, q - B) > 0 && cross(A - C, q - C) > 0;
        EXPECT_NEAR(kern::sdCone(p, cr, ch), inside ? -dist : dist, 1e-4f) << i;
    }
}

TEST(SdfPrimitive, EllipsoidBoundsTheTrueDistanceWithItsSign) {
    Rng rng;
    double worst = 1.0;
    for (int i = 0; i < 300; ++i) {
        const vec3 r = rng.v3(0.2f, 2.5f);
        const vec3 p = rng.v3(-3.5f, 3.5f);
        const double truth = ellipsoidSurfaceDistance(dvec3(p), dvec3(r));
        const bool inside = glm::length(dvec3(p) / dvec3(r)) < 1.0;
        const float d = kern::sdEllipsoid(p, r);
        EXPECT_LE(std::abs(d), truth + 1e-4) << i; // never more than the true distance
        if (truth > 1e-3) EXPECT_EQ(d < 0.0f, inside) << i;
        if (truth > 1e-2) worst = std::min(worst, std::abs(d) / truth);
    }
    // and it is a useful bound, not 0 (recorded: the worst ratio on these draws)
    RecordProperty("worst_ratio_to_true_distance", std::to_string(worst));
    EXPECT_GT(worst, 0.05);
    // exact for a sphere and along an axis
    EXPECT_NEAR(kern::sdEllipsoid(vec3(3, 0, 0), vec3(1.5f)), 1.5f, 1e-6f);
    EXPECT_NEAR(kern::sdEllipsoid(vec3(6, 0, 0), vec3(3, 1, 1)), 3.0f, 1e-6f);
}

TEST(SdfPrimitive, EveryPrimitiveIsOneLipschitz) {
    Rng rng;
    const std::vector<std::function<float(vec3)>> prims = {
        [](vec3 p) { return kern::sdSphere(p, 1.2f); },
        [](vec3 p) { return kern::sdEllipsoid(p, vec3(2.0f, 0.3f, 1.0f)); },
        [](vec3 p) { return kern::sdBox(p, vec3(1.0f, 0.4f, 2.0f)); },
        [](vec3 p) { return kern::sdRoundBox(p, vec3(1.0f, 0.6f, 2.0f), 0.3f); },
        [](vec3 p) { return kern::sdCapsule(p, vec3(-1, 0, 0), vec3(1, 1, 0), 0.4f); },
        [](vec3 p) { return kern::sdTorus(p, 1.5f, 0.3f); },
        [](vec3 p) { return kern::sdCone(p, 1.0f, 2.0f); },
        [](vec3 p) { return kern::sdPlane(p, glm::normalize(vec3(1, 2, 3)), 0.5f); },
    };
    for (size_t k = 0; k < prims.size(); ++k)
        for (int i = 0; i < 20000; ++i) {
            const vec3 p = rng.v3(-3.0f, 3.0f);
            const vec3 q = p + rng.dir() * (i % 2 ? rng.u(1e-3f, 0.05f) : rng.u(0.05f, 3.0f));
            const float dpq = glm::length(p - q);
            ASSERT_LE(std::abs(prims[k](p) - prims[k](q)), dpq * (1.0f + 1e-4f) + 1e-5f)
                << "primitive " << k << " at " << p.x << "," << p.y << "," << p.z;
        }
}

TEST(SdfOperators, SmoothUnionIsBelowBothAndHardFarFromTheSeam) {
    Rng rng;
    for (int i = 0; i < 20000; ++i) {
        const float a = rng.u(-3.0f, 3.0f), b = rng.u(-3.0f, 3.0f), k = rng.u(0.01f, 1.0f);
        const float s = kern::sdfSmoothUnion(a, b, k);
        EXPECT_LE(s, a);
        EXPECT_LE(s, b);
        EXPECT_GE(s, std::min(a, b) - 0.25f * k - 1e-6f); // lowered by at most k / 4
        if (std::abs(a - b) >= k) EXPECT_EQ(s, std::min(a, b));
        EXPECT_GE(kern::sdfSmoothIntersection(a, b, k), std::max(a, b));
        EXPECT_GE(kern::sdfSmoothSubtraction(a, b, k), std::max(a, -b));
    }
    EXPECT_EQ(kern::sdfSmoothUnion(0.3f, -0.2f, 0.0f), -0.2f); // k = 0: the hard union
}

namespace {

/// A tree with every primitive, every operator, smooth blends and transforms (rotations,
/// uniform and non-uniform scale).
SdfNodeDesc testTree(float amplitude = 0.0f) {
    SdfNodeDesc sphere = sdfSphere(0.8f);
    sphere.transform.translate = vec3(-1.0f, 0.2f, 0.0f);
    SdfNodeDesc ell;
    ell.kind = SdfKind::Ellipsoid;
    ell.radii = vec3(1.2f, 0.5f, 0.7f);
    ell.transform.rotate = vec3(20.0f, 35.0f, -10.0f);
    ell.transform.translate = vec3(0.6f, 0.0f, 0.3f);
    SdfNodeDesc box = sdfBox(vec3(0.5f, 0.3f, 0.6f));
    box.transform.translate = vec3(0.0f, 0.6f, 0.0f);
    box.transform.scale = vec3(1.0f, 2.0f, 0.7f); // non-uniform
    SdfNodeDesc rbox;
    rbox.kind = SdfKind::RoundBox;
    rbox.size = vec3(0.4f);
    rbox.rounding = 0.1f;
    rbox.transform.translate = vec3(1.5f, -0.5f, 0.0f);
    SdfNodeDesc cap;
    cap.kind = SdfKind::Capsule;
    cap.radius = 0.25f;
    cap.transform.rotate = vec3(0.0f, 0.0f, 60.0f);
    SdfNodeDesc tor;
    tor.kind = SdfKind::Torus;
    tor.majorRadius = 0.9f;
    tor.minorRadius = 0.2f;
    tor.transform.rotate = vec3(70.0f, 0.0f, 0.0f);
    tor.transform.scale = vec3(1.3f);
    SdfNodeDesc cone;
    cone.kind = SdfKind::Cone;
    cone.radius = 0.6f;
    cone.height = 1.2f;
    cone.transform.translate = vec3(0.0f, -1.5f, 0.5f);
    SdfNodeDesc plane;
    plane.kind = SdfKind::Plane;
    plane.normal = vec3(0.0f, -1.0f, 0.2f);
    plane.offset = 1.2f;
    SdfNodeDesc blob = sdfOp(SdfKind::Union, {sphere, ell, box, rbox}, 0.4f);
    blob.transform.rotate = vec3(0.0f, 15.0f, 0.0f);
    SdfNodeDesc cut = sdfOp(SdfKind::Subtraction, {blob, cap}, 0.1f);
    SdfNodeDesc all = sdfOp(SdfKind::Union, {cut, tor, cone});
    SdfNodeDesc root = sdfOp(SdfKind::Intersection, {all, plane}, 0.2f);
    root.transform.scale = vec3(1.1f, 0.9f, 1.0f);
    root.displacement.amplitude = amplitude;
    root.displacement.frequency = 2.0f;
    root.displacement.octaves = 4;
    return root;
}

} // namespace

TEST(SdfTree, IsOneLipschitzWithTransformsAndSmoothOperators) {
    const SdfTree tree = flattenSdf(testTree());
    ASSERT_EQ(tree.nodes.size(), 12u);
    EXPECT_EQ(tree.displacementBound, 0.0f);
    Rng rng;
    for (int i = 0; i < 50000; ++i) {
        const vec3 p = rng.v3(-3.0f, 3.0f);
        const vec3 q = p + rng.dir() * (i % 2 ? rng.u(1e-3f, 0.05f) : rng.u(0.05f, 3.0f));
        ASSERT_LE(std::abs(tree.bound(p) - tree.bound(q)),
                  glm::length(p - q) * (1.0f + 1e-4f) + 2e-5f);
    }
}

TEST(SdfTree, TransformsMoveAndScaleThePrimitive) {
    SdfNodeDesc s = sdfSphere(1.0f);
    s.transform.translate = vec3(2.0f, 0.0f, 0.0f);
    s.transform.scale = vec3(3.0f);
    const SdfTree t = flattenSdf(s);
    EXPECT_NEAR(t.distance(vec3(2.0f, 5.0f, 0.0f)), 2.0f, 1e-5f); // radius 3 about (2, 0, 0)
    EXPECT_NEAR(t.distance(vec3(2.0f, 0.0f, 0.0f)), -3.0f, 1e-5f);
    // rotation of a box about z by 90 degrees swaps its x and y extents
    SdfNodeDesc b = sdfBox(vec3(2.0f, 0.5f, 0.5f));
    b.transform.rotate = vec3(0.0f, 0.0f, 90.0f);
    const SdfTree tb = flattenSdf(b);
    EXPECT_NEAR(tb.distance(vec3(0.0f, 3.0f, 0.0f)), 1.0f, 1e-5f);
    EXPECT_NEAR(tb.distance(vec3(3.0f, 0.0f, 0.0f)), 2.5f, 1e-5f);
    // a non-uniform scale gives a bound: the smallest scale times the local distance
    SdfNodeDesc e = sdfSphere(1.0f);
    e.transform.scale = vec3(4.0f, 1.0f, 1.0f);
    const SdfTree te = flattenSdf(e);
    EXPECT_NEAR(te.distance(vec3(6.0f, 0.0f, 0.0f)), 0.5f, 1e-5f); // true distance 2
    EXPECT_NEAR(te.distance(vec3(0.0f, 2.0f, 0.0f)), 1.0f, 1e-5f); // exact on the short axis
}

TEST(SdfTree, RejectsTreesItCannotEvaluate) {
    EXPECT_THROW(flattenSdf(sdfOp(SdfKind::Union, {})), std::invalid_argument);
    EXPECT_THROW(flattenSdf(sdfSphere(0.0f)), std::invalid_argument);
    SdfNodeDesc s = sdfSphere(1.0f);
    s.transform.scale = vec3(1.0f, 0.0f, 1.0f);
    EXPECT_THROW(flattenSdf(s), std::invalid_argument);
    SdfNodeDesc deep = sdfSphere(1.0f);
    for (int i = 0; i < kSdfMaxStack + 2; ++i)
        deep = sdfOp(SdfKind::Union, {sdfSphere(1.0f), deep});
    EXPECT_THROW(flattenSdf(deep), std::invalid_argument);
}

namespace {

/// Sphere tracing of the level set `level` of tree.distance() from o along d with the skip
/// distance; returns the hit t, or tmax.
float sphereTrace(const SdfTree& tree, vec3 o, vec3 d, float tmax, float level, int& steps) {
    float t = 0.0f;
    steps = 0;
    while (t < tmax && steps < 100000) {
        const float s = tree.skipDistance(o + t * d, level);
        ++steps;
        if (s < 1e-4f) return t;
        t += s;
    }
    return tmax;
}

/// First t in [0, tmax] where distance() <= level, by dense sampling (step h) from where the ray
/// enters the support box (outside it the distance is above the level: SupportBox... checks it).
float denseFirst(const SdfTree& tree, vec3 o, vec3 d, float tmax, float level, float h) {
    float t0 = 0.0f, t1 = tmax;
    if (!intersectBox(Ray{o, d}, tree.supportBox(level), 0.0f, tmax, t0, t1)) return tmax;
    for (float t = t0; t < t1; t += h)
        if (tree.distance(o + t * d) <= level) return t;
    return tmax;
}

void checkSphereTracing(const SdfTree& tree, int rays) {
    Rng rng;
    long steps = 0;
    int hits = 0;
    for (int i = 0; i < rays; ++i) {
        const vec3 o = rng.dir() * 5.0f;
        const vec3 target = rng.v3(-1.0f, 1.0f);
        const vec3 d = glm::normalize(target - o);
        int n = 0;
        const float tHit = sphereTrace(tree, o, d, 10.0f, 0.0f, n);
        steps += n;
        const float tDense = denseFirst(tree, o, d, 10.0f, 0.0f, 2e-3f);
        hits += tHit < 10.0f;
        // never past the surface: the dense sampling finds no inside point before the hit
        ASSERT_GE(tDense, tHit - 2e-3f) << "ray " << i;
    }
    EXPECT_GT(hits, rays / 4); // the rays do meet the surface
    testing::Test::RecordProperty("mean_steps", std::to_string(double(steps) / rays));
}

} // namespace

TEST(SdfTree, SphereTracingNeverStepsPastTheSurface) {
    checkSphereTracing(flattenSdf(testTree()), 10000);
}

TEST(SdfTree, DisplacementIsFoldedIntoTheSkipDistance) {
    // with noise on, the skip distance steps by bound - A: no displaced density is missed
    const SdfTree tree = flattenSdf(testTree(0.25f));
    EXPECT_NEAR(tree.displacementBound, 0.25f * 0.9f, 1e-6f); // amplitude times min scale
    Rng rng;
    float seen = 0.0f;
    for (int i = 0; i < 200000; ++i) {
        const vec3 p = rng.v3(-3.0f, 3.0f);
        const float diff = std::abs(tree.distance(p) - tree.bound(p));
        ASSERT_LE(diff, tree.displacementBound + 1e-5f);
        seen = std::max(seen, diff);
    }
    EXPECT_GT(seen, 0.5f * tree.displacementBound); // the noise does reach near its bound
    checkSphereTracing(tree, 10000);
}

TEST(SdfTree, SupportBoxHoldsEveryPointAtOrBelowTheLevel) {
    for (float amp : {0.0f, 0.25f}) {
        SdfNodeDesc d = testTree(amp);
        d.children.pop_back(); // drop the plane: bounded
        d.kind = SdfKind::Union;
        const SdfTree tree = flattenSdf(d);
        for (float level : {0.0f, 0.3f}) {
            const Box b = tree.supportBox(level);
            ASSERT_TRUE(sdfBoxBounded(b));
            Rng rng;
            int inside = 0;
            for (int i = 0; i < 200000; ++i) {
                const vec3 p = rng.v3(-5.0f, 5.0f);
                if (tree.distance(p) > level) continue;
                ++inside;
                ASSERT_TRUE(b.contains(p)) << p.x << "," << p.y << "," << p.z;
            }
            EXPECT_GT(inside, 100);
        }
    }
    // an unintersected plane is unbounded
    SdfNodeDesc plane;
    plane.kind = SdfKind::Plane;
    EXPECT_FALSE(sdfBoxBounded(flattenSdf(plane).supportBox(0.0f)));
}
