/// @file sdf.h
/// @brief Trees of signed distance functions (SDFs): primitives combined by (smooth) CSG, each
/// node with its own domain transform and optional noise displacement, flattened into an array
/// that is evaluated without recursion or virtual calls (ready to upload to a GPU). Thomann
/// 2020, ch. 3-4; the primitives and operators are the kernels of core/kernels/sdf.glsl.
///
/// The bound story (what sphere tracing and the majorants rely on):
/// - Every primitive kernel is 1-Lipschitz (exact distances, the ellipsoid a bound); min, max,
///   negation and the polynomial smooth min/max are 1-Lipschitz in the sup norm of their inputs,
///   so a tree WITHOUT displacement is a 1-Lipschitz function: SdfTree::bound(p).
/// - Domain transforms: local = S^-1 R^T (p - t). Rotation and translation keep distances; a
///   scale s multiplies local distances by s, so a node's value in parent units is
///   s * child(local). With a NON-uniform scale the map p -> local is (1 / min(s))-Lipschitz, so
///   the value is multiplied by min(s) (a bound, no longer a distance): the Lipschitz constant
///   stays 1 and the value never exceeds the true distance. Factors multiply down the tree.
/// - Displacement: a node may add A * n(local p), n a noise in [-1, 1] (sdfNoise), A in the node's
///   units (scaled like its value). Through the 1-Lipschitz operators an error of A in a child is
///   at most A in its parent, so |distance(p) - bound(p)| <= displacementBound (the largest sum
///   of amplitudes along a root-to-leaf path). Hence every q within
///   bound(p) - displacementBound - c of p has distance(q) > c: sphere tracing the UNDISPLACED
///   bound and stepping by that never misses the displaced level set c (sdfSkipDistance).
/// - supportBox(c): a box holding every p with distance(p) <= c (per node: the primitive's box
///   grown by c, unions of boxes, intersections of boxes, the first child's box for a
///   subtraction; a smooth union lowers the value by at most k / 4 and a displacement by at
///   most A, so those raise the level their children are asked for).
///
/// @code
///   SdfNodeDesc a = sdfSphere(1.0f), b = sdfBox(vec3(0.5f));
///   b.transform.translate = vec3(1, 0, 0);
///   SdfNodeDesc u = sdfOp(SdfKind::Union, {a, b}, 0.3f); // smooth union, k = 0.3
///   SdfTree tree = flattenSdf(u);
///   float d = tree.distance(p);
/// @endcode
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "core/geometry.h"
#include "core/kernels/kernels.h"

namespace nimbus {

/// Primitives first, then operators (a node with children).
enum class SdfKind {
    Sphere,    ///< radius
    Ellipsoid, ///< radii (a bound, see sdEllipsoid)
    Box,       ///< size (half-extents)
    RoundBox,  ///< size (half-extents), rounding
    Capsule,   ///< a, b (segment ends), radius
    Torus,     ///< major radius (ring, xz plane), minor radius (tube)
    Cone,      ///< radius (base disc at y = 0), height (apex at y = height)
    Plane,     ///< normal (unit), offset: the half-space dot(p, normal) < offset
    Union,
    Intersection,
    Subtraction ///< first child minus all others
};

inline bool sdfIsPrimitive(SdfKind k) {
    return k < SdfKind::Union;
}
/// Scene-file names ("sphere", ..., "union", "intersection", "subtraction").
const char* sdfKindName(SdfKind k);

enum class SdfNoise { Perlin = 0, Worley = 1 }; ///< values = SDF_NOISE_* in sdf.glsl

/// parent-from-local = translate * Rz * Ry * Rx * scale (the convention of [[instance]]).
struct SdfTransform {
    vec3 translate{0.0f};
    vec3 rotate{0.0f}; ///< degrees about x, then y, then z
    vec3 scale{1.0f};  ///< all > 0; non-uniform: values multiplied by the smallest (see above)
};

/// distance += amplitude * sdfNoise(local p, noise, frequency, octaves, gain, seed).
struct SdfDisplacement {
    float amplitude = 0.0f; ///< node units; 0: none
    SdfNoise noise = SdfNoise::Perlin;
    float frequency = 1.0f; ///< noise cells per node unit
    int octaves = 3;
    float gain = 0.5f;
    std::uint32_t seed = 1;
};

/// One node of an SDF tree as a person writes it (a scene file, a test).
struct SdfNodeDesc {
    SdfKind kind = SdfKind::Sphere;
    float radius = 1.0f;           ///< sphere, capsule, cone (base)
    vec3 radii{1.0f};              ///< ellipsoid
    vec3 size{1.0f};               ///< box, round box: half-extents
    float rounding = 0.0f;         ///< round box
    vec3 a{0.0f, -0.5f, 0.0f};     ///< capsule
    vec3 b{0.0f, 0.5f, 0.0f};      ///< capsule
    float majorRadius = 1.0f;      ///< torus
    float minorRadius = 0.25f;     ///< torus
    float height = 1.0f;           ///< cone
    vec3 normal{0.0f, 1.0f, 0.0f}; ///< plane (normalised by flattenSdf)
    float offset = 0.0f;           ///< plane
    float smooth = 0.0f;           ///< operators: blend width k (node units); 0 = hard
    SdfTransform transform;
    SdfDisplacement displacement;
    std::vector<SdfNodeDesc> children; ///< operators: at least one
};

SdfNodeDesc sdfSphere(float radius);
SdfNodeDesc sdfBox(vec3 halfExtents);
SdfNodeDesc sdfOp(SdfKind op, std::vector<SdfNodeDesc> children, float smooth = 0.0f);

/// One node of the flat array (postfix order: children before their parent, root last). All in
/// plain data: a GPU port uploads the array as is.
struct SdfNode {
    SdfKind kind = SdfKind::Sphere;
    int childCount = 0;             ///< operators: the last childCount values on the stack
    int parent = -1;                ///< index of the parent, -1 for the root
    glm::mat3 localFromWorld{1.0f}; ///< local = localFromWorld * p + localOffset
    vec3 localOffset{0.0f};
    float factor = 1.0f;     ///< value in tree units = factor * value in local units
    vec4 p0{0.0f}, p1{0.0f}; ///< primitive parameters, local units (see evaluate)
    float k = 0.0f;          ///< operators: blend width in tree units
    float amplitude = 0.0f;  ///< displacement in tree units
    int noise = 0;           ///< SDF_NOISE_*
    float frequency = 1.0f;  ///< per local unit
    int octaves = 3;
    float gain = 0.5f;
    std::uint32_t seed = 1;
};

/// Deepest value stack an SdfTree may need (flattenSdf refuses deeper trees).
constexpr int kSdfMaxStack = 64;
static_assert(kSdfMaxStack == kern::SDF_MAX_STACK);

/// The node in the kernel's layout (kern::SdfTreeNode): the columns of localFromWorld, the
/// offset, the parameters; what SdfTree::gpuNodes holds.
kern::SdfTreeNode sdfTreeNode(const SdfNode& n);

struct SdfTree {
    std::vector<SdfNode> nodes; ///< postfix, root last; empty: no surface (distance = +inf)
    /// The same nodes in the kernel's layout (core/kernels/sdf_tree.glsl, std430): what
    /// evaluate() walks with kern::sdfTreeStep and what the GLSL port uploads as is.
    std::vector<kern::SdfTreeNode> gpuNodes;
    float displacementBound = 0.0f; ///< |distance(p) - bound(p)| <= this, everywhere
    int stackDepth = 0;

    /// The signed distance (a bound, see the file comment) with displacement.
    float distance(vec3 p) const { return evaluate(p, true); }
    /// The same without displacement: 1-Lipschitz, within displacementBound of distance().
    float bound(vec3 p) const { return evaluate(p, false); }
    /// A box holding every p with distance(p) <= level (level >= 0 is the useful case);
    /// components of +-1e30 where the tree is unbounded (a plane not intersected away).
    Box supportBox(float level) const;
    /// How far sphere tracing may step from p without passing the level set `level` of
    /// distance() (sdfSkipDistance of bound(p)); <= 0: no safe step.
    float skipDistance(vec3 p, float level) const;

    float evaluate(vec3 p, bool displaced) const;
};

/// Flattens a tree (children before parents). Throws std::invalid_argument with a message for a
/// tree it cannot evaluate: an operator without children, a non-positive scale, a primitive
/// parameter out of range, a zero plane normal, a tree deeper than kSdfMaxStack.
SdfTree flattenSdf(const SdfNodeDesc& root);

/// Unbounded extents in supportBox().
constexpr float kSdfUnbounded = 1e30f;
inline bool sdfBoxBounded(const Box& b) {
    return maxComponent(glm::abs(b.lo)) < 0.5f * kSdfUnbounded &&
           maxComponent(glm::abs(b.hi)) < 0.5f * kSdfUnbounded;
}

} // namespace nimbus
