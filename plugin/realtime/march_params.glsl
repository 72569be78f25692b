// march_params.glsl: the parameter block of the GLSL march pass (plugin/realtime/march_pass.glsl),
// written once in the kernels' GLSL/C++ subset (core/kernels/prelude.h): compiled as C++ by
// plugin/realtime/march_params.h, which fills it from the scene and the frame plan, and as GLSL
// after the embedded kernels, where the pass reads it from a shader storage buffer (std430).
//
// Layout rule, so that C++ and std430 agree byte for byte without padding: every vec4 member
// comes first (std430 aligns a vec4 to 16 bytes; they sit at 0, 16, 32, ...), then 4-byte
// scalars only (float, int, uint). No vec3 (12 bytes in C++, 16-aligned in std430), no bool,
// no nested struct (a struct's std430 alignment is its largest member's). The kernel structs
// (CumulusParams, PhaseParams) are rebuilt from it by rtCumulusParams and rtPhaseParams.

struct RtMarchParams {
    vec4 camOrigin;     // camera (core/camera.h): position
    vec4 camForward;    // unit vectors of the view
    vec4 camRight;
    vec4 camUp;
    vec4 boundsLo;      // the field's bounds: the box march walks
    vec4 boundsHi;
    vec4 sunDirection;  // toward the sun
    vec4 sunIrradiance; // RGB, intensity folded in
    vec4 sigmaS;        // per unit density, density scale folded in (core/media/medium.h)
    vec4 sigmaT;
    vec4 skyZenith;     // core/media/sky.h: uniform sky = zenith
    vec4 skyHorizon;
    vec4 skySphere;     // mean sky over the sphere times sky.ambient (skyMeans().sphere)
    vec4 baseOffset;    // cumulus: wind * time
    vec4 detailOffset;  // cumulus: (wind + detail wind) * time
    vec4 sigmaTr;       // transport extinction per unit density (Medium::sigma_tr): diffusion
    vec4 diffusionLo;   // the diffusion grid (RT_MS_DIFFUSION): its bounds' lower corner
    vec4 diffusionVoxel; // ... and its voxel size
    vec4 photonLo;      // the photon grid (RT_MS_PHOTONS): its bounds' lower corner
    vec4 photonVoxel;   // ... and its voxel size
    vec4 skinLo;        // the photons' skin profile: the density integral toward the sun
    vec4 skinVoxel;     // (the light volume of core/lighting/light_volume.h), lo and voxel
    vec4 majorantLo;    // the majorant grid (RT_SKIP): its bounds' lower corner
    vec4 majorantCell;  // ... and its cell size
    vec4 lightLo;       // the sun's light-attenuation volume (RT_LIGHT_VOLUME, render.shadow =
    vec4 lightHi;       // "volume", core/lighting/light_volume.h): its bounds, in which it
    vec4 lightVoxel;    // replaces the shadow march, and its voxel size
    vec4 skyVolumeLo;   // the single-scattered sky's volume (RT_SKY_VOLUME, render.sky_shadow =
    vec4 skyVolumeVoxel; // "volume", core/lighting/sky_volume.h): lower corner and voxel size

    // the cumulus layer (CloudLayer, core/kernels/cloud.glsl)
    float layerBottom;
    float layerTop;
    float heightA;
    float heightB;
    float coverage;
    float softness;
    float erosion;
    float towerSpacing;
    float towerRadiusMin;
    float towerRadiusMax;
    float towerHeightMin;
    float towerHeightMax;
    float towerProbability;
    float towerAnisotropy;
    uint fieldSeed;
    // the rest of CumulusParams
    float fieldDensity;
    float basePeriod;
    int baseLattice;
    int baseOctaves;
    float detailPeriod;
    int detailLattice;
    int detailOctaves;

    // the phase function (PhaseParams, core/kernels/phase.glsl)
    int phaseKind;
    float phaseG;
    float phaseG2;
    float phaseBlend;
    float phaseAlpha;
    float phaseDiameter;

    // camera
    float tanHalfY;
    float aspect;
    int width;
    int height;

    // march (core/integrators/march.cpp) and the frame plan
    uint frameKey;      // pcg(frameSeedKey ^ pcg(render.seed))
    int jitter;         // render.jitter
    float epsilon;      // early exit below this transmittance
    float step;         // plan.step: primary step schedule (core/tracking/step_schedule.h)
    float stepGrowth;
    float shadowStep;   // plan.shadowStep: shadow step schedule
    float shadowGrowth;
    float stepTau;      // render.step_tau: steps split above this optical depth (0: never)
    int octaves;
    float octaveContribution;
    float octaveExtinction;
    float octaveEccentricity;
    float octaveGate;   // render.octave_gate: octaves above the first fade in thin cloud
    int inScatter;      // INSCATTER_* (core/kernels/lighting.glsl)
    float inScatterC;
    float inScatterStrength;
    int skyKind;        // SKY_* (core/kernels/lighting.glsl)
    float ambientGround; // MarchContext::kAmbientGround
    int pixelSamples;
    int filterKind;     // FILTER_* (core/kernels/pixel.glsl)
    float filterWidth;
    int sampleIndex;    // the pixel sample a pass adds (RT_MULTISAMPLE: one pass per sample)

    // the Lorenz-Mie table (RT_MIE_TABLE): its node count (core/media/mie.h)
    int mieNodes;
    // the multiple-scattering grids: voxels per axis (x fastest in their buffers)
    int diffusionResX;
    int diffusionResY;
    int diffusionResZ;
    int photonResX;
    int photonResY;
    int photonResZ;
    int skinResX;       // the skin profile's light volume: voxels per axis (0: flat voxels)
    int skinResY;
    int skinResZ;
    float skinK;        // PhotonVolume::skinK: extinction per unit density integral
    float skinFloor;    // PhotonVolume::skinFloor: the profile's lower bound
    float msP1;         // render.ms_p1: the P1 term of the diffusion's radiance
    float mediumG;      // Medium::g, the phase function's mean cosine (the diffusion's P1 term)
    // the VDB grid (RT_VDB): the field's density scale (field.density, GridField::scale); the
    // box is boundsLo/Hi, the grid's own map is read from its buffer
    float vdbDensity;
    // the baked cumulus noise (RT_BAKED_NOISE): nodes per axis of the base and detail tiles
    int baseBakeRes;
    int detailBakeRes;
    // the majorant grid (RT_SKIP, core/tracking/majorant.h): cells per axis (x fastest in its
    // buffer), 0 without
    int majorantResX;
    int majorantResY;
    int majorantResZ;
    // the light-attenuation volume (RT_LIGHT_VOLUME): voxels per axis (x fastest in its buffer)
    int lightResX;
    int lightResY;
    int lightResZ;
    // the single-scattered sky's volume (RT_SKY_VOLUME): voxels per axis and its directions (K
    // density integrals per voxel, side by side, voxels x fastest)
    int skyVolumeResX;
    int skyVolumeResY;
    int skyVolumeResZ;
    int skyDirections;
    // the SDF cloud (RT_SDF): density = sdfScale * sdfDensityFromDistance(d(p), sdfFalloff), d the
    // tree of sdfNodeCount nodes in its buffer (binding 12, SdfTreeNode); the box is boundsLo/Hi
    float sdfScale;
    float sdfFalloff;
    int sdfNodeCount;
    // the march in slices (RT_RESUMABLE, `nimbus rt`; an engine's export has none of it): each
    // dispatch takes at most sliceSteps camera steps per ray from where the last one stopped
    // (sliceIndex 0 starts the rays), and checks Mesa llvmpipe's loop budget with a loop of
    // loopProbe (2) iterations (march_pass.glsl, "The loop budget")
    int sliceIndex;
    int sliceSteps;
    int loopProbe;
};

// The cumulus kernel parameters of the block (cumulusParams() of core/fields/cumulus.cpp).
NB_FN CumulusParams rtCumulusParams(IN(RtMarchParams) P) {
    CumulusParams C;
    C.layer.bottom = P.layerBottom;
    C.layer.top = P.layerTop;
    C.layer.heightA = P.heightA;
    C.layer.heightB = P.heightB;
    C.layer.coverage = P.coverage;
    C.layer.softness = P.softness;
    C.layer.erosion = P.erosion;
    C.layer.towerSpacing = P.towerSpacing;
    C.layer.towerRadiusMin = P.towerRadiusMin;
    C.layer.towerRadiusMax = P.towerRadiusMax;
    C.layer.towerHeightMin = P.towerHeightMin;
    C.layer.towerHeightMax = P.towerHeightMax;
    C.layer.towerProbability = P.towerProbability;
    C.layer.towerAnisotropy = P.towerAnisotropy;
    C.layer.seed = P.fieldSeed;
    C.density = P.fieldDensity;
    C.basePeriod = P.basePeriod;
    C.baseLattice = P.baseLattice;
    C.baseOctaves = P.baseOctaves;
    C.detailPeriod = P.detailPeriod;
    C.detailLattice = P.detailLattice;
    C.detailOctaves = P.detailOctaves;
    C.baseOffset = vec3(P.baseOffset.x, P.baseOffset.y, P.baseOffset.z);
    C.detailOffset = vec3(P.detailOffset.x, P.detailOffset.y, P.detailOffset.z);
    return C;
}

// The phase function of the block (phaseParams() of core/media/phase.h).
NB_FN PhaseParams rtPhaseParams(IN(RtMarchParams) P) {
    return makePhaseParams(P.phaseKind, P.phaseG, P.phaseG2, P.phaseBlend, P.phaseAlpha,
                           P.phaseDiameter);
}

// Sky radiance toward direction d: the kernel skyRadianceToward (core/kernels/lighting.glsl),
// as skyRadiance() of core/media/sky.h calls it.
NB_FN vec3 rtSkyRadiance(IN(RtMarchParams) P, vec3 d) {
    return skyRadianceToward(P.skyKind, vec3(P.skyZenith.x, P.skyZenith.y, P.skyZenith.z),
                             vec3(P.skyHorizon.x, P.skyHorizon.y, P.skyHorizon.z), d);
}
