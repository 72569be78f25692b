// sdf_tree.glsl: one node of a flattened SDF tree (core/sdf/sdf.h, SdfTree) evaluated on a value
// stack, the body of SdfTree::evaluate written once for the C++ build and the GLSL port. The
// tree is a postfix array (children before their parent, root last): a primitive pushes its
// value, an operator pops its childCount children, folds them left to right with its (smooth)
// CSG operator and pushes the result; either may then add its noise displacement. The loop over
// the nodes is the caller's (SdfTree::evaluate over SdfTree::gpuNodes on the CPU, rtSdfDistance
// in plugin/realtime/march_data.glsl over a shader storage buffer): GLSL cannot pass a buffer's
// array to a function.
//
// SdfTreeNode is the node as a GPU uploads it: std430 and C++ agree on its layout (vec4 members
// first, then 4-byte scalars, 144 bytes; static_asserts in core/sdf/sdf.cpp).

// Node kinds (values = the SdfKind enum of core/sdf/sdf.h; checked in core/kernels/enum_mirrors.h).
const int SDF_KIND_SPHERE = 0;
const int SDF_KIND_ELLIPSOID = 1;
const int SDF_KIND_BOX = 2;
const int SDF_KIND_ROUND_BOX = 3;
const int SDF_KIND_CAPSULE = 4;
const int SDF_KIND_TORUS = 5;
const int SDF_KIND_CONE = 6;
const int SDF_KIND_PLANE = 7;
const int SDF_KIND_UNION = 8;
const int SDF_KIND_INTERSECTION = 9;
const int SDF_KIND_SUBTRACTION = 10;

// The deepest value stack a tree may need (kSdfMaxStack; flattenSdf refuses deeper trees).
const int SDF_MAX_STACK = 64;

struct SdfTreeNode {
    vec4 col0;        // localFromWorld, column 0 (w 0)
    vec4 col1;        // column 1
    vec4 col2;        // column 2
    vec4 localOffset; // local = localFromWorld * p + localOffset (w 0)
    vec4 p0;          // primitive parameters, local units (SdfNode::p0)
    vec4 p1;
    int kind;       // SDF_KIND_*
    int childCount; // operators: the last childCount values on the stack
    float factor;   // value in tree units = factor * value in local units
    float k;        // operators: blend width in tree units
    float amplitude; // displacement in tree units (0: none)
    int noiseKind;   // SDF_NOISE_*
    float frequency; // per local unit
    int octaves;
    float gain;
    uint seed;
    int pad0;
    int pad1;
};

struct SdfTreeStack {
    float v[SDF_MAX_STACK];
    int sp;
};

// A primitive's value at local point q, local units.
NB_FN float sdfTreePrimitive(IN(SdfTreeNode) n, vec3 q) {
    vec3 a = vec3(n.p0.x, n.p0.y, n.p0.z);
    if (n.kind == SDF_KIND_SPHERE) return sdSphere(q, n.p0.x);
    if (n.kind == SDF_KIND_ELLIPSOID) return sdEllipsoid(q, a);
    if (n.kind == SDF_KIND_BOX) return sdBox(q, a);
    if (n.kind == SDF_KIND_ROUND_BOX) return sdRoundBox(q, a, n.p0.w);
    if (n.kind == SDF_KIND_CAPSULE)
        return sdCapsule(q, a, vec3(n.p1.x, n.p1.y, n.p1.z), n.p0.w);
    if (n.kind == SDF_KIND_TORUS) return sdTorus(q, n.p0.x, n.p0.y);
    if (n.kind == SDF_KIND_CONE) return sdCone(q, n.p0.x, n.p0.y);
    if (n.kind == SDF_KIND_PLANE) return sdPlane(q, a, n.p0.w);
    return 0.0f;
}

// An operator's fold step: the value so far a with the next child's value b.
NB_FN float sdfTreeCombine(int op, float a, float b, float k) {
    if (op == SDF_KIND_UNION) return sdfSmoothUnion(a, b, k);
    if (op == SDF_KIND_INTERSECTION) return sdfSmoothIntersection(a, b, k);
    if (op == SDF_KIND_SUBTRACTION) return sdfSmoothSubtraction(a, b, k);
    return a;
}

// Node n at world point p: pushes its value (with its displacement when `displaced`). After the
// last node, s.v[0] is the tree's value (SdfTree::distance, or ::bound when not displaced).
NB_FN void sdfTreeStep(IN(SdfTreeNode) n, vec3 p, bool displaced, INOUT(SdfTreeStack) s) {
    // localFromWorld * p + localOffset, in glm's order: ((c0 p.x + c1 p.y) + c2 p.z) + offset
    vec3 q = vec3(n.col0.x, n.col0.y, n.col0.z) * p.x + vec3(n.col1.x, n.col1.y, n.col1.z) * p.y +
             vec3(n.col2.x, n.col2.y, n.col2.z) * p.z +
             vec3(n.localOffset.x, n.localOffset.y, n.localOffset.z);
    float v;
    if (n.kind < SDF_KIND_UNION) {
        v = n.factor * sdfTreePrimitive(n, q);
    } else {
        s.sp -= n.childCount;
        v = s.v[s.sp];
        for (int i = 1; i < n.childCount; i++) v = sdfTreeCombine(n.kind, v, s.v[s.sp + i], n.k);
    }
    if (displaced && n.amplitude > 0.0f)
        v += n.amplitude * sdfNoise(q, n.noiseKind, n.frequency, n.octaves, n.gain, n.seed);
    s.v[s.sp] = v;
    s.sp += 1;
}
