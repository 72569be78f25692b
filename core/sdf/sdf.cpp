#include "core/sdf/sdf.h"

#include <algorithm>
#include <cstddef>
#include <cmath>
#include <stdexcept>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "core/kernels/kernels.h"

namespace nimbus {

const char* sdfKindName(SdfKind k) {
    switch (k) {
    case SdfKind::Sphere:
        return "sphere";
    case SdfKind::Ellipsoid:
        return "ellipsoid";
    case SdfKind::Box:
        return "box";
    case SdfKind::RoundBox:
        return "round_box";
    case SdfKind::Capsule:
        return "capsule";
    case SdfKind::Torus:
        return "torus";
    case SdfKind::Cone:
        return "cone";
    case SdfKind::Plane:
        return "plane";
    case SdfKind::Union:
        return "union";
    case SdfKind::Intersection:
        return "intersection";
    case SdfKind::Subtraction:
        return "subtraction";
    }
    return "?";
}

SdfNodeDesc sdfSphere(float radius) {
    SdfNodeDesc d;
    d.kind = SdfKind::Sphere;
    d.radius = radius;
    return d;
}

SdfNodeDesc sdfBox(vec3 halfExtents) {
    SdfNodeDesc d;
    d.kind = SdfKind::Box;
    d.size = halfExtents;
    return d;
}

SdfNodeDesc sdfOp(SdfKind op, std::vector<SdfNodeDesc> children, float smooth) {
    SdfNodeDesc d;
    d.kind = op;
    d.smooth = smooth;
    d.children = std::move(children);
    return d;
}

namespace {

[[noreturn]] void fail(const SdfNodeDesc& d, const std::string& what) {
    throw std::invalid_argument(std::string(sdfKindName(d.kind)) + ": " + what);
}

bool positive(float x) {
    return std::isfinite(x) && x > 0.0f;
}
bool positive(vec3 v) {
    return positive(v.x) && positive(v.y) && positive(v.z);
}
bool finite(vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

/// Checks a primitive's parameters and packs them into p0, p1 (local units).
void packPrimitive(const SdfNodeDesc& d, SdfNode& n) {
    switch (d.kind) {
    case SdfKind::Sphere:
        if (!positive(d.radius)) fail(d, "radius must be > 0");
        n.p0 = vec4(d.radius, 0.0f, 0.0f, 0.0f);
        break;
    case SdfKind::Ellipsoid:
        if (!positive(d.radii)) fail(d, "radii must all be > 0");
        n.p0 = vec4(d.radii, 0.0f);
        break;
    case SdfKind::Box:
        if (!positive(d.size)) fail(d, "size (half-extents) must all be > 0");
        n.p0 = vec4(d.size, 0.0f);
        break;
    case SdfKind::RoundBox:
        if (!positive(d.size)) fail(d, "size (half-extents) must all be > 0");
        if (!(d.rounding >= 0.0f && d.rounding <= minComponent(d.size)))
            fail(d, "rounding must be in [0, smallest half-extent]");
        n.p0 = vec4(d.size, d.rounding);
        break;
    case SdfKind::Capsule:
        if (!positive(d.radius)) fail(d, "radius must be > 0");
        if (!finite(d.a) || !finite(d.b)) fail(d, "a and b must be finite");
        n.p0 = vec4(d.a, d.radius);
        n.p1 = vec4(d.b, 0.0f);
        break;
    case SdfKind::Torus:
        if (!positive(d.majorRadius) || !positive(d.minorRadius) || d.minorRadius > d.majorRadius)
            fail(d, "needs major_radius >= minor_radius > 0");
        n.p0 = vec4(d.majorRadius, d.minorRadius, 0.0f, 0.0f);
        break;
    case SdfKind::Cone:
        if (!positive(d.radius) || !positive(d.height)) fail(d, "radius and height must be > 0");
        n.p0 = vec4(d.radius, d.height, 0.0f, 0.0f);
        break;
    case SdfKind::Plane: {
        const float len = glm::length(d.normal);
        if (!positive(len) || !std::isfinite(d.offset))
            fail(d, "normal must be non-zero and offset finite");
        n.p0 = vec4(d.normal / len, d.offset);
        break;
    }
    default:
        break;
    }
}

struct Flattener {
    SdfTree& tree;

    /// Appends the subtree of d; returns its index and sets the stack it needs.
    int add(const SdfNodeDesc& d, const glm::mat4& localFromWorldParent, float factorParent,
            int depth, int& need) {
        if (depth > kSdfMaxStack)
            fail(d, "tree nested deeper than " + std::to_string(kSdfMaxStack));
        const SdfTransform& x = d.transform;
        if (!positive(x.scale)) fail(d, "scale must be > 0 on every axis");
        if (!finite(x.translate) || !finite(x.rotate)) fail(d, "transform must be finite");
        glm::mat4 parentFromLocal = glm::translate(glm::mat4(1.0f), x.translate);
        parentFromLocal = glm::rotate(parentFromLocal, glm::radians(x.rotate.z), vec3(0, 0, 1));
        parentFromLocal = glm::rotate(parentFromLocal, glm::radians(x.rotate.y), vec3(0, 1, 0));
        parentFromLocal = glm::rotate(parentFromLocal, glm::radians(x.rotate.x), vec3(1, 0, 0));
        parentFromLocal = glm::scale(parentFromLocal, x.scale);
        const glm::mat4 localFromWorld = glm::inverse(parentFromLocal) * localFromWorldParent;
        const float factor = factorParent * minComponent(x.scale);
        const SdfDisplacement& disp = d.displacement;
        if (!(disp.amplitude >= 0.0f) || !std::isfinite(disp.amplitude))
            fail(d, "displacement amplitude must be >= 0");
        if (disp.amplitude > 0.0f &&
            (!positive(disp.frequency) || disp.octaves < 1 || disp.octaves > 12 ||
             !(disp.gain > 0.0f && disp.gain <= 1.0f)))
            fail(d, "displacement needs frequency > 0, octaves in [1, 12], gain in (0, 1]");
        if (!(d.smooth >= 0.0f) || !std::isfinite(d.smooth)) fail(d, "smooth must be >= 0");

        int childCount = 0;
        std::vector<int> childRoots;
        need = 1;
        if (!sdfIsPrimitive(d.kind)) {
            if (d.children.empty()) fail(d, "an operator needs at least one child");
            for (const SdfNodeDesc& c : d.children) {
                int childNeed = 0;
                childRoots.push_back(add(c, localFromWorld, factor, depth + 1, childNeed));
                need = std::max(need, childCount + childNeed);
                ++childCount;
            }
            if (need > kSdfMaxStack)
                fail(d, "tree needs more than " + std::to_string(kSdfMaxStack) + " stack values");
        }
        SdfNode n;
        n.kind = d.kind;
        n.childCount = childCount;
        n.localFromWorld = glm::mat3(localFromWorld);
        n.localOffset = vec3(localFromWorld[3]);
        n.factor = factor;
        n.k = d.smooth * factor;
        n.amplitude = disp.amplitude * factor;
        n.noise = int(disp.noise);
        n.frequency = disp.frequency;
        n.octaves = disp.octaves;
        n.gain = disp.gain;
        n.seed = disp.seed;
        packPrimitive(d, n);
        const int index = int(tree.nodes.size());
        for (int c : childRoots) tree.nodes[size_t(c)].parent = index;
        tree.nodes.push_back(n);
        return index;
    }
};

/// Box of {value <= 0} of a primitive in its local space.
Box primitiveBox(const SdfNode& n) {
    const vec3 p0(n.p0);
    switch (n.kind) {
    case SdfKind::Sphere:
        return Box{vec3(-n.p0.x), vec3(n.p0.x)};
    case SdfKind::Ellipsoid:
    case SdfKind::Box:
    case SdfKind::RoundBox:
        return Box{-p0, p0};
    case SdfKind::Capsule: {
        const vec3 b(n.p1);
        return Box{glm::min(p0, b) - vec3(n.p0.w), glm::max(p0, b) + vec3(n.p0.w)};
    }
    case SdfKind::Torus: {
        const float R = n.p0.x + n.p0.y;
        return Box{vec3(-R, -n.p0.y, -R), vec3(R, n.p0.y, R)};
    }
    case SdfKind::Cone:
        return Box{vec3(-n.p0.x, 0.0f, -n.p0.x), vec3(n.p0.x, n.p0.y, n.p0.x)};
    default:
        return Box{vec3(-kSdfUnbounded), vec3(kSdfUnbounded)};
    }
}

Box clampBox(Box b) {
    b.lo = glm::max(b.lo, vec3(-kSdfUnbounded));
    b.hi = glm::min(b.hi, vec3(kSdfUnbounded));
    return b;
}

/// World box around the image of a local box through p = worldFromLocal(q).
Box imageBox(const glm::mat3& m, vec3 t, const Box& b) {
    if (!sdfBoxBounded(b)) return Box{vec3(-kSdfUnbounded), vec3(kSdfUnbounded)};
    Box r{vec3(kSdfUnbounded), vec3(-kSdfUnbounded)};
    for (int k = 0; k < 8; ++k) {
        const vec3 c(k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y, k & 4 ? b.hi.z : b.lo.z);
        const vec3 w = m * c + t;
        r.lo = glm::min(r.lo, w);
        r.hi = glm::max(r.hi, w);
    }
    return r;
}

} // namespace

// the layout the GLSL port's std430 buffer has: vec4s at multiples of 16, then the scalars
static_assert(sizeof(kern::SdfTreeNode) == 144);
static_assert(offsetof(kern::SdfTreeNode, p1) == 80);
static_assert(offsetof(kern::SdfTreeNode, kind) == 96);
static_assert(offsetof(kern::SdfTreeNode, seed) == 132);

kern::SdfTreeNode sdfTreeNode(const SdfNode& n) {
    kern::SdfTreeNode g{};
    g.col0 = vec4(n.localFromWorld[0], 0.0f);
    g.col1 = vec4(n.localFromWorld[1], 0.0f);
    g.col2 = vec4(n.localFromWorld[2], 0.0f);
    g.localOffset = vec4(n.localOffset, 0.0f);
    g.p0 = n.p0;
    g.p1 = n.p1;
    g.kind = int(n.kind);
    g.childCount = n.childCount;
    g.factor = n.factor;
    g.k = n.k;
    g.amplitude = n.amplitude;
    g.noiseKind = n.noise;
    g.frequency = n.frequency;
    g.octaves = n.octaves;
    g.gain = n.gain;
    g.seed = n.seed;
    return g;
}

SdfTree flattenSdf(const SdfNodeDesc& root) {
    SdfTree tree;
    Flattener f{tree};
    int need = 0;
    f.add(root, glm::mat4(1.0f), 1.0f, 0, need);
    tree.stackDepth = need;
    tree.gpuNodes.reserve(tree.nodes.size());
    for (const SdfNode& n : tree.nodes) tree.gpuNodes.push_back(sdfTreeNode(n));
    // the displacement bound: the largest sum of amplitudes along a root-to-leaf path
    std::vector<float> pathSum(tree.nodes.size(), 0.0f);
    for (size_t i = tree.nodes.size(); i-- > 0;) {
        const SdfNode& n = tree.nodes[i];
        pathSum[i] = n.amplitude + (n.parent >= 0 ? pathSum[size_t(n.parent)] : 0.0f);
        tree.displacementBound = std::max(tree.displacementBound, pathSum[i]);
    }
    return tree;
}

float SdfTree::evaluate(vec3 p, bool displaced) const {
    if (gpuNodes.empty()) return kSdfUnbounded;
    kern::SdfTreeStack stack;
    stack.sp = 0;
    for (const kern::SdfTreeNode& n : gpuNodes) kern::sdfTreeStep(n, p, displaced, stack);
    return stack.v[0];
}

float SdfTree::skipDistance(vec3 p, float level) const {
    return kern::sdfSkipDistance(bound(p), displacementBound, level);
}

Box SdfTree::supportBox(float level) const {
    if (nodes.empty()) return Box{};
    const size_t n = nodes.size();
    // top-down: the level each node's own (undisplaced) value must reach for the root to reach
    // `level` (a displacement lowers by at most A, a smooth union by at most k / 4)
    std::vector<float> inner(n, 0.0f);
    for (size_t i = n; i-- > 0;) {
        const SdfNode& node = nodes[i];
        const float asked =
            node.parent >= 0
                ? inner[size_t(node.parent)] + (nodes[size_t(node.parent)].kind == SdfKind::Union
                                                    ? 0.25f * nodes[size_t(node.parent)].k
                                                    : 0.0f)
                : level;
        inner[i] = asked + node.amplitude;
    }
    // bottom-up: boxes on a stack, like evaluate()
    std::vector<Box> stack;
    stack.reserve(size_t(stackDepth));
    for (size_t i = 0; i < n; ++i) {
        const SdfNode& node = nodes[i];
        Box b;
        if (sdfIsPrimitive(node.kind)) {
            const float grow = std::max(inner[i], 0.0f) / node.factor;
            Box local = primitiveBox(node);
            if (sdfBoxBounded(local)) {
                local.lo -= vec3(grow);
                local.hi += vec3(grow);
            }
            const glm::mat3 worldFromLocal = glm::inverse(node.localFromWorld);
            b = imageBox(worldFromLocal, -(worldFromLocal * node.localOffset), local);
        } else {
            const size_t first = stack.size() - size_t(node.childCount);
            b = stack[first];
            for (size_t c = first + 1; c < stack.size(); ++c) {
                const Box& o = stack[c];
                if (node.kind == SdfKind::Union) {
                    b.lo = glm::min(b.lo, o.lo);
                    b.hi = glm::max(b.hi, o.hi);
                } else if (node.kind == SdfKind::Intersection) {
                    b.lo = glm::max(b.lo, o.lo);
                    b.hi = glm::min(b.hi, o.hi);
                }
                // subtraction: inside the first child
            }
            stack.resize(first);
        }
        stack.push_back(clampBox(b));
    }
    Box r = stack.back();
    if (r.lo.x > r.hi.x || r.lo.y > r.hi.y || r.lo.z > r.hi.z) return Box{};
    return r;
}

} // namespace nimbus
