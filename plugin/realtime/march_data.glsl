// march_data.glsl: what the GLSL march pass (march_pass.glsl) reads besides the kernels: the
// parameter block (march_params.glsl) and, when the frame uses them, the Lorenz-Mie table and
// the multiple-scattering grids the CPU computed (Renderer::marchGrids, core/render.h), each in a
// shader storage buffer, with their lookups written as the CPU's host code reads them:
// MieTable::eval (core/media/mie.cpp), DiffusionVolume::sample with its gradient
// (core/lighting/diffusion.cpp), PhotonVolume::sample with its skin profile
// (core/lighting/photons.h) and sampleVoxelCentres (core/geometry.h); and the field's NanoVDB
// grid (RT_VDB) through PNanoVDB, sampled as GridField::density; the cumulus noise tiles the CPU
// baked (RT_BAKED_NOISE), sampled as NoiseVolume::sample; the SDF cloud's node array (RT_SDF),
// evaluated by the kernel sdfTreeStep as SdfTree::distance. Shader storage buffers and
// trilinear interpolation by hand rather than textures: a texture unit's filtering weights are
// fixed point on most GPUs (commonly 8 bits of fraction), the CPU's are float. The one
// exception is field.evaluation = "rgba" (RT_RGBA_NOISE): Olajos' layout asks for 3D textures
// and the texture unit's filter, so that mode's parity is measured, not exact. Assembled after
// march_params.glsl; tests/test_rt_march.cpp compiles it with its own main() to compare each
// lookup with the CPU's on thousands of points.

layout(std430, binding = 0) readonly buffer RtParamBlock { RtMarchParams P; };
#if RT_MIE_TABLE
// the Lorenz-Mie table: per node (cos theta ascending from -1 to 1, phase R, G, B in 1/sr)
layout(std430, binding = 3) readonly buffer RtMieTable { vec4 rtMieNode[]; };
#endif
#if RT_MS_DIFFUSION
// the diffusion's fluence phi (RGB) at the voxel centres, 3 floats per voxel, x fastest
layout(std430, binding = 4) readonly buffer RtDiffusionGrid { float rtDiffusion[]; };
#endif
#if RT_MS_PHOTONS
// the photons' in-scattered radiance (RGB) at the voxel centres, 3 floats per voxel, x fastest
layout(std430, binding = 5) readonly buffer RtPhotonGrid { float rtPhoton[]; };
#if RT_PHOTON_SKIN
// the skin profile's density integral toward the sun at the voxel centres, x fastest
layout(std430, binding = 6) readonly buffer RtSkinGrid { float rtSkinTau[]; };
#endif
#endif
#if RT_SKY_VOLUME
// the single-scattered sky (render.sky_scattering = "single" or render.photon_sky, with
// render.sky_shadow = "volume"; core/lighting/sky_volume.h): first P.skyDirections records of 8
// floats, the direction w_k toward the sky and the sky's radiance L_k there (sky.ambient folded
// in), each padded to 4 (rt::skyVolumeBuffer); then the sky volume's K density integrals per
// voxel, side by side, voxels x fastest (P.skyVolumeResX/Y/Z voxels of P.skyVolumeVoxel from
// P.skyVolumeLo)
layout(std430, binding = 7) readonly buffer RtSkyVolume { float rtSkyVolume[]; };
#endif
#if RT_LIGHT_VOLUME || RT_GATE_VOLUME
// the sun's light-attenuation volume (LightVolume, core/lighting/light_volume.h; the one
// MarchContext reads with render.shadow = "volume", and for the octave gate's line integral,
// RT_GATE_VOLUME, where the frame builds it): the density integral toward the sun at the
// voxel centres, x fastest (P.lightResX/Y/Z voxels of P.lightVoxel from P.lightLo)
layout(std430, binding = 15) readonly buffer RtLightGrid { float rtLightTau[]; };
#endif
#if RT_VDB
// the field's NanoVDB grid (a nanovdb::FloatGrid, the bytes the CPU samples), read through
// PNanoVDB; its name is the one PNanoVDB's GLSL buffer functions read
layout(std430, binding = 9) readonly buffer RtVdbGrid { uint pnanovdb_buf_data[]; };
// @pnanovdb: plugin/realtime/rt_march.cpp puts the text of PNanoVDB.h here (pnanovdbSource())
#endif
#if RT_BAKED_NOISE
// the cumulus noise tiles the CPU baked for the sequence (NoiseVolume, core/fields/cumulus.h:
// bakeCumulusBase / bakeCumulusDetail, the bytes Renderer::fieldFor samples): one float per node
// of a periodic res^3 tile, x fastest, then y, then z; base res = P.baseBakeRes, detail res =
// P.detailBakeRes. One scalar per node: the CPU bakes each noise with its octaves summed.
#if RT_RGBA_NOISE
// field.evaluation = "rgba": the tiles in Olajos' channel layout (kern::cumulusBaseChannels /
// cumulusDetailChannels): RGBA8 3D textures of baseBakeRes^3 / detailBakeRes^3 texels, node i
// of the tile at texel i, GL_LINEAR, GL_REPEAT; the texture unit interpolates each channel and
// cumulusBaseFromChannels / cumulusDetailFromChannels combine them
layout(binding = 4) uniform sampler3D rtBaseChannels;
layout(binding = 5) uniform sampler3D rtDetailChannels;
#else
layout(std430, binding = 10) readonly buffer RtBaseNoise { float rtBaseNoise[]; };
layout(std430, binding = 11) readonly buffer RtDetailNoise { float rtDetailNoise[]; };
#endif
#endif
#if RT_SKIP
// the field's majorant grid for the frame (MajorantGrid, core/tracking/majorant.h: the grid the
// CPU renders the frame with, Renderer::volumesFor): the density bound of each cell, x fastest,
// then y, then z (P.majorantResX/Y/Z cells of P.majorantCell from P.majorantLo), then the
// distance of each block of 4^3 cells (MajorantGrid::blockDistance, as floats; ceil(res / 4)
// blocks per axis, x fastest). Only whether a bound is 0 is read (the cell provably holds no
// cloud, its padding included), and the distances, to leap over empty blocks.
layout(std430, binding = 13) readonly buffer RtMajorant { float rtMajorant[]; };
#endif
#if RT_SDF
// the SDF cloud's tree: SdfTree::gpuNodes (core/sdf/sdf.h), postfix, root last
layout(std430, binding = 12) readonly buffer RtSdfNodes { SdfTreeNode rtSdfNode[]; };
#endif

vec3 rtXyz(vec4 v) { return vec3(v.x, v.y, v.z); }

#if RT_RESUMABLE
// The loop budget. Mesa's llvmpipe ends every loop of a shader once the loops of one SIMD batch
// of invocations have taken LP_MAX_TGSI_LOOP_ITERATIONS = 65535 iterations in all (gallivm:
// "Maximum iterations before loop termination, shared between every loop"): one counter per
// batch, set at the batch's start and decremented at the end of every iteration of every loop
// (masked-off ones included), after which each loop runs once; no error is raised. A camera ray
// whose samples each run a shadow march over an SDF tree needs far more (sdf_cloud.toml: the
// sun's transmittance came out too high, the image 27-34 dB from the CPU's), so `nimbus rt`
// marches in slices (march_pass.glsl, RT_RESUMABLE) and checks with rtLoopBudgetHeld, after the
// march, that the budget held.
// True when a loop of P.loopProbe (2) iterations still runs them all: the batch's counter was
// above 1 here, so it never reached 0 before and every loop before ran to its own end.
bool rtLoopBudgetHeld() {
    int k = 0;
    for (int m = 0; m < P.loopProbe; m++) k++;
    return k == P.loopProbe;
}
#endif

#if RT_VDB
// GridField::density (core/fields/grid.cpp) through PNanoVDB: world to index by the grid's
// inverse map in float (mVecF, mInvMatF: NanoVDB's worldToIndexF, with the CPU's order of
// operations; `precise`: no fused multiply-adds the CPU does not do), trilinear over the voxels
// floor(x) .. floor(x) + 1 with the CPU's lerps (NanoVDB's SampleFromVoxels<1>), max(0, value)
// times the field's density scale; 0 outside the field's box (Field::density). One read
// accessor per invocation, kept between lookups (the CPU keeps one per thread): successive
// samples along a ray mostly fall in the same leaf.
const uint RT_GRID_TYPE_FLOAT = 1u; // PNANOVDB_GRID_TYPE_FLOAT (nanovdb::GridType::Float)
pnanovdb_readaccessor_t rtVdbAccessor;
bool rtVdbAccessorReady = false;

float rtVdbValue(ivec3 ijk) {
    pnanovdb_buf_t buf = pnanovdb_buf_t(0u);
    if (!rtVdbAccessorReady) {
        pnanovdb_grid_handle_t grid = pnanovdb_grid_handle_t(pnanovdb_address_null());
        pnanovdb_readaccessor_init(rtVdbAccessor,
                                   pnanovdb_tree_get_root(buf, pnanovdb_grid_get_tree(buf, grid)));
        rtVdbAccessorReady = true;
    }
    pnanovdb_address_t a = pnanovdb_readaccessor_get_value_address(RT_GRID_TYPE_FLOAT, buf,
                                                                   rtVdbAccessor, ijk);
    return pnanovdb_read_float(buf, a);
}

// the index-space point of world point p (Map::applyInverseMapF)
vec3 rtVdbWorldToIndex(vec3 p) {
    pnanovdb_buf_t buf = pnanovdb_buf_t(0u);
    pnanovdb_map_handle_t map =
        pnanovdb_grid_get_map(buf, pnanovdb_grid_handle_t(pnanovdb_address_null()));
    precise float d0 = p.x - pnanovdb_map_get_vecf(buf, map, 0u);
    precise float d1 = p.y - pnanovdb_map_get_vecf(buf, map, 1u);
    precise float d2 = p.z - pnanovdb_map_get_vecf(buf, map, 2u);
    precise vec3 x;
    x.x = d0 * pnanovdb_map_get_invmatf(buf, map, 0u) +
          d1 * pnanovdb_map_get_invmatf(buf, map, 1u) + d2 * pnanovdb_map_get_invmatf(buf, map, 2u);
    x.y = d0 * pnanovdb_map_get_invmatf(buf, map, 3u) +
          d1 * pnanovdb_map_get_invmatf(buf, map, 4u) + d2 * pnanovdb_map_get_invmatf(buf, map, 5u);
    x.z = d0 * pnanovdb_map_get_invmatf(buf, map, 6u) +
          d1 * pnanovdb_map_get_invmatf(buf, map, 7u) + d2 * pnanovdb_map_get_invmatf(buf, map, 8u);
    return x;
}

// a + t (b - a), unfused (the CPU's lerp in GridField::density)
float rtLerp(float a, float b, float t) {
    precise float r = a + t * (b - a);
    return r;
}

float rtVdbDensity(vec3 p, float scale) {
    vec3 lo = rtXyz(P.boundsLo);
    vec3 hi = rtXyz(P.boundsHi);
    if (!(p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z))
        return 0.0f;
    vec3 x = rtVdbWorldToIndex(p);
    vec3 fl = floor(x);
    precise vec3 f = x - fl;
    ivec3 i = ivec3(fl);
    float c000 = rtVdbValue(i);
    float c001 = rtVdbValue(i + ivec3(0, 0, 1));
    float c010 = rtVdbValue(i + ivec3(0, 1, 0));
    float c011 = rtVdbValue(i + ivec3(0, 1, 1));
    float c100 = rtVdbValue(i + ivec3(1, 0, 0));
    float c101 = rtVdbValue(i + ivec3(1, 0, 1));
    float c110 = rtVdbValue(i + ivec3(1, 1, 0));
    float c111 = rtVdbValue(i + ivec3(1, 1, 1));
    float v = rtLerp(rtLerp(rtLerp(c000, c001, f.z), rtLerp(c010, c011, f.z), f.y),
                     rtLerp(rtLerp(c100, c101, f.z), rtLerp(c110, c111, f.z), f.y), f.x);
    return max(0.0f, v) * scale;
}
#endif

#if RT_BAKED_NOISE && RT_RGBA_NOISE
// The RGBA8 tile's channels at u in voxel units through the texture unit: u wrapped into
// [0, res) as NoiseVolume::sample4 wraps it, node i at texel i, whose centre is (i + 0.5) / res
// (the filter's weights are the GPU's own: 8 bits of fraction on many).
vec4 rtChannels(sampler3D tile, int res, vec3 u) {
    float n = float(res);
    vec3 w = u - floor(u / n) * n;
    return textureLod(tile, (w + 0.5f) / n, 0.0f);
}
#endif

#if RT_BAKED_NOISE && !RT_RGBA_NOISE
// i modulo n in [0, n) for every int i (GLSL leaves % of a negative operand undefined)
int rtWrapIndex(int i, int n) { return i >= 0 ? i % n : (n - 1) - ((-1 - i) % n); }

float rtNoiseNode(int tile, int res, int x, int y, int z) {
    int i = (z * res + y) * res + x;
    return tile == 0 ? rtBaseNoise[i] : rtDetailNoise[i];
}

// NoiseVolume::sample (core/fields/cumulus.cpp): the trilinear lookup of tile `tile` (0 base,
// 1 detail) of res^3 nodes at u in voxel units, wrapped (u and u + res give the same value),
// with the CPU's order of operations (`precise`: no fused multiply-adds the CPU does not do).
float rtNoiseSample(int tile, int res, vec3 u) {
    float n = float(res);
    precise vec3 w = u - floor(u / n) * n; // [0, res)
    vec3 f0 = floor(w);
    precise vec3 f = w - f0;
    int x0 = rtWrapIndex(int(f0.x), res);
    int y0 = rtWrapIndex(int(f0.y), res);
    int z0 = rtWrapIndex(int(f0.z), res);
    int x1 = rtWrapIndex(x0 + 1, res);
    int y1 = rtWrapIndex(y0 + 1, res);
    int z1 = rtWrapIndex(z0 + 1, res);
    float a000 = rtNoiseNode(tile, res, x0, y0, z0), a100 = rtNoiseNode(tile, res, x1, y0, z0);
    float a010 = rtNoiseNode(tile, res, x0, y1, z0), a110 = rtNoiseNode(tile, res, x1, y1, z0);
    float a001 = rtNoiseNode(tile, res, x0, y0, z1), a101 = rtNoiseNode(tile, res, x1, y0, z1);
    float a011 = rtNoiseNode(tile, res, x0, y1, z1), a111 = rtNoiseNode(tile, res, x1, y1, z1);
    precise float c00 = a000 + f.x * (a100 - a000);
    precise float c10 = a010 + f.x * (a110 - a010);
    precise float c01 = a001 + f.x * (a101 - a001);
    precise float c11 = a011 + f.x * (a111 - a011);
    precise float c0 = c00 + f.y * (c10 - c00);
    precise float c1 = c01 + f.y * (c11 - c01);
    precise float v = c0 + f.z * (c1 - c0);
    return v;
}
#endif

#if RT_BAKED_NOISE
// CumulusField::density with both tiles baked (core/fields/cumulus.cpp): the kernel's three
// stages (cumulusDensity), the noises read from the tiles at the noise-domain points times res.
float rtBakedCumulusDensity(CumulusParams C, vec3 p) {
    float env = cumulusEnvelope(C, p);
    if (cloudShape(C.layer, env, 1.0f, 0.0f) <= 0.0f) return 0.0f;
    precise vec3 ub = cumulusBaseDomain(C, p) * float(P.baseBakeRes);
#if RT_RGBA_NOISE
    float base = cumulusBaseFromChannels(rtChannels(rtBaseChannels, P.baseBakeRes, ub));
#else
    float base = rtNoiseSample(0, P.baseBakeRes, ub);
#endif
    if (cloudShape(C.layer, env, base, 0.0f) <= 0.0f) return 0.0f;
    precise vec3 ud = cumulusDetailDomain(C, p) * float(P.detailBakeRes);
#if RT_RGBA_NOISE
    float detail = cumulusDetailFromChannels(C, rtChannels(rtDetailChannels, P.detailBakeRes, ud));
#else
    float detail = rtNoiseSample(1, P.detailBakeRes, ud);
#endif
    return C.density * cloudShape(C.layer, env, base, detail);
}
#endif

#if RT_SDF
// SdfTree::distance (core/sdf/sdf.cpp): the tree's nodes through the kernel sdfTreeStep
// (core/kernels/sdf_tree.glsl), the loop SdfTree::evaluate runs on the CPU; +1e30 for an empty
// tree (kSdfUnbounded).
float rtSdfDistance(vec3 p) {
    if (P.sdfNodeCount <= 0) return 1e30f;
    SdfTreeStack s;
    s.sp = 0;
    for (int i = 0; i < P.sdfNodeCount; i++) sdfTreeStep(rtSdfNode[i], p, true, s);
    return s.v[0];
}

// Field::density of an SDF cloud (SdfCloudField::density): 0 outside the field's box, else
// scale * sdfDensityFromDistance(d(p), falloff).
float rtSdfDensity(vec3 p) {
    vec3 lo = rtXyz(P.boundsLo);
    vec3 hi = rtXyz(P.boundsHi);
    if (!(p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z))
        return 0.0f;
    return P.sdfScale * sdfDensityFromDistance(rtSdfDistance(p), P.sdfFalloff);
}
#endif

#if RT_MIE_TABLE
// MieTable::interval (core/media/mie.cpp): the interval i of the nodes with
// cos_i <= mu <= cos_i+1, mu clamped to [-1, 1]. By bisection here; the CPU starts from a guide
// table and walks to the same interval (the two can differ only when mu is a node itself, where
// both sides interpolate to the node's value).
int rtMieInterval(float mu) {
    mu = clamp(mu, -1.0f, 1.0f);
    int lo = 0;
    int hi = P.mieNodes - 1;
    // invariant: cos_lo <= mu (cos_0 = -1), and lo < hi; 32 halvings cover any table
    for (int k = 0; k < 32 && hi - lo > 1; k++) {
        int mid = (lo + hi) / 2;
        if (rtMieNode[mid].x <= mu) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// MieTable::eval(mu): the phase function per RGB channel, linear in cos theta between the nodes.
vec3 rtMieEval(float mu) {
    int i = rtMieInterval(mu);
    vec4 n0 = rtMieNode[i];
    vec4 n1 = rtMieNode[i + 1];
    float t = clamp((mu - n0.x) / (n1.x - n0.x), 0.0f, 1.0f);
    vec3 v0 = vec3(n0.y, n0.z, n0.w);
    vec3 v1 = vec3(n1.y, n1.z, n1.w);
    return v0 + t * (v1 - v0);
}
#endif

// glm::mix(x, y, a) of the CPU: x (1 - a) + y a (GLSL's mix may round otherwise).
vec3 rtMix(vec3 x, vec3 y, float a) { return x * (1.0f - a) + y * a; }

// The trilinear footprint of world point p in a grid of voxel centres lo + (i + 1/2) voxel,
// clamped to the outermost centres (sampleVoxelCentres, core/geometry.h): corners i0, i1 and
// weights f.
void rtVoxelFootprint(vec3 p, vec3 lo, vec3 voxel, ivec3 res, out ivec3 i0, out ivec3 i1,
                      out vec3 f) {
    vec3 u = (p - lo) / voxel - vec3(0.5f);
    u = clamp(u, vec3(0.0f), vec3(res - ivec3(1)));
    i0 = min(ivec3(u), res - ivec3(1));
    i1 = min(i0 + ivec3(1), res - ivec3(1));
    f = u - vec3(i0);
}

// sampleVoxelCentres' interpolation of a scalar (glm::mix along x, then y, then z) from the
// corner values c<x><y><z> and the weights f of rtVoxelFootprint.
float rtTrilinear(float c000, float c100, float c010, float c110, float c001, float c101,
                  float c011, float c111, vec3 f) {
    float c00 = c000 * (1.0f - f.x) + c100 * f.x;
    float c10 = c010 * (1.0f - f.x) + c110 * f.x;
    float c01 = c001 * (1.0f - f.x) + c101 * f.x;
    float c11 = c011 * (1.0f - f.x) + c111 * f.x;
    float c0 = c00 * (1.0f - f.y) + c10 * f.y;
    float c1 = c01 * (1.0f - f.y) + c11 * f.y;
    return c0 * (1.0f - f.z) + c1 * f.z;
}

#if RT_LIGHT_VOLUME || RT_GATE_VOLUME
float rtLightTauAt(int x, int y, int z) {
    return rtLightTau[(z * P.lightResY + y) * P.lightResX + x];
}

// Whether the light volume holds p (Box::contains of its bounds: the faces included).
bool rtInLightVolume(vec3 p) {
    vec3 lo = rtXyz(P.lightLo);
    vec3 hi = rtXyz(P.lightHi);
    return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z;
}

// LightVolume::sample(p): the density integral toward the sun, sampleVoxelCentres of a scalar.
float rtLightVolumeSample(vec3 p) {
    ivec3 res = ivec3(P.lightResX, P.lightResY, P.lightResZ);
    ivec3 i0, i1;
    vec3 f;
    rtVoxelFootprint(p, rtXyz(P.lightLo), rtXyz(P.lightVoxel), res, i0, i1, f);
    return rtTrilinear(rtLightTauAt(i0.x, i0.y, i0.z), rtLightTauAt(i1.x, i0.y, i0.z),
                       rtLightTauAt(i0.x, i1.y, i0.z), rtLightTauAt(i1.x, i1.y, i0.z),
                       rtLightTauAt(i0.x, i0.y, i1.z), rtLightTauAt(i1.x, i0.y, i1.z),
                       rtLightTauAt(i0.x, i1.y, i1.z), rtLightTauAt(i1.x, i1.y, i1.z), f);
}
#endif

#if RT_MS_DIFFUSION
vec3 rtDiffusionAt(int x, int y, int z) {
    int j = 3 * ((z * P.diffusionResY + y) * P.diffusionResX + x);
    return vec3(rtDiffusion[j], rtDiffusion[j + 1], rtDiffusion[j + 2]);
}

// DiffusionVolume::sample(p, grad) (core/lighting/diffusion.cpp): the fluence at p and the
// gradient of the trilinear interpolant, per channel (gradR = d phi_R / d(x, y, z), ...).
vec3 rtDiffusionSample(vec3 p, out vec3 gradR, out vec3 gradG, out vec3 gradB) {
    ivec3 res = ivec3(P.diffusionResX, P.diffusionResY, P.diffusionResZ);
    vec3 voxel = rtXyz(P.diffusionVoxel);
    ivec3 i0, i1;
    vec3 f;
    rtVoxelFootprint(p, rtXyz(P.diffusionLo), voxel, res, i0, i1, f);
    vec3 c000 = rtDiffusionAt(i0.x, i0.y, i0.z);
    vec3 c100 = rtDiffusionAt(i1.x, i0.y, i0.z);
    vec3 c010 = rtDiffusionAt(i0.x, i1.y, i0.z);
    vec3 c110 = rtDiffusionAt(i1.x, i1.y, i0.z);
    vec3 c001 = rtDiffusionAt(i0.x, i0.y, i1.z);
    vec3 c101 = rtDiffusionAt(i1.x, i0.y, i1.z);
    vec3 c011 = rtDiffusionAt(i0.x, i1.y, i1.z);
    vec3 c111 = rtDiffusionAt(i1.x, i1.y, i1.z);
    vec3 c00 = rtMix(c000, c100, f.x);
    vec3 c10 = rtMix(c010, c110, f.x);
    vec3 c01 = rtMix(c001, c101, f.x);
    vec3 c11 = rtMix(c011, c111, f.x);
    vec3 c0 = rtMix(c00, c10, f.y);
    vec3 c1 = rtMix(c01, c11, f.y);
    // a clamped axis (one voxel, or outside the outer centres) has no slope
    vec3 dx = rtMix(rtMix(c100 - c000, c110 - c010, f.y), rtMix(c101 - c001, c111 - c011, f.y),
                    f.z) /
              voxel.x;
    vec3 dy = rtMix(c10 - c00, c11 - c01, f.z) / voxel.y;
    vec3 dz = (c1 - c0) / voxel.z;
    gradR = vec3(dx.x, dy.x, dz.x);
    gradG = vec3(dx.y, dy.y, dz.y);
    gradB = vec3(dx.z, dy.z, dz.z);
    return rtMix(c0, c1, f.z);
}
#endif

#if RT_MS_PHOTONS
vec3 rtPhotonAt(int x, int y, int z) {
    int j = 3 * ((z * P.photonResY + y) * P.photonResX + x);
    return vec3(rtPhoton[j], rtPhoton[j + 1], rtPhoton[j + 2]);
}

#if RT_PHOTON_SKIN
float rtSkinTauAt(int x, int y, int z) {
    return rtSkinTau[(z * P.skinResY + y) * P.skinResX + x];
}

// PhotonVolume::skin(p): max(exp(-skinK tau_sun(p)), skinFloor), tau_sun read as
// LightVolume::sample reads it (sampleVoxelCentres of a scalar)
float rtPhotonSkin(vec3 p) {
    ivec3 res = ivec3(P.skinResX, P.skinResY, P.skinResZ);
    ivec3 i0, i1;
    vec3 f;
    rtVoxelFootprint(p, rtXyz(P.skinLo), rtXyz(P.skinVoxel), res, i0, i1, f);
    float tau = rtTrilinear(rtSkinTauAt(i0.x, i0.y, i0.z), rtSkinTauAt(i1.x, i0.y, i0.z),
                            rtSkinTauAt(i0.x, i1.y, i0.z), rtSkinTauAt(i1.x, i1.y, i0.z),
                            rtSkinTauAt(i0.x, i0.y, i1.z), rtSkinTauAt(i1.x, i0.y, i1.z),
                            rtSkinTauAt(i0.x, i1.y, i1.z), rtSkinTauAt(i1.x, i1.y, i1.z), f);
    return max(exp(-P.skinK * tau), P.skinFloor);
}
#endif

// PhotonVolume::sample(p): sampleVoxelCentres of the radiance, times the skin profile
// (RT_PHOTON_SKIN: render.photon_skin > 0) or 1.
vec3 rtPhotonSample(vec3 p) {
    ivec3 res = ivec3(P.photonResX, P.photonResY, P.photonResZ);
    ivec3 i0, i1;
    vec3 f;
    rtVoxelFootprint(p, rtXyz(P.photonLo), rtXyz(P.photonVoxel), res, i0, i1, f);
    vec3 c00 = rtMix(rtPhotonAt(i0.x, i0.y, i0.z), rtPhotonAt(i1.x, i0.y, i0.z), f.x);
    vec3 c10 = rtMix(rtPhotonAt(i0.x, i1.y, i0.z), rtPhotonAt(i1.x, i1.y, i0.z), f.x);
    vec3 c01 = rtMix(rtPhotonAt(i0.x, i0.y, i1.z), rtPhotonAt(i1.x, i0.y, i1.z), f.x);
    vec3 c11 = rtMix(rtPhotonAt(i0.x, i1.y, i1.z), rtPhotonAt(i1.x, i1.y, i1.z), f.x);
    vec3 L = rtMix(rtMix(c00, c10, f.y), rtMix(c01, c11, f.y), f.z);
#if RT_PHOTON_SKIN
    return L * rtPhotonSkin(p);
#else
    return L * 1.0f;
#endif
}
#endif

#if RT_SKY_VOLUME
// The phase function toward a sky direction, as PhaseFunction::eval (the table's RGB, or the
// analytic phase in every channel).
vec3 rtSkyPhase(PhaseParams phase, float cosTheta) {
#if RT_MIE_TABLE
    return rtMieEval(cosTheta);
#else
    return vec3(phaseEval(phase, cosTheta));
#endif
}

vec3 rtSkyDirection(int k) {
    int o = 8 * k;
    return vec3(rtSkyVolume[o], rtSkyVolume[o + 1], rtSkyVolume[o + 2]);
}

// The sky light scattered once toward -d at p (MarchContext::skyWeights and skySingleScatter):
// sum_k W_k exp(-sigma_t tau_k(p)), W_k = L_k p(d . w_k) / sum_j p(d . w_j), tau_k read
// trilinearly as SkyVolume::sample (clamped to the outermost voxel centres), in the same order of
// operations. The weights depend on the ray alone; they are recomputed per sample (K phase
// evaluations) rather than carried through the slices of a resumable march.
vec3 rtSkySingleScatter(PhaseParams phase, vec3 p, vec3 d, vec3 sigmaT) {
    int K = P.skyDirections;
    vec3 sum = vec3(0.0f);
    for (int k = 0; k < K; k++) sum += rtSkyPhase(phase, dot(d, rtSkyDirection(k)));
    vec3 inv = vec3(1.0f) / max(sum, vec3(1e-30f));
    ivec3 res = ivec3(P.skyVolumeResX, P.skyVolumeResY, P.skyVolumeResZ);
    vec3 u = (p - rtXyz(P.skyVolumeLo)) / rtXyz(P.skyVolumeVoxel) - vec3(0.5f);
    u = clamp(u, vec3(0.0f), vec3(res - ivec3(1)));
    ivec3 i0 = min(ivec3(u), res - ivec3(1));
    ivec3 i1 = min(i0 + ivec3(1), res - ivec3(1));
    vec3 f = u - vec3(i0);
    int base = 8 * K;
    int c0 = base + ((i0.z * res.y + i0.y) * res.x + i0.x) * K;
    int c1 = base + ((i0.z * res.y + i0.y) * res.x + i1.x) * K;
    int c2 = base + ((i0.z * res.y + i1.y) * res.x + i0.x) * K;
    int c3 = base + ((i0.z * res.y + i1.y) * res.x + i1.x) * K;
    int c4 = base + ((i1.z * res.y + i0.y) * res.x + i0.x) * K;
    int c5 = base + ((i1.z * res.y + i0.y) * res.x + i1.x) * K;
    int c6 = base + ((i1.z * res.y + i1.y) * res.x + i0.x) * K;
    int c7 = base + ((i1.z * res.y + i1.y) * res.x + i1.x) * K;
    float w0 = (1.0f - f.x) * (1.0f - f.y) * (1.0f - f.z);
    float w1 = f.x * (1.0f - f.y) * (1.0f - f.z);
    float w2 = (1.0f - f.x) * f.y * (1.0f - f.z);
    float w3 = f.x * f.y * (1.0f - f.z);
    float w4 = (1.0f - f.x) * (1.0f - f.y) * f.z;
    float w5 = f.x * (1.0f - f.y) * f.z;
    float w6 = (1.0f - f.x) * f.y * f.z;
    float w7 = f.x * f.y * f.z;
    vec3 S = vec3(0.0f);
    for (int k = 0; k < K; k++) {
        float tau = 0.0f;
        tau += w0 * rtSkyVolume[c0 + k];
        tau += w1 * rtSkyVolume[c1 + k];
        tau += w2 * rtSkyVolume[c2 + k];
        tau += w3 * rtSkyVolume[c3 + k];
        tau += w4 * rtSkyVolume[c4 + k];
        tau += w5 * rtSkyVolume[c5 + k];
        tau += w6 * rtSkyVolume[c6 + k];
        tau += w7 * rtSkyVolume[c7 + k];
        int o = 8 * k + 4;
        vec3 L = vec3(rtSkyVolume[o], rtSkyVolume[o + 1], rtSkyVolume[o + 2]);
        vec3 W = rtSkyPhase(phase, dot(d, rtSkyDirection(k))) * L;
        W *= inv;
        S += W * beerLambert(sigmaT * tau);
    }
    return S;
}
#endif
