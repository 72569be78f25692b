// dda.glsl: the cell walk of a 3D DDA over a regular grid (Amanatides & Woo 1987), as the
// majorant iterator (core/tracking/majorant.cpp) takes it: the cell holding a coordinate, where a
// ray meets a grid plane, and which axis the ray crosses next.

// The cell index holding coordinate x along an axis whose grid starts at lo with cells of size
// `cell` (unclamped).
NB_FN int ddaCell(float x, float lo, float cell) { return int(floor((x - lo) / cell)); }

// Ray parameter where the ray (origin o, direction d along the axis) meets grid plane `edge`.
NB_FN float ddaEdgeT(float lo, int edge, float cell, float o, float d) {
    return (lo + float(edge) * cell - o) / d;
}

// The axis whose next plane the ray meets first (ties: z over x, z over y, y over x).
NB_FN int ddaAxis(vec3 tNext) {
    return tNext.x < tNext.y ? (tNext.x < tNext.z ? 0 : 2) : (tNext.y < tNext.z ? 1 : 2);
}
