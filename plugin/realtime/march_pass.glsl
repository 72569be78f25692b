// march_pass.glsl: the GLSL march pass, one invocation per pixel. Assembled by
// plugin/realtime/rt_march.cpp as: #version 430, the feature #defines of the frame (RT_SUN,
// RT_AMBIENT, RT_BACKGROUND_SKY, RT_MULTISAMPLE, RT_MIE_TABLE, RT_MS_DIFFUSION, RT_MS_PHOTONS,
// RT_PHOTON_SKIN, RT_VDB, RT_BAKED_NOISE, RT_RGBA_NOISE, RT_SDF, RT_SKIP, RT_LIGHT_VOLUME,
// RT_GATE_VOLUME, RT_SKY_VOLUME: only
// the features the scene uses are
// compiled in; RT_RESUMABLE: `nimbus rt`'s march in slices, below), the embedded kernels
// (core/kernels/source.h), march_params.glsl, march_data.glsl (the parameter block, the Mie table,
// the multiple-scattering grids, the majorant grid, and their lookups), then this file.
//
// It is the CPU `march` integrator (core/integrators/march.cpp, MarchContext::renderPixel and
// traceRay) for the subset rt_march.h lists, written with the same kernels and in the same
// order of operations: pixel-centre rays of the same pinhole camera (core/camera.h), the same
// hashes of (pixel, frame, seed) for the jitter of each ray and of each shadow ray, the same step
// schedules (core/tracking/step_schedule.h; in float here, double on the CPU), the density from
// cumulusDensity evaluated per sample (RT_BAKED_NOISE: its noises read from the tiles the CPU
// baked, RT_RGBA_NOISE: RGBA8 3D textures in Olajos' channel layout; RT_VDB: the field's NanoVDB grid through PNanoVDB; RT_SDF: the SDF cloud's tree through
// the kernel sdfTreeStep), the sun's transmittance by a shadow march per sample (RT_LIGHT_VOLUME:
// read from the CPU's light-attenuation volume where it holds the sample), phaseEval (or
// the Lorenz-Mie table, RT_MIE_TABLE) and the octaves (Wrenninge), inScatterFactor, the
// multiple-scattering grids the CPU computed for the frame (RT_MS_DIFFUSION, RT_MS_PHOTONS) added
// as MarchContext::traceRay adds them, the height-occluded sky ambient or the single-scattered
// sky from the CPU's sky volume (RT_SKY_VOLUME), marchStep (Hillaire's
// energy-conserving step) and the early exit at transmittance < epsilon.
// Empty-space skipping (RT_SKIP): a sample whose majorant cell (the CPU's grid for the frame) has
// the bound 0 is not evaluated, and the step index jumps to the step holding the ray's exit
// from that cell, or from the cube of empty blocks around it; the samples visited stay on the
// schedule's lattice, so only samples of density 0 are dropped and the image is the same bit
// for bit (camera and shadow rays).
// What it does not do: the column sky, the single-scattered sky by shadow marches
// (render.sky_shadow = "march"), surfaces.

layout(local_size_x = 8, local_size_y = 8) in;

// per pixel, row-major from the top-left: the sums of main() below
layout(std430, binding = 1) buffer RtPixels { float pixels[]; };
// samples that were NaN or infinite (left out, as on the CPU; the host counts pixels)
layout(std430, binding = 2) buffer RtCounters { uint nonFinite; };

const float RT_FLOAT_MAX = 3.402823466e38f;
const int RT_MAX_STEPS = 1048576; // a bound on any loop over steps (a GPU must not hang)

#if RT_RESUMABLE
// The march in slices against llvmpipe's loop budget (march_data.glsl, "The loop budget"):
// each dispatch takes at most P.sliceSteps camera steps per ray from where the last stopped, the
// ray's state in RtSlices between dispatches; the host dispatches again while `unfinished` grows
// and renders the frame again in shorter slices when `loopBudgetSpent` is not 0. The samples and
// their arithmetic do not depend on the slicing (a ray's state is stored as the floats it holds).
struct RtRayState {
    vec4 L;       // radiance so far (w: the density at the last step's sample, RtRay.prev)
    vec4 T;       // transmittance so far (w 0)
    vec4 TF;      // the forward beam's transmittance so far (RT_FORWARD_DELTA; w 0)
    float depth;
    int depthSet;
    int n;        // the next step of the camera schedule
    int marching; // 1: the ray goes on in the next slice; 0: done (or never started)
};
layout(std430, binding = 14) buffer RtSlices {
    uint unfinished;      // rays left marching, summed over the dispatches of a frame
    uint loopBudgetSpent; // invocations whose loop budget ran out, summed likewise
    uint slicePad0;
    uint slicePad1;
    RtRayState rtRayState[]; // per pixel, row-major from the top-left
};
#endif

// The step schedule of core/tracking/step_schedule.h: fixed steps dt0 up to tg = ceil(1 / growth)
// dt0, then steps growing geometrically by (1 + growth).
struct RtSchedule {
    float dt0;
    float growth;
    float tg;
    float logG;
};

RtSchedule rtSchedule(float step, float growth) {
    RtSchedule s;
    s.dt0 = step;
    s.growth = growth;
    s.tg = 0.0f;
    s.logG = 0.0f;
    if (growth > 0.0f) {
        s.tg = ceil(1.0f / growth) * step;
        s.logG = log(1.0f + growth);
    }
    return s;
}

float rtScheduleU(RtSchedule s, float t) {
    if (s.growth <= 0.0f || t <= s.tg) return t / s.dt0;
    return s.tg / s.dt0 + log(t / s.tg) / s.logG;
}

float rtScheduleT(RtSchedule s, float u) {
    float ug = s.growth > 0.0f ? s.tg / s.dt0 : 0.0f;
    if (s.growth <= 0.0f || u <= ug) return u * s.dt0;
    return s.tg * exp((u - ug) * s.logG);
}

// intersectBox() of core/geometry.h (slabs, NaN-safe for direction components of 0).
bool rtIntersectBox(vec3 o, vec3 d, vec3 lo, vec3 hi, float tmin, float tmax, out float t0,
                    out float t1) {
    t0 = tmin;
    t1 = tmax;
    for (int a = 0; a < 3; a++) {
        float inv = 1.0f / d[a];
        float tn = (lo[a] - o[a]) * inv;
        float tf = (hi[a] - o[a]) * inv;
        if (tn > tf) {
            float x = tn;
            tn = tf;
            tf = x;
        }
        t0 = tn > t0 ? tn : t0;
        t1 = tf < t1 ? tf : t1;
        if (t0 > t1) return false;
    }
    return true;
}

float rtMaxComponent(vec3 v) { return max(v.x, max(v.y, v.z)); }
float rtMinComponent(vec3 v) { return min(v.x, min(v.y, v.z)); }

#if RT_SKIP
// Empty-space skipping (MajorantIterator::next and leap, core/tracking/majorant.cpp): whether the
// majorant cell holding the point p = o + d t has the bound 0, and if so where the ray o + d t
// leaves the empty region around it (tExit): the cube of 2 k - 1 blocks of MajorantGrid::kBlock
// (4) cells around the cell's block when that block's distance k (MajorantGrid::blockDistance,
// the Chebyshev distance in blocks to the nearest block holding a non-zero cell) is at least 1,
// else the cell alone; clipped to the grid, as the CPU's leap clips it. A point outside the grid
// is not skipped (its density is looked up). Each cell's bound covers the cell grown by 5% of
// its size (buildMajorantGrid's padding), so a sample that rounds into a neighbouring cell, or a
// step that ends a few ulp past the exit, still sees no density. Axes along which d is 0 are
// left out of the exit (the ray never crosses their planes; tExit stays the largest float when
// all are).
const int RT_MAJORANT_BLOCK = 4; // MajorantGrid::kBlock

// The nearer of tExit and where the ray (origin o, direction d along one axis) meets the plane
// `face` of that axis (an axis the ray runs parallel to is left out).
float rtFaceExit(float tExit, float o, float d, float face) {
    return d != 0.0f ? min(tExit, (face - o) / d) : tExit;
}

bool rtEmptyCell(vec3 o, vec3 d, vec3 p, out float tExit) {
    ivec3 res = ivec3(P.majorantResX, P.majorantResY, P.majorantResZ);
    vec3 lo = rtXyz(P.majorantLo);
    vec3 cell = rtXyz(P.majorantCell);
    ivec3 c = ivec3(floor((p - lo) / cell));
    tExit = RT_FLOAT_MAX;
    if (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, res))) return false;
    if (rtMajorant[(c.z * res.y + c.y) * res.x + c.x] != 0.0f) return false;
    // the block distances follow the cells in the buffer, x fastest
    ivec3 blocks = (res + ivec3(RT_MAJORANT_BLOCK - 1)) / RT_MAJORANT_BLOCK;
    ivec3 b = c / RT_MAJORANT_BLOCK;
    int k = int(rtMajorant[res.x * res.y * res.z + (b.z * blocks.y + b.y) * blocks.x + b.x]);
    ivec3 c0 = c;
    ivec3 c1 = c + ivec3(1);
    if (k > 0) {
        c0 = max(b - ivec3(k - 1), ivec3(0)) * RT_MAJORANT_BLOCK;
        c1 = min((b + ivec3(k)) * RT_MAJORANT_BLOCK, res); // one past the cube's last cell
    }
    // (the axes written out, not a loop: llvmpipe's loop budget counts every loop entered)
    tExit = rtFaceExit(tExit, o.x, d.x, lo.x + float(d.x > 0.0f ? c1.x : c0.x) * cell.x);
    tExit = rtFaceExit(tExit, o.y, d.y, lo.y + float(d.y > 0.0f ? c1.y : c0.y) * cell.y);
    tExit = rtFaceExit(tExit, o.z, d.z, lo.z + float(d.z > 0.0f ? c1.z : c0.z) * cell.z);
    return true;
}

// The step to go on from after a sample in an empty cell (RT_SKIP): the one before the step of
// schedule s that holds the cell's exit tExit (clipped to tOut), so that the loop's n++ lands on
// the step holding the exit, whose sample is checked again (it may still lie in the empty cell);
// never before n, so the loop always advances. Every step skipped has its sample before tExit,
// in the empty cell: skipping drops only samples of density 0, as marchSegments does.
// With render.step_tau the loop lands one step earlier still: the step before the one holding the
// exit may be the last whose sample lies in the empty cell, and rtEdgeStep looks at it.
int rtSkipTo(RtSchedule s, int n, float tExit, float tOut) {
    return max(n, int(floor(rtScheduleU(s, min(tExit, tOut)))) - (P.stepTau > 0.0f ? 2 : 1));
}
#endif

// The field the pass marches (Field::density): the procedural cumulus, its noise evaluated per
// sample, or (RT_VDB) the NanoVDB grid read through PNanoVDB (march_data.glsl, rtVdbDensity), or
// (RT_SDF) the SDF cloud's tree (rtSdfDensity).
#if RT_VDB
struct RtField {
    float scale; // field.density
};

RtField rtField() {
    RtField F;
    F.scale = P.vdbDensity;
    return F;
}

float rtDensity(RtField F, vec3 p) { return rtVdbDensity(p, F.scale); }
#elif RT_SDF
struct RtField {
    float scale; // field.density (read from P by rtSdfDensity)
};

RtField rtField() {
    RtField F;
    F.scale = P.sdfScale;
    return F;
}

float rtDensity(RtField F, vec3 p) { return rtSdfDensity(p); }
#else
struct RtField {
    CumulusParams cumulus;
};

RtField rtField() {
    RtField F;
    F.cumulus = rtCumulusParams(P);
    return F;
}

#if RT_BAKED_NOISE
// the noise read from the tiles the CPU baked (march_data.glsl), as CumulusField::density
float rtDensity(RtField F, vec3 p) { return rtBakedCumulusDensity(F.cumulus, p); }
#else
float rtDensity(RtField F, vec3 p) { return cumulusDensity(F.cumulus, p); }
#endif
#endif

// The densities around a march step that render.step_tau's test looks at besides its own
// sample's (splitDensity; MarchContext's StepNeighbours): the sample before (kept while the
// visited steps follow each other; 0 after a stretch skipped as empty, where the density is 0
// too), or a shadow ray's start, and the next step's, read ahead and used again when that step
// comes.
struct RtNeighbours {
    int prevN; // the step prev belongs to (RT_ANY_STEP: a shadow ray's start, before any step)
    float prev;
    int nextN; // the step next belongs to (-1 after none was read)
    float next;
    float around; // the larger of the current step's neighbours
};
const int RT_ANY_STEP = -2147483647;
const int RT_NO_STEP = -2147483646; // prev belongs to no step (nothing before it saw density)

// Where a march stands within its step n. Each iteration of a step loop looks up one density at
// most (llvmpipe's loop budget counts an iteration of every loop a lookup enters, taken or not),
// so a step takes one iteration or more, held while they last: its sample (unless read ahead),
// then with render.step_tau the next step's sample (read ahead, kept for that step) and the
// split is decided, then its sub-steps if it is split, each at its own turn of the jitter
// (substepOffset).
const int RT_PHASE_STEP = 0;  // a new step: its sample
const int RT_PHASE_AHEAD = 1; // the next step's sample, then the split
const int RT_PHASE_SUB = 2;   // sub-step j of k
struct RtStepper {
    int phase;
    int j;
    int k;
    float here; // the density at the step's sample
    RtNeighbours nb;
};

// A march from a point of density rhoStart (a shadow ray's start: the first step's neighbour; 0
// for a march that enters the volume from outside).
RtStepper rtStepperStart(float rhoStart) {
    RtStepper st;
    st.phase = RT_PHASE_STEP;
    st.j = 0;
    st.k = 1;
    st.here = 0.0f;
    st.nb.prevN = rhoStart > 0.0f ? RT_ANY_STEP : RT_NO_STEP;
    st.nb.prev = rhoStart;
    st.nb.nextN = -1;
    st.nb.next = 0.0f;
    st.nb.around = 0.0f;
    return st;
}

// The sample of step n + 1 (clipped to [tIn, tOut]) in t; false where that step is empty.
bool rtNextSample(RtSchedule s, int n, float tIn, float tOut, float jitter, out float t) {
    float tA = max(rtScheduleT(s, float(n + 1)), tIn);
    float tB = min(rtScheduleT(s, float(n + 2)), tOut);
    t = tA + jitter * (tB - tA);
    return tB > tA;
}

// Step n's sample has density `here`: the sample before becomes its neighbour.
void rtStepperBegin(inout RtStepper st, int n, float here) {
    st.here = here;
    st.nb.around = st.nb.prevN == n - 1 || st.nb.prevN == RT_ANY_STEP ? st.nb.prev : 0.0f;
    st.nb.prev = here;
    st.nb.prevN = n;
    st.nb.nextN = -1;
    st.phase = RT_PHASE_AHEAD;
}

// What step n (from tA to tA + dt, not skipped; `empty`: its sample lies in an empty majorant
// cell, density 0) looks up in this iteration: true with the point in `at`, false for nothing.
bool rtStepperLookup(inout RtStepper st, RtSchedule s, int n, float tA, float dt, bool empty,
                     vec3 o, vec3 w, float tIn, float tOut, float jitter, out vec3 at) {
    at = o;
    if (st.phase == RT_PHASE_STEP) {
        if (!empty && st.nb.nextN != n) {
            at = o + w * (tA + jitter * dt);
            return true;
        }
        rtStepperBegin(st, n, empty ? 0.0f : st.nb.next);
    }
    if (st.phase == RT_PHASE_AHEAD) {
        float t;
        bool next = rtNextSample(s, n, tIn, tOut, jitter, t);
        at = o + w * t;
        return P.stepTau > 0.0f && next;
    }
    at = o + w * substepT(tA, dt / float(st.k), st.j, jitter);
    return true;
}

// Takes this iteration's lookup v (of the point rtStepperLookup chose, if it chose one) for step
// n from tA to tA + dt, split where its optical depth times `weight` (the transmittance in front
// of it times the largest sigma_t) is above render.step_tau. True with what the march adds in
// (t, h, rho, key: a sample of density rho standing for a stretch h, the key of its random
// numbers, f: where t lies in that stretch, as a fraction of it); `hold` is true while the step
// takes more iterations.
bool rtStepperTake(inout RtStepper st, int n, float tA, float dt, float jitter, float v,
                   bool looked, float weight, out float t, out float h, out float rho,
                   out uint key, out bool hold, out float f) {
    t = tA + jitter * dt;
    h = dt;
    f = jitter;
    rho = 0.0f;
    key = uint(n);
    hold = false;
    if (st.phase == RT_PHASE_STEP) {
        rtStepperBegin(st, n, v);
        // without splitting nothing is read ahead: decided at once
        hold = P.stepTau > 0.0f;
        if (hold) return false;
        looked = false;
    }
    if (st.phase == RT_PHASE_AHEAD) {
        if (looked) {
            st.nb.next = v;
            st.nb.nextN = n + 1;
            st.nb.around = max(st.nb.around, v);
        }
        st.k = substeps(weight * splitDensity(st.here, st.nb.around) * dt, P.stepTau);
        if (st.k == 1) {
            st.phase = RT_PHASE_STEP;
            rho = st.here;
            return true;
        }
        st.phase = RT_PHASE_SUB;
        st.j = 0;
        hold = true;
        return false;
    }
    // sub-step j: the key of core/tracking/step_schedule.h's substepIndex (its low bits)
    h = dt / float(st.k);
    t = substepT(tA, h, st.j, jitter);
    f = substepOffset(st.j, jitter);
    rho = v;
    key = uint(n) * 0x7f4a7c15u + uint(st.j + 1) * 0x1ce4e5b9u;
    st.j++;
    hold = st.j < st.k;
    if (!hold) {
        st.phase = RT_PHASE_STEP;
        st.j = 0;
        st.k = 1;
    }
    return true;
}

#if RT_SKIP
// Whether step n, whose sample lies in an empty majorant cell, is visited all the same (as a
// sample of density 0) rather than skipped: with render.step_tau a march that takes every step
// splits such a step where a neighbour's density is above 0 (the step may reach out of the cell),
// so skipping visits the steps where that can happen, for the same image: the step after a
// visited one that saw density (or a shadow ray's first) and the step whose next sample lies
// outside the empty cell. Every other skipped step has neighbours of density 0.
bool rtEdgeStep(RtNeighbours nb, RtSchedule s, int n, vec3 o, vec3 w, float tIn, float tOut,
                float jitter) {
    if (!(P.stepTau > 0.0f)) return false;
    if ((nb.prevN == n - 1 || nb.prevN == RT_ANY_STEP) && nb.prev > 0.0f) return true;
    float t, tExit;
    return rtNextSample(s, n, tIn, tOut, jitter, t) && !rtEmptyCell(o, w, o + w * t, tExit);
}
#endif

#if RT_SUN
// The density integral from p toward direction w (MarchContext::densityIntegral): a jittered
// march on the shadow schedule from p (or from where the ray enters the box, when p lies outside
// it), stopped once the transmittance is below 1e-5 in every channel.
float rtDensityIntegral(RtField F, vec3 p, float rhoP, vec3 w, uint rng) {
    float jitter = P.jitter != 0 ? hashToUnit(pcg(rng)) : 0.5f;
    float tauStop = 11.5f / max(rtMinComponent(rtXyz(P.sigmaT)), 1e-12f);
    vec3 lo = rtXyz(P.boundsLo);
    vec3 hi = rtXyz(P.boundsHi);
    float tIn, tOut;
    if (!rtIntersectBox(p, w, lo, hi, 0.0f, RT_FLOAT_MAX, tIn, tOut)) return 0.0f;
    vec3 o = p;
    if (tIn > 0.0f) {
        o = p + w * tIn;
        if (!rtIntersectBox(o, w, lo, hi, 0.0f, RT_FLOAT_MAX, tIn, tOut)) return 0.0f;
        rhoP = 0.0f; // (the march starts where it enters the box, with nothing before it)
    }
    RtSchedule s = rtSchedule(P.shadowStep, P.shadowGrowth);
    float sigmaTMax = rtMaxComponent(rtXyz(P.sigmaT));
    float sigmaTMin = rtMinComponent(rtXyz(P.sigmaT));
    float tau = 0.0f;
    // one step early: float rounding of u(tIn) must not skip the first step (it is clipped away)
    int n0 = int(floor(rtScheduleU(s, tIn))) - 1;
    bool marching = true;
    // a step whose optical depth times the transmittance in front of it is above render.step_tau
    // is split (substeps; MarchContext::densityIntegral); the test looks at the densities around
    // the step too, the first step's neighbour being p's density rhoP (RtStepper)
    RtStepper st = rtStepperStart(rhoP);
    for (int n = n0; marching && n < n0 + RT_MAX_STEPS; n++) {
        float tA = max(rtScheduleT(s, float(n)), tIn);
        float tB = min(rtScheduleT(s, float(n + 1)), tOut);
        float dt = tB - tA;
        vec3 at = o;
        bool look = false;
        bool skipped = !(tB > tA);
        if (!skipped) {
            bool empty = false;
#if RT_SKIP
            if (st.phase == RT_PHASE_STEP) {
                float tExit;
                empty = rtEmptyCell(o, w, o + w * (tA + jitter * dt), tExit);
                skipped = empty && !rtEdgeStep(st.nb, s, n, o, w, tIn, tOut, jitter);
                if (skipped) n = rtSkipTo(s, n, tExit, tOut);
            }
#endif
            if (!skipped) look = rtStepperLookup(st, s, n, tA, dt, empty, o, w, tIn, tOut, jitter, at);
        }
        float v = look ? rtDensity(F, at) : 0.0f; // the iteration's one lookup
        if (!skipped) {
            float t, h, rho, f;
            uint key;
            bool hold;
            if (rtStepperTake(st, n, tA, dt, jitter, v, look, exp(-sigmaTMin * tau) * sigmaTMax, t,
                              h, rho, key, hold, f))
                tau += rho * h;
            if (hold) n--; // the same step again
            marching = tau <= tauStop;
        } else if (!(tB > tA)) {
            marching = tA < tOut;
        }
    }
    return tau;
}
#endif // RT_SUN: the shadow march exists only where the sun is compiled in

struct RtSample {
    vec3 L;
    vec3 T;
    float alpha;
    float depth;
};

// A camera ray's march so far: what MarchContext::traceRay accumulates, and where it is.
struct RtRay {
    vec3 L;
    vec3 T;
    vec3 TF; // under sigma_t - g^2 sigma_s: carries the sun's single scattering (RT_FORWARD_DELTA)
    float depth;
    bool depthSet;
    bool started; // n is set (the first step is known once the box is hit)
    int n;        // the next step of the camera schedule
    float prev;   // the density at step n - 1's sample (0 where it was skipped as empty)
    bool marching;
};

RtRay rtRayStart() {
    RtRay r;
    r.L = vec3(0.0f);
    r.T = vec3(1.0f);
    r.TF = vec3(1.0f);
    r.depth = 0.0f;
    r.depthSet = false;
    r.started = false;
    r.n = 0;
    r.prev = 0.0f;
    r.marching = true;
    return r;
}

// One sample of a camera ray (MarchContext::traceRay's visit): at t on o + t d, standing for the
// length dt, t at the fraction f of it, with the density rho there; key seeds its random numbers
// (its step's index, or substepIndex's low bits for a sub-step). Its light is looked at where
// the stretch's transmittance puts it (lightFraction). Adds its light to L, T and TF, sets the
// depth where T first falls below half, and whether the march goes on.
void rtMarchSample(RtField F, PhaseParams phase, vec3 mie, vec3 o, vec3 d, float t, float dt,
                   float f, float rho, uint pixelKey, uint key, inout vec3 L, inout vec3 T,
                   inout vec3 TF, inout float depth, inout bool depthSet, inout bool marching) {
    vec3 sunDir = rtXyz(P.sunDirection);
    float cosTheta = dot(d, sunDir);
    vec3 sigmaS = rtXyz(P.sigmaS);
    vec3 sigmaT = rtXyz(P.sigmaT);
    float sigmaTMean = (sigmaT.x + sigmaT.y + sigmaT.z) / 3.0f;
    vec3 p = o + d * (t + dt * (lightFraction(f, sigmaTMean * rho * dt) - f));
#if RT_FORWARD_DELTA
    // the forward peak's share g^2 of scattering stays in the beams (PlanFrame's forwardFraction)
    float forwardFraction = P.mediumG * P.mediumG;
    vec3 sigmaTF = sigmaT - forwardFraction * sigmaS;
#endif
#if RT_AMBIENT
    vec3 lo = rtXyz(P.boundsLo);
    vec3 hi = rtXyz(P.boundsHi);
#endif
    vec3 S = vec3(0.0f);
    vec3 SF = vec3(0.0f);
#if RT_FORWARD_DELTA
    // past T's tolerance only the forward beam goes on: T's terms are dropped
    bool beamT = rtMaxComponent(T) >= P.epsilon;
#else
    bool beamT = true;
#endif
#if RT_SUN
#if RT_LIGHT_VOLUME
    // MarchContext::sunOpticalDepth: the light volume where it holds p
    float tau = rtInLightVolume(p)
                    ? rtLightVolumeSample(p)
                    : rtDensityIntegral(F, p, rho, sunDir, pcg(pixelKey ^ (key * 0x9e3779b9u)));
#else
    float tau = rtDensityIntegral(F, p, rho, sunDir, pcg(pixelKey ^ (key * 0x9e3779b9u)));
#endif
    vec3 sun = vec3(0.0f);
    vec3 higher = vec3(0.0f);
    vec3 sunForward = vec3(0.0f);
    float weight = 1.0f;
    float extinction = 1.0f;
    PhaseParams octavePhase = phase;
#if RT_MIE_TABLE
    // PhaseFunction::octave of the table: w table + (1 - w) / 4 pi, w scaled by
    // the eccentricity per octave
    float tableWeight = 1.0f;
#endif
#if RT_MS_PHOTONS
    // traced photons carry every higher order: the octaves stand down
    int octaves = 1;
#else
    int octaves = beamT ? P.octaves : 1;
#endif
    for (int i = 0; i < octaves; i++) {
#if RT_MIE_TABLE
        vec3 ph = tableWeight * mie + vec3((1.0f - tableWeight) * NB_INV_4PI);
        tableWeight *= P.octaveEccentricity;
#else
        vec3 ph = vec3(phaseEval(octavePhase, cosTheta));
#endif
#if RT_FORWARD_DELTA
        // the single scattering (octave 0) in the beams' extinction
        if (i == 0)
            sunForward = octaveSun(ph, sigmaTF, tau, 1.0f, 1.0f);
        else
            higher += octaveSun(ph, sigmaT, tau, weight, extinction);
#else
        if (i == 0)
            sun += octaveSun(ph, sigmaT, tau, weight, extinction);
        else
            higher += octaveSun(ph, sigmaT, tau, weight, extinction);
#endif
        weight *= P.octaveContribution;
        extinction *= P.octaveExtinction;
        octavePhase = phaseOctave(octavePhase, P.octaveEccentricity);
    }
    // the octave gate (render.octave_gate): the octaves above the first need a cloud along the
    // sun's line to scatter in; the density integral away from the sun by a second shadow march,
    // or where the sun-depth volume holds p (RT_GATE_VOLUME), that volume read where the line
    // leaves it on the far side
    if (octaves > 1 && P.octaveGate > 0.0f && rtMaxComponent(higher) > 0.0f) {
        float line = tau;
        if (octaveGateNeedsAway(sigmaS, P.octaveGate, tau) > 0.0f) {
#if RT_GATE_VOLUME
            if (rtInLightVolume(p))
                line = max(tau, rtLightVolumeSample(boxExitPoint(p, -sunDir, rtXyz(P.lightLo),
                                                                 rtXyz(P.lightHi))));
            else
#endif
                line += rtDensityIntegral(F, p, rho, -sunDir, pcg(pixelKey ^ (key * 0xc2b2ae35u)));
        }
        higher *= octaveGateFactor(sigmaS, P.octaveGate, line);
    }
    sun += higher;
    vec3 sunIn = rtXyz(P.sunIrradiance) *
                 inScatterFactor(P.inScatter, rho, tau, sigmaT, P.inScatterC,
                                 P.inScatterStrength);
    S += sunIn * sun;
    SF = sunIn * sunForward;
#if RT_MS_PHOTONS
    // the sun light scattered more than once (core/lighting/photons.h)
    S += rtPhotonSample(p);
#endif
#endif
#if RT_MS_DIFFUSION
    // sun light scattered more than once and all sky light (diffusion.h): the P1
    // radiance scattered toward the camera by the phase function
    if (beamT) {
        vec3 gradR, gradG, gradB;
        vec3 phi = rtDiffusionSample(p, gradR, gradG, gradB);
        vec3 sigmaTr = rtXyz(P.sigmaTr);
        vec3 ms = vec3(
            p1Radiance(phi.x, gradR, sigmaTr.x, rho, P.mediumG, P.msP1, -d),
            p1Radiance(phi.y, gradG, sigmaTr.y, rho, P.mediumG, P.msP1, -d),
            p1Radiance(phi.z, gradB, sigmaTr.z, rho, P.mediumG, P.msP1, -d));
        S += ms * NB_INV_4PI;
    }
#endif
#if RT_SKY_VOLUME
    // the sky light scattered once, its transmittance from the sky volume
    // (MarchContext::skySingleScatter)
    if (beamT) S += rtSkySingleScatter(phase, p, d, sigmaT);
#endif
#if RT_AMBIENT
    // the sky ambient, occluded by height (MarchContext::skyInScatter)
    float span = max(hi.y - lo.y, 1e-20f);
    float h = clamp((p.y - lo.y) / span, 0.0f, 1.0f);
    if (beamT) S += skyHeightInScatter(rtXyz(P.skySphere), h, P.ambientGround);
#endif
    marchStep(S, sigmaS, sigmaT, rho, dt, L, T);
#if RT_FORWARD_DELTA
    marchStep(SF, sigmaS, sigmaTF, rho, dt, L, TF);
#endif
    if (!depthSet && (T.x + T.y + T.z) < 1.5f) {
        depth = t;
        depthSet = true;
    }
#if RT_FORWARD_DELTA
    // the forward beam reaches further: it alone decides where the march stops
    marching = rtMaxComponent(TF) >= P.epsilon;
#else
    marching = rtMaxComponent(T) >= P.epsilon;
#endif
}

// One camera ray (MarchContext::traceRay without surfaces, the column sky or the marched
// single-scattered sky), marched from r for at most maxSteps steps (RT_MAX_STEPS: to its end);
// r.marching is false once the ray is done.
void rtMarchRay(RtField F, PhaseParams phase, vec3 o, vec3 d, uint pixelKey, float jitter,
                int maxSteps, inout RtRay r) {
    vec3 sigmaT = rtXyz(P.sigmaT);
    vec3 L = r.L;
    vec3 T = r.T;
    vec3 TF = r.TF;
    float depth = r.depth;
    bool depthSet = r.depthSet;
    vec3 lo = rtXyz(P.boundsLo);
    vec3 hi = rtXyz(P.boundsHi);
#if RT_MIE_TABLE
    // the table at this ray's angle to the sun (PhaseFunction::eval of the table kind), once a ray
    vec3 mie = rtMieEval(dot(d, rtXyz(P.sunDirection)));
#else
    vec3 mie = vec3(0.0f);
#endif
    float tIn, tOut;
    bool marching = false;
    if (rtIntersectBox(o, d, lo, hi, 0.0f, RT_FLOAT_MAX, tIn, tOut)) {
        RtSchedule s = rtSchedule(P.step, P.stepGrowth);
        int n0 = int(floor(rtScheduleU(s, tIn))) - 1;
        if (!r.started) r.n = n0;
        int nEnd = min(n0 + RT_MAX_STEPS, r.n + min(maxSteps, RT_MAX_STEPS));
        int n = r.n;
        // (the step loops end by their condition, without break or continue)
        marching = r.marching;
        // steps split as the shadow march's are (RtStepper), by the transmittance of the beam
        // that carries the light to the camera (MarchContext::traceRay); a slice ends only
        // between steps, the density at the last sample carried over in r.prev (for step r.n - 1)
        RtStepper st = rtStepperStart(0.0f);
        if (r.started) {
            st.nb.prev = r.prev;
            st.nb.prevN = n - 1;
        }
        for (; marching && n < nEnd; n++) {
            float tA = max(rtScheduleT(s, float(n)), tIn);
            float tB = min(rtScheduleT(s, float(n + 1)), tOut);
            if (!(tB > tA)) {
                marching = tA < tOut;
            } else {
                float dt = tB - tA;
                bool empty = false;
                bool skipped = false;
#if RT_SKIP
                if (st.phase == RT_PHASE_STEP) {
                    // a sample in an empty majorant cell: on from the step holding the exit from
                    // the cell (or from the cube of empty blocks around it)
                    float tExit;
                    empty = rtEmptyCell(o, d, o + d * (tA + jitter * dt), tExit);
                    skipped = empty && !rtEdgeStep(st.nb, s, n, o, d, tIn, tOut, jitter);
                    if (skipped) n = rtSkipTo(s, n, tExit, tOut);
                }
#endif
                if (!skipped) {
                    vec3 at;
                    bool look =
                        rtStepperLookup(st, s, n, tA, dt, empty, o, d, tIn, tOut, jitter, at);
                    float v = look ? rtDensity(F, at) : 0.0f; // the iteration's one lookup
#if RT_FORWARD_DELTA
                    float beam = rtMaxComponent(TF);
#else
                    float beam = rtMaxComponent(T);
#endif
                    float t, h, rho, f;
                    uint key;
                    bool hold;
                    if (rtStepperTake(st, n, tA, dt, jitter, v, look,
                                      beam * rtMaxComponent(sigmaT), t, h, rho, key, hold, f) &&
                        rho > 0.0f)
                        rtMarchSample(F, phase, mie, o, d, t, h, f, rho, pixelKey, key, L, T, TF,
                                      depth, depthSet, marching);
                    if (hold) n--; // the same step again
                }
            }
        }
        r.n = n;
        r.prev = st.nb.prevN == n - 1 ? st.nb.prev : 0.0f;
        marching = marching && n < n0 + RT_MAX_STEPS;
    }
    r.L = L;
    r.T = T;
    r.TF = TF;
    r.depth = depth;
    r.depthSet = depthSet;
    r.started = true;
    r.marching = marching;
}

// The sample of a finished ray (traceRay's end: the sky behind the clouds).
RtSample rtFinishRay(RtRay ray, vec3 d) {
    RtSample r;
    vec3 L = ray.L;
    vec3 T = ray.T;
    r.alpha = 1.0f - (T.x + T.y + T.z) / 3.0f;
#if RT_BACKGROUND_SKY
    L += T * rtSkyRadiance(P, d);
    r.alpha = 1.0f;
#endif
    r.L = L;
    r.T = T;
    r.depth = ray.depth;
    return r;
}

// The ray through image position (px, py) in pixels (Camera::generate, core/camera.h).
vec3 rtCameraDirection(float px, float py) {
    float sx = (2.0f * px / float(P.width) - 1.0f) * P.tanHalfY * P.aspect;
    float sy = (1.0f - 2.0f * py / float(P.height)) * P.tanHalfY;
    return normalize(rtXyz(P.camForward) + sx * rtXyz(P.camRight) + sy * rtXyz(P.camUp));
}

bool rtFinite(vec3 v) {
    return !(isnan(v.x) || isnan(v.y) || isnan(v.z) || isinf(v.x) || isinf(v.y) || isinf(v.z));
}

// One pass per pixel sample: with RT_MULTISAMPLE the host dispatches the pass once per sample
// k = P.sampleIndex and the pass adds the sample, weighted by the filter, to the pixel's sums;
// the host divides by the summed weights (MarchContext::renderPixel does both in one loop; a
// loop over the samples around the march inside the shader lost samples on Mesa 22.3.6's
// llvmpipe: the loop stopped after 2 of 4 iterations at some pixels, PSNR 35.7 dB against the
// CPU: the loop budget above ran out). With RT_RESUMABLE a sample is added in the slice where
// its ray ends. Per pixel, 12 floats: sum w L (RGB), sum w alpha, sum w T (RGB), sum w, sum w
// depth, sum of the weights of the samples with a depth, 2 unused.
void main() {
    int x = int(gl_GlobalInvocationID.x);
    int y = int(gl_GlobalInvocationID.y);
    if (x >= P.width || y >= P.height) return;
#if RT_RESUMABLE
    int j = y * P.width + x;
    // a ray that ended in an earlier slice (or that this sample does not take) is left alone
    if (P.sliceIndex > 0 && rtRayState[j].marching == 0) return;
#endif
    RtField F = rtField();
    PhaseParams phase = rtPhaseParams(P);
    vec3 origin = rtXyz(P.camOrigin);
    uint pixelKey = pcg(uint(x) ^ pcg(uint(y) ^ pcg(P.frameKey)));
    int i = 12 * (y * P.width + x);
#if RT_MULTISAMPLE
    // stratified over the filter's width, each sample weighted by the filter (renderPixel)
    int k = P.sampleIndex;
    int ns = max(1, P.pixelSamples);
    uint key = pcg(pixelKey ^ pcg(uint(k) + 1u));
    float ux = P.jitter != 0 ? hashToUnit(pcg(key ^ 0x1b873593u)) : 0.5f;
    float uy = P.jitter != 0 ? hashToUnit(pcg(key ^ 0x85ebca6bu)) : 0.5f;
    vec2 off = pixelSampleOffset(k, ns, ux, uy, P.filterWidth);
    float w = pixelFilterWeight(P.filterKind, off.x, off.y, P.filterWidth);
    if (!(w > 0.0f)) return;
    float jitter = P.jitter != 0 ? hashToUnit(key) : 0.5f;
    uint rayKey = key;
    vec3 d = rtCameraDirection(float(x) + 0.5f + off.x, float(y) + 0.5f + off.y);
#else
    float w = 1.0f;
    float jitter = P.jitter != 0 ? hashToUnit(pixelKey) : 0.5f;
    uint rayKey = pixelKey;
    vec3 d = rtCameraDirection(float(x) + 0.5f, float(y) + 0.5f);
#endif
#if RT_RESUMABLE
    RtRay ray = rtRayStart();
    if (P.sliceIndex > 0) {
        RtRayState st = rtRayState[j];
        ray.L = rtXyz(st.L);
        ray.T = rtXyz(st.T);
        ray.TF = rtXyz(st.TF);
        ray.depth = st.depth;
        ray.depthSet = st.depthSet != 0;
        ray.started = true;
        ray.n = st.n;
        ray.prev = st.L.w;
    }
    rtMarchRay(F, phase, origin, d, rayKey, jitter, P.sliceSteps, ray);
    if (!rtLoopBudgetHeld()) {
        // this slice's values are cut short: the host renders the frame again
        atomicAdd(loopBudgetSpent, 1u);
        return;
    }
    RtRayState st;
    st.L = vec4(ray.L, ray.prev);
    st.T = vec4(ray.T, 0.0f);
    st.TF = vec4(ray.TF, 0.0f);
    st.depth = ray.depth;
    st.depthSet = ray.depthSet ? 1 : 0;
    st.n = ray.n;
    st.marching = ray.marching ? 1 : 0;
    rtRayState[j] = st;
    if (ray.marching) {
        atomicAdd(unfinished, 1u);
        return;
    }
#else
    RtRay ray = rtRayStart();
    rtMarchRay(F, phase, origin, d, rayKey, jitter, RT_MAX_STEPS, ray);
#endif
    RtSample smp = rtFinishRay(ray, d);
#if RT_MULTISAMPLE
    if (!rtFinite(smp.L)) {
        atomicAdd(nonFinite, 1u);
        return;
    }
#endif
    pixels[i + 0] += w * smp.L.x;
    pixels[i + 1] += w * smp.L.y;
    pixels[i + 2] += w * smp.L.z;
    pixels[i + 3] += w * smp.alpha;
    pixels[i + 4] += w * smp.T.x;
    pixels[i + 5] += w * smp.T.y;
    pixels[i + 6] += w * smp.T.z;
    pixels[i + 7] += w;
    if (smp.depth > 0.0f) {
        pixels[i + 8] += w * smp.depth;
        pixels[i + 9] += w;
    }
}
