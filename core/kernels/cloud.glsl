// cloud.glsl: cloud shaping after Olajos 2016, ch. 2 ("Real-time rendering of volumetric
// clouds"): a height distribution HD(h) = (1 - e^{-a h}) e^{-b h} gives flat bases and slowly
// thinning tops; Gaussian towers (truncated bivariate normal peaks, one per hashed cell) set how
// high each column reaches; noise carves the shape, thresholded with a soft edge and eroded by
// finer octaves. Pure math: the noise values come in as arguments, so the same shaping serves
// direct evaluation, baked noise volumes and conservative bounds.

struct CloudLayer {
    float bottom;           // world altitude (y) of the layer base
    float top;              // world altitude of the layer top
    float heightA;          // HD rise rate a (large: flat base)
    float heightB;          // HD decay rate b
    float coverage;         // in [0,1]: threshold is 1 - coverage
    float softness;         // width of the soft edge above the threshold
    float erosion;          // in [0,1): how much the detail noise eats the edges
    float towerSpacing;     // size of the hashed cells holding at most one tower each
    float towerRadiusMin;   // footprint radius (3 sigma) range
    float towerRadiusMax;
    float towerHeightMin;   // column height range, as a fraction of the layer
    float towerHeightMax;
    float towerProbability; // chance that a cell holds a tower
    float towerAnisotropy;  // 0: round footprints; up to 0.9: elongated
    uint seed;
};

const float CLOUD_TRUNC = 0.011108996538f; // e^{-4.5}: the Gaussian is cut at 3 sigma
const int CLOUD_TOWER_PERIOD = 1048576;    // towers do not repeat in practice

NB_FN float heightDistribution(float h, float a, float b) {
    return (1.0f - exp(-a * h)) * exp(-b * h);
}

// argmax of HD: d/dh HD = 0 at h* = ln((a + b) / b) / a.
NB_FN float heightDistributionPeak(float a, float b) { return log((a + b) / b) / a; }

// HD normalised to a peak of 1; zero outside (0, 1).
NB_FN float heightProfile(float h, float a, float b) {
    if (h <= 0.0f || h >= 1.0f) return 0.0f;
    return heightDistribution(h, a, b) / heightDistribution(heightDistributionPeak(a, b), a, b);
}

// Maximum of heightProfile over [h0, h1]; HD is unimodal so the max sits at the clamped peak.
NB_FN float heightProfileMax(float h0, float h1, float a, float b) {
    if (h1 <= 0.0f || h0 >= 1.0f) return 0.0f;
    float hp = clamp(heightDistributionPeak(a, b), max(h0, 1e-6f), min(h1, 1.0f - 1e-6f));
    return heightProfile(hp, a, b);
}

struct Tower {
    vec2 center;
    float sigmaX;  // std deviation along the rotated x axis
    float sigmaZ;
    float cosA;    // rotation of the footprint
    float sinA;
    float height;  // column height as a fraction of the layer
    bool present;
};

// The footprint of tower (i, j) from its first hash draw u0: its centre, and its larger
// standard deviation sigmaX (r / 3; sigmaZ is at most that).
NB_FN vec2 towerCenter(IN(CloudLayer) L, int i, int j, vec3 u0) {
    return vec2((float(i) + u0.x) * L.towerSpacing, (float(j) + u0.y) * L.towerSpacing);
}
NB_FN float towerSigmaX(IN(CloudLayer) L, vec3 u0) {
    return mix(L.towerRadiusMin, L.towerRadiusMax, u0.z) / 3.0f;
}

// Tower (i, j) from its first hash draw h0 (towerEnvelope has it already for its reach test).
NB_FN Tower cloudTowerFromDraw(IN(CloudLayer) L, int i, int j, uvec3 h0) {
    uvec3 h1 = latticeHash3(ivec3(i, j, 1), CLOUD_TOWER_PERIOD, L.seed);
    vec3 u0 = hashToUnit3(h0);
    vec3 u1 = hashToUnit3(h1);
    Tower t;
    t.present = hashToUnit(pcg(h0.x ^ h1.y)) < L.towerProbability;
    t.center = towerCenter(L, i, j, u0);
    t.sigmaX = towerSigmaX(L, u0);
    t.sigmaZ = t.sigmaX * (1.0f - L.towerAnisotropy * u1.x);
    float angle = 6.28318530718f * u1.y;
    t.cosA = cos(angle);
    t.sinA = sin(angle);
    // larger towers grow taller: blend the size draw into the height draw
    t.height = mix(L.towerHeightMin, L.towerHeightMax, mix(u1.z, u0.z, 0.6f));
    return t;
}

NB_FN Tower cloudTower(IN(CloudLayer) L, int i, int j) {
    return cloudTowerFromDraw(L, i, j, latticeHash3(ivec3(i, j, 0), CLOUD_TOWER_PERIOD, L.seed));
}

// Truncated Gaussian from the Mahalanobis distance squared q: 1 at q = 0, 0 from q = 9 on.
NB_FN float truncatedGaussian(float q) {
    return max(0.0f, (exp(-0.5f * q) - CLOUD_TRUNC) / (1.0f - CLOUD_TRUNC));
}

// Vertical envelope in [0, 1] for a point at layer height fraction h under a column of height
// towerH (both fractions of the layer): HD of the height within the column, rounded off toward
// the column top by (1 - hn^4) so towers end in domes rather than flat lids.
NB_FN float cloudEnvelope(IN(CloudLayer) L, float h, float towerH) {
    if (towerH <= 1e-4f) return 0.0f;
    float hn = h / towerH;
    float hn2 = hn * hn;
    return heightProfile(hn, L.heightA, L.heightB) * max(0.0f, 1.0f - hn2 * hn2);
}

// Upper bound of cloudEnvelope for h in [h0, h1] and a column height of at most towerHMax.
// hn = h / towerH is smallest for the tallest column; both factors are bounded separately over
// hn in [h0 / towerHMax, 1): the profile by its max there, the rounding by its value at the low
// end.
NB_FN float cloudEnvelopeBound(IN(CloudLayer) L, float h0, float h1, float towerHMax) {
    if (towerHMax <= 1e-4f || h1 <= 0.0f) return 0.0f;
    float lo = max(h0, 0.0f) / towerHMax;
    float lo2 = lo * lo;
    return heightProfileMax(lo, 1.0f, L.heightA, L.heightB) * max(0.0f, 1.0f - lo2 * lo2);
}

// Fade-out of a tower toward the rim of its footprint: full strength where the Gaussian weight
// g is above 0.35, so the base stays wide and flat; zero at g = 0, which removes the thin skirt
// the Gaussian tails would otherwise leave at the bottom of the layer. Non-decreasing in g.
NB_FN float towerRim(float g) { return smoothstep(0.1f, 0.7f, g); }

// Envelope of the tower field at (x, h, z): for each tower k with footprint weight g_k (the
// truncated Gaussian), the column reaches height_k * g_k and the envelope is
// cloudEnvelope(h, height_k g_k) * towerRim(g_k): towers round off toward the top and the rim;
// the max over towers is taken. Footprints reach at most towerRadiusMax <= towerSpacing, so
// the 3x3 neighbouring cells hold every tower that can touch (x, z).
NB_FN float towerEnvelope(IN(CloudLayer) L, float h, float x, float z) {
    int ci = int(floor(x / L.towerSpacing));
    int cj = int(floor(z / L.towerSpacing));
    float best = 0.0f;
    for (int dj = -1; dj <= 1; dj++) {
        for (int di = -1; di <= 1; di++) {
            // most of the nine towers are out of reach: towerRim is 0 from a Mahalanobis
            // distance squared of 4.41 on (g = 0.1), which a Euclidean distance squared above
            // 4.5 sigmaX^2 guarantees (g at most 0.0954 there; sigmaZ <= sigmaX). Those are left
            // out after the first hash draw, before the second and the trigonometry: the
            // envelope is the same to the bit, at a fraction of the cost
            uvec3 h0 = latticeHash3(ivec3(ci + di, cj + dj, 0), CLOUD_TOWER_PERIOD, L.seed);
            vec3 u0 = hashToUnit3(h0);
            vec2 c = towerCenter(L, ci + di, cj + dj, u0);
            float sx = towerSigmaX(L, u0);
            float ex = x - c.x, ez = z - c.y;
            if (ex * ex + ez * ez > 4.5f * sx * sx) continue;
            Tower t = cloudTowerFromDraw(L, ci + di, cj + dj, h0);
            if (!t.present) continue;
            float dx = x - t.center.x;
            float dz = z - t.center.y;
            float rx = (t.cosA * dx + t.sinA * dz) / t.sigmaX;
            float rz = (-t.sinA * dx + t.cosA * dz) / t.sigmaZ;
            float g = truncatedGaussian(rx * rx + rz * rz);
            if (g <= 0.0f) continue;
            best = max(best, cloudEnvelope(L, h, t.height * g) * towerRim(g));
        }
    }
    return best;
}

// Conservative upper bound of towerEnvelope over [x0,x1] x [h0,h1] x [z0,z1]: per tower, the
// Mahalanobis distance is at least the Euclidean distance to the box over the largest sigma,
// which bounds g_k; cloudEnvelopeBound is non-decreasing in the column height.
NB_FN float towerEnvelopeBound(IN(CloudLayer) L, float h0, float h1, float x0, float x1,
                               float z0, float z1) {
    int i0 = int(floor(x0 / L.towerSpacing)) - 1;
    int i1 = int(floor(x1 / L.towerSpacing)) + 1;
    int j0 = int(floor(z0 / L.towerSpacing)) - 1;
    int j1 = int(floor(z1 / L.towerSpacing)) + 1;
    float best = 0.0f;
    for (int j = j0; j <= j1; j++) {
        for (int i = i0; i <= i1; i++) {
            Tower t = cloudTower(L, i, j);
            if (!t.present) continue;
            float dx = max(max(x0 - t.center.x, t.center.x - x1), 0.0f);
            float dz = max(max(z0 - t.center.y, t.center.y - z1), 0.0f);
            float smax = max(t.sigmaX, t.sigmaZ);
            float g = truncatedGaussian((dx * dx + dz * dz) / (smax * smax));
            if (g <= 0.0f) continue;
            best = max(best, cloudEnvelopeBound(L, h0, h1, t.height * g) * towerRim(g));
        }
    }
    return best;
}

// Density in [0, 1] from the envelope, the base noise and the detail noise (all in [0, 1]).
// Coverage as in Schneider 2015: the threshold on the base noise falls from 1 (no cloud) where
// the envelope is 0 to 1 - coverage at the envelope's peak; a soft edge of width `softness`
// above it; then the detail noise erodes the thin parts. Non-decreasing in envelope and base,
// non-increasing in detail: bounds follow by plugging in the bounds of the inputs.
NB_FN float cloudShape(IN(CloudLayer) L, float envelope, float base, float detail) {
    float d = clamp((base - (1.0f - L.coverage * envelope)) / L.softness, 0.0f, 1.0f);
    d = d * d * (3.0f - 2.0f * d);
    float e = min(L.erosion * detail, 0.99f);
    return clamp((d - e) / (1.0f - e), 0.0f, 1.0f);
}

// A procedural cumulus layer at one time: its shaping, the two noises it is carved from (tiles
// of the given world period, lattice cells per tile and octaves) and the wind offsets at that
// time (the whole field drifts by baseOffset; the detail noise by detailOffset).
struct CumulusParams {
    CloudLayer layer;
    float density;      // scale of cloudShape
    float basePeriod;   // world size of one tile of the base noise
    int baseLattice;    // lattice cells per tile (lowest octave)
    int baseOctaves;
    float detailPeriod; // world size of one tile of the detail noise
    int detailLattice;
    int detailOctaves;
    vec3 baseOffset;    // wind * time
    vec3 detailOffset;  // (wind + detail wind) * time
};

// Base-shape noise at noise-domain point q (one tile per unit), in [0, 1].
NB_FN float cumulusBaseNoise(IN(CumulusParams) C, vec3 q) {
    return perlinWorley(q * float(C.baseLattice), C.baseLattice, C.baseOctaves, C.layer.seed);
}

// Detail (erosion) noise at noise-domain point q, in [0, 1].
NB_FN float cumulusDetailNoise(IN(CumulusParams) C, vec3 q) {
    return worleyFbm(q * float(C.detailLattice), C.detailLattice, C.detailOctaves, 0.5f,
                     C.layer.seed + 0x9e3779b9u);
}

// Olajos' channel layout (2016, ch. 2: several frequencies in the RGBA channels of one 3D
// texture, combined per sample after the texture unit's trilinear filter), for tiles baked
// with field.evaluation = "rgba". Base: R the Perlin FBM mapped to [0, 1], G, B, A the Worley
// noise at 1, 2 and 4 times the lattice frequency (perlinWorley's parts). Detail: R, G, B its
// Worley octaves 0, 1, 2, A the octaves from 3 on, averaged with their FBM weights. Every
// channel lies in [0, 1]. At the same point, ...FromChannels(...Channels(q)) is the noise
// (up to rounding); between the nodes of a tile the channels are interpolated before the
// combination, not after it.
NB_FN vec4 cumulusBaseChannels(IN(CumulusParams) C, vec3 q) {
    vec3 p = q * float(C.baseLattice);
    int per = C.baseLattice;
    uint ws = C.layer.seed + 7919u;
    return vec4(0.5f + 0.5f * perlinFbm(p, per, C.baseOctaves, 0.5f, C.layer.seed),
                worleyNoise(p, per, ws), worleyNoise(p * 2.0f, per * 2, ws + 101u),
                worleyNoise(p * 4.0f, per * 4, ws + 202u));
}

NB_FN float cumulusBaseFromChannels(vec4 c) {
    // worleyFbm's sum for 3 octaves in its order: weights 1, 1/2, 1/4 over their sum
    float worley = (c.y + 0.5f * c.z + 0.25f * c.w) / 1.75f;
    return perlinWorleyOf(c.x, worley);
}

NB_FN vec4 cumulusDetailChannels(IN(CumulusParams) C, vec3 q) {
    vec3 p = q * float(C.detailLattice);
    uint seed = C.layer.seed + 0x9e3779b9u;
    vec4 c = vec4(0.0f, 0.0f, 0.0f, 0.0f);
    float tail = 0.0f;
    float tailNorm = 0.0f;
    float amp = 1.0f;
    float freq = 1.0f;
    int per = C.detailLattice;
    for (int i = 0; i < C.detailOctaves; i++) {
        float w = worleyNoise(p * freq, per, seed + uint(i) * 101u);
        if (i == 0) c.x = w;
        if (i == 1) c.y = w;
        if (i == 2) c.z = w;
        if (i >= 3) {
            tail += amp * w;
            tailNorm += amp;
        }
        amp *= 0.5f;
        freq *= 2.0f;
        per *= 2;
    }
    if (tailNorm > 0.0f) c.w = tail / tailNorm;
    return c;
}

NB_FN float cumulusDetailFromChannels(IN(CumulusParams) C, vec4 c) {
    // worleyFbm's weights (gain 1/2): 1, 1/2, 1/4 for R, G, B and the octaves' own for A
    float sum = 0.0f;
    float norm = 0.0f;
    float tailNorm = 0.0f;
    float amp = 1.0f;
    for (int i = 0; i < C.detailOctaves; i++) {
        if (i == 0) sum += amp * c.x;
        if (i == 1) sum += amp * c.y;
        if (i == 2) sum += amp * c.z;
        if (i >= 3) tailNorm += amp;
        norm += amp;
        amp *= 0.5f;
    }
    sum += tailNorm * c.w;
    return sum / norm;
}

// Noise-domain points of world point p: the base noise drifts with the field, the detail noise
// with its own offset.
NB_FN vec3 cumulusBaseDomain(IN(CumulusParams) C, vec3 p) {
    return (p - C.baseOffset) / C.basePeriod;
}
NB_FN vec3 cumulusDetailDomain(IN(CumulusParams) C, vec3 p) {
    return (p - C.detailOffset) / C.detailPeriod;
}

// Tower envelope at world point p: height fraction from the (fixed) layer altitudes, towers
// drifting with the field.
NB_FN float cumulusEnvelope(IN(CumulusParams) C, vec3 p) {
    float h = (p.y - C.layer.bottom) / (C.layer.top - C.layer.bottom);
    return towerEnvelope(C.layer, h, p.x - C.baseOffset.x, p.z - C.baseOffset.z);
}

// Cumulus density at world point p inside the layer's box, the noise evaluated directly. The
// cheap envelope decides first whether even the largest base noise (1) can pass the threshold,
// then the base noise whether the detail noise is needed. Callers that read the noises from
// baked tiles follow the same three stages with cloudShape.
NB_FN float cumulusDensity(IN(CumulusParams) C, vec3 p) {
    float env = cumulusEnvelope(C, p);
    if (cloudShape(C.layer, env, 1.0f, 0.0f) <= 0.0f) return 0.0f;
    float base = cumulusBaseNoise(C, cumulusBaseDomain(C, p));
    if (cloudShape(C.layer, env, base, 0.0f) <= 0.0f) return 0.0f;
    float detail = cumulusDetailNoise(C, cumulusDetailDomain(C, p));
    return C.density * cloudShape(C.layer, env, base, detail);
}

// Upper bound of cumulusEnvelope over the world box [lo, hi] (inside the layer's box).
NB_FN float cumulusEnvelopeBound(IN(CumulusParams) C, vec3 lo, vec3 hi) {
    float span = C.layer.top - C.layer.bottom;
    float h0 = (lo.y - C.layer.bottom) / span;
    float h1 = (hi.y - C.layer.bottom) / span;
    return towerEnvelopeBound(C.layer, h0, h1, lo.x - C.baseOffset.x, hi.x - C.baseOffset.x,
                              lo.z - C.baseOffset.z, hi.z - C.baseOffset.z);
}

// Upper bound of the density where the envelope is at most envMax and the base noise at most
// baseMax (cloudShape is non-decreasing in both and non-increasing in the detail noise).
NB_FN float cumulusDensityBound(IN(CumulusParams) C, float envMax, float baseMax) {
    return C.density * cloudShape(C.layer, envMax, baseMax, 0.0f);
}
