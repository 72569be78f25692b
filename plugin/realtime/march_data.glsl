// march_data.glsl: what the GLSL march pass (march_pass.glsl) reads besides the kernels: the
// parameter block (march_params.glsl) and, when the frame uses them, the Lorenz-Mie table and
// the multiple-scattering grids the CPU computed (Renderer::marchGrids, core/render.h), each in a
// shader storage buffer, with their lookups written as the CPU's host code reads them:
// MieTable::eval (core/media/mie.cpp), DiffusionVolume::sample with its gradient
// (core/lighting/diffusion.cpp), PhotonVolume::sample with its skin profile
// (core/lighting/photons.h) and sampleVoxelCentres (core/geometry.h). Shader storage buffers and
// trilinear interpolation by hand rather than textures: a texture unit's filtering weights are
// fixed point on most GPUs (commonly 8 bits of fraction), the CPU's are float. Assembled after
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

vec3 rtXyz(vec4 v) { return vec3(v.x, v.y, v.z); }

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
    float c00 = rtSkinTauAt(i0.x, i0.y, i0.z) * (1.0f - f.x) + rtSkinTauAt(i1.x, i0.y, i0.z) * f.x;
    float c10 = rtSkinTauAt(i0.x, i1.y, i0.z) * (1.0f - f.x) + rtSkinTauAt(i1.x, i1.y, i0.z) * f.x;
    float c01 = rtSkinTauAt(i0.x, i0.y, i1.z) * (1.0f - f.x) + rtSkinTauAt(i1.x, i0.y, i1.z) * f.x;
    float c11 = rtSkinTauAt(i0.x, i1.y, i1.z) * (1.0f - f.x) + rtSkinTauAt(i1.x, i1.y, i1.z) * f.x;
    float c0 = c00 * (1.0f - f.y) + c10 * f.y;
    float c1 = c01 * (1.0f - f.y) + c11 * f.y;
    float tau = c0 * (1.0f - f.z) + c1 * f.z;
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
