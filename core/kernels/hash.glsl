// hash.glsl: integer hashing, bit-exact in C++ and GLSL.
// pcg3d and pcg after Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 9(3), 2020.

NB_FN uvec3 pcg3d(uvec3 v) {
    v = v * 1664525u + uvec3(1013904223u);
    v.x += v.y * v.z;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v = v ^ (v >> uvec3(16u));
    v.x += v.y * v.z;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    return v;
}

NB_FN uint pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform float in [0, 1) from the top 24 bits of a hash.
NB_FN float hashToUnit(uint h) { return float(h >> 8u) * (1.0f / 16777216.0f); }

NB_FN vec3 hashToUnit3(uvec3 h) {
    return vec3(float(h.x >> 8u), float(h.y >> 8u), float(h.z >> 8u)) * (1.0f / 16777216.0f);
}

// Floor-modulo for lattice wrapping (GLSL leaves % of negative ints undefined).
NB_FN int wrapLattice(int a, int period) {
    return a - period * int(floor(float(a) / float(period)));
}

NB_FN ivec3 wrapLattice3(ivec3 c, int period) {
    return ivec3(wrapLattice(c.x, period), wrapLattice(c.y, period), wrapLattice(c.z, period));
}

NB_FN uvec3 latticeHash3(ivec3 c, int period, uint seed) {
    ivec3 w = wrapLattice3(c, period);
    return pcg3d(uvec3(uint(w.x), uint(w.y), uint(w.z)) + uvec3(seed, seed * 7u, seed * 13u));
}
