#include "core/integrators/pathtrace.h"

#include "core/media/sky.h"
#include "core/tracking/tracking.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nimbus {

namespace {

constexpr float kInf = std::numeric_limits<float>::max();
/// The shadow roulette: estimated transmittances below this are traced with probability T / it.
constexpr float kShadowRouletteT = 0.1f;
/// and never with a probability below this (a bound on the weight 1 / q where the estimate
/// is wrong, e.g. behind a gap the sun-depth volume's interpolation smeared over).
constexpr float kMinShadowProbability = 0.05f;

/// Keeps the path weights as ratios (pbrt-v4's beta and r_u): the estimate of channel c is
/// f_c / mean(p), unchanged when both are divided by the same number, so they are divided by
/// mean(p) at every event. Multiplied raw, both underflow to 0 after a few hundred null
/// collisions in thick media, and 0/0 lost the whole sample (13% of them on a dense cloud).
/// mean(p) > 0: the hero channel's probability of the event it chose is a factor of it.
inline void rescale(vec3& f, vec3& p) {
    const float m = meanComponent(p);
    f /= m;
    p /= m;
}

} // namespace

PathContext::PathContext(const SceneDesc& scene, const FramePlan& plan, const VolumeSet& volumes,
                         const SurfaceQuery* surfaces, const LightVolume* sunDepth)
    : s_(scene), plan_(plan), vols_(volumes), surfaces_(surfaces), camera_(scene.camera),
      medium_(Medium::fromDesc(scene.medium)), sunDepth_(sunDepth),
      sigmaTMin_(std::min(medium_.sigma_t.x, std::min(medium_.sigma_t.y, medium_.sigma_t.z))) {
    frameKey_ = kern::pcg(frameSeedKey(scene, plan) ^ kern::pcg(scene.render.seed ^ 0x5bd1e995u));
    if (scene.sun.angularDiameter > 0.0f) {
        sunCosMax_ = std::cos(glm::radians(0.5f * scene.sun.angularDiameter));
        sunWeight_ = 2.0f / (1.0f + sunCosMax_);
    }
}

vec3 PathContext::sunDirection(Sampler& rng) const {
    if (!(sunCosMax_ < 1.0f)) return s_.sun.direction;
    const float u0 = rng.next(), u1 = rng.next();
    return kern::phaseDirection(s_.sun.direction, 1.0f - u0 * (1.0f - sunCosMax_), u1);
}

float PathContext::sunShadowProbability(vec3 p) const {
    if (!sunDepth_ || !(sigmaTMin_ > 0.0f)) return 1.0f;
    // The volume holds the density integral toward the sun at voxel centres, read
    // trilinearly, so within a voxel of p it can be off by the density crossed there: it is
    // read one voxel diagonal closer to the sun, which leaves out the stretch where the
    // interpolation is unsure (and errs toward tracing)
    const vec3 q = p + s_.sun.direction * glm::length(sunDepth_->voxel);
    const float depth = sunDepth_->sample(q) * sigmaTMin_;
    // an estimated transmittance of 0.1 or more: always traced (the ratio tracking's own
    // roulette starts there); below, traced with probability T / 0.1, so the weighted
    // estimate stays near 0.1 times the estimate's error
    return std::clamp(std::exp(-depth) / kShadowRouletteT, kMinShadowProbability, 1.0f);
}

template <class F>
bool PathContext::sampleCollisions(const Ray& ray, float tmax, Sampler& rng, RayVolumes& rv,
                                   F&& visit) const {
    if (medium_.sigma_t_max <= 0.0f || !rv.begin(vols_, ray, 0.0f, tmax)) return true;
    return sampleTmaj(rv, medium_.sigma_t_max, rng,
                      [&](float t, const MajorantSegment&, float sigmaMaj) {
                          return visit(t, rv.density(t), sigmaMaj);
                      });
}

PathContext::Event PathContext::track(const Ray& ray, float tmax, Sampler& rng, int hero, vec3& f,
                                      vec3& p, float& tHit, RayCounters& cnt,
                                      Scratch& scratch) const {
    Event ev = Event::Escaped;
    sampleCollisions(ray, tmax, rng, scratch.rv, [&](float t, float rho, float sigmaMaj) {
        ++cnt.primarySamples;
        // event probabilities of every channel's own delta tracking; the hero channel's choose
        // the event, the path pdf of each channel is kept for spectral MIS
        const vec3 pS = medium_.sigma_s * rho / sigmaMaj, pA = medium_.sigma_a * rho / sigmaMaj;
        const vec3 pN = vec3(1.0f) - pS - pA;
        const float u = rng.next();
        if (u < pA[hero]) {
            ev = Event::Absorbed; // no emission: the path ends
            return false;
        }
        if (u < pA[hero] + pS[hero]) {
            f *= pS;
            p *= pS;
            rescale(f, p);
            tHit = t;
            ev = Event::Scattered;
            return false;
        }
        f *= pN;
        p *= pN;
        rescale(f, p);
        return true;
    });
    return ev;
}

vec3 PathContext::visibility(vec3 p, vec3 d, Sampler& rng, RayCounters& cnt,
                             Scratch& scratch) const {
    if (surfaces_ && surfaces_->occluded(Ray{p, d}, 1e-4f, kInf)) return vec3(0.0f);
    return transmittance(p, d, rng, cnt, scratch);
}

vec3 PathContext::transmittance(vec3 p, vec3 d, Sampler& rng, RayCounters& cnt, Scratch& scratch,
                                float tmax) const {
    vec3 T(1.0f);
    sampleCollisions(Ray{p, d}, tmax, rng, scratch.rv, [&](float, float rho, float sigmaMaj) {
        ++cnt.shadowSamples;
        T *= vec3(1.0f) - medium_.sigma_t * rho / sigmaMaj;
        // Russian roulette on small transmittance keeps the estimator unbiased
        const float m = maxComponent(T);
        if (m < 0.1f) {
            const float q = 1.0f - m / 0.1f;
            if (rng.next() < q) {
                T = vec3(0.0f);
                return false;
            }
            T /= 1.0f - q;
        }
        return true;
    });
    return T;
}

vec3 PathContext::tracePath(const Ray& cameraRay, Sampler& rng, vec3& Tcam, float& alphaOut,
                            float& depthOut, RayCounters& cnt, Scratch& scratch) const {
    const bool sky = s_.sky.kind != SkyKind::None;
    constexpr float kSkyPdf = 0.0795774715459f; // uniform sphere, 1 / (4 pi)
    constexpr float kInvPi = 0.318309886184f;

    SurfaceHit hit;
    float tSurf = kInf;
    bool surf = surfaces_ && surfaces_->intersect(cameraRay, 0.0f, kInf, hit);
    if (surf) tSurf = hit.t;

    // camera-ray transmittance for alpha and the AOV (ratio tracking, independent stream),
    // tracked only when one of them needs it (an opaque pixel without the AOV does not)
    const bool opaque =
        (surf && !hit.holdout) || (!surf && s_.render.background == Background::Sky);
    Sampler trng{rng.key ^ 0xa511e9b3u, 0};
    Tcam = opaque && !plan_.aovs.transmittance
               ? vec3(0.0f)
               : transmittance(cameraRay.o, cameraRay.d, trng, cnt, scratch, tSurf);
    depthOut = 0.0f;
    alphaOut = opaque ? 1.0f : std::clamp(1.0f - meanComponent(Tcam), 0.0f, 1.0f);

    // Spectral MIS (one-sample over the channel that drives the tracking): f is the path
    // throughput and p the path pdf under each channel's own tracking; the estimate of channel
    // c is f_c / mean(p). For grey media f == p and every weight is 1.
    const int hero = std::min(2, int(rng.next() * 3.0f));
    vec3 L(0.0f), f(1.0f), p(1.0f);
    Ray ray = cameraRay;
    float lastPhasePdf = 0.0f; // pdf of the phase sample that made the current ray
    float lastSkyPdf = 0.0f;   // pdf of the sky's next-event estimation at its vertex (0: none)
    bool fromSurface = false;  // the current ray left a surface (no sky NEE was taken there)
    for (int depth = 0;; ++depth) {
        if (depth > 0) {
            surf = surfaces_ && surfaces_->intersect(ray, 1e-4f, kInf, hit);
            tSurf = surf ? hit.t : kInf;
        }
        float t = 0.0f;
        const Event ev = track(ray, tSurf, rng, hero, f, p, t, cnt, scratch);
        if (ev == Event::Absorbed) break;
        const vec3 beta = f / meanComponent(p);
        if (ev == Event::Escaped && surf) {
            // an opaque diffuse surface (a holdout absorbs: it is a black matte for paths)
            if (hit.holdout) break;
            const vec3 pos = ray.at(hit.t) + hit.normal * (1e-4f * std::max(1.0f, hit.t));
            if (depth == 0) depthOut = hit.t;
            const vec3 sunDir = plan_.shadows ? sunDirection(rng) : s_.sun.direction;
            const float cosSun = glm::dot(hit.normal, sunDir);
            if (plan_.shadows && cosSun > 0.0f)
                L += beta * hit.albedo * (kInvPi * cosSun * sunWeight_) * s_.sun.irradiance *
                     visibility(pos, sunDir, rng, cnt, scratch);
            // cosine-weighted bounce: weight albedo
            const float u0 = rng.next(), u1 = rng.next();
            const vec3 d = kern::phaseDirection(hit.normal, std::sqrt(u0), u1);
            if (depth + 1 >= s_.render.maxDepth) {
                // the last vertex: its sky light through the bounce ray (no sky NEE at
                // surfaces), the transmittance standing in for tracking to the escape
                if (sky)
                    L += beta * hit.albedo * skyRadiance(s_.sky, d) *
                         visibility(pos, d, rng, cnt, scratch);
                break;
            }
            ray = Ray{pos, d};
            f *= hit.albedo;
            fromSurface = true;
        } else if (ev == Event::Escaped) {
            if (depth == 0) {
                if (s_.render.background == Background::Sky) L += beta * skyRadiance(s_.sky, ray.d);
            } else if (sky) {
                const float w = fromSurface ? 1.0f : lastPhasePdf / (lastPhasePdf + lastSkyPdf);
                L += beta * skyRadiance(s_.sky, ray.d) * w;
            }
            break;
        } else {
            const vec3 pos = ray.at(t);
            if (depth == 0) depthOut = t;

            // next-event estimation: the sun, its shadow ray traced with probability q and
            // weighted by 1 / q (the shadow roulette; q = 1 without it)
            if (plan_.shadows) {
                const float q = sunShadowProbability(pos);
                if (q >= 1.0f || rng.next() < q) {
                    const vec3 sunDir = sunDirection(rng);
                    const vec3 ph = medium_.phase.eval(glm::dot(ray.d, sunDir));
                    L += beta * s_.sun.irradiance * ph *
                         visibility(pos, sunDir, rng, cnt, scratch) * sunWeight_ / q;
                }
            }
            // next-event estimation: the sky (render.sky_nee), MIS with phase sampling by the
            // balance heuristic; without it the sky is reached by the phase-sampled rays alone
            // (weight 1), which measured lower noise at a third of the lookups on Nimbus'
            // smooth skies (uniform-sphere directions sample phase x sky worse than the phase
            // does, and each costs a shadow ray)
            const bool skyNee = sky && plan_.skyNee;
            if (skyNee) {
                const float z = 1.0f - 2.0f * rng.next();
                const vec3 wi = kern::phaseDirection(vec3(0.0f, 0.0f, 1.0f), z, rng.next());
                const float cosTheta = glm::dot(ray.d, wi);
                const float w = kSkyPdf / (kSkyPdf + medium_.phase.pdf(cosTheta));
                const vec3 Tr = visibility(pos, wi, rng, cnt, scratch);
                L += beta * skyRadiance(s_.sky, wi) * Tr * medium_.phase.eval(cosTheta) *
                     (w / kSkyPdf);
            }
            lastSkyPdf = skyNee ? kSkyPdf : 0.0f;
            // continue by sampling the phase function (the same direction for every channel, so
            // its weight eval / pdf goes into the throughput alone)
            const float u0 = rng.next(), u1 = rng.next();
            const PhaseSample ps = medium_.phase.sample(vec2(u0, u1));
            if (!(ps.pdf > 0.0f)) break;
            const vec3 d = kern::phaseDirection(ray.d, ps.cosTheta, rng.next());
            if (depth + 1 >= s_.render.maxDepth) {
                // the last vertex: the phase-sampled half of the sky's MIS pair, the
                // transmittance standing in for tracking to the escape (without it the sky
                // lost the phase-sampled share at max_depth: 0.75 of it at max_depth = 1)
                if (sky)
                    L += beta * ps.weight * skyRadiance(s_.sky, d) *
                         visibility(pos, d, rng, cnt, scratch) * (ps.pdf / (ps.pdf + lastSkyPdf));
                break;
            }
            f *= ps.weight;
            lastPhasePdf = ps.pdf;
            fromSurface = false;
            ray = Ray{pos, d};
        }
        // Russian roulette only on throughput below 1 (pbrt-v4): a floor on q would divide an
        // albedo-1 path's weight by 1 - q at every bounce (0.95^-200 = 3e4 after 200 bounces
        // in thick cloud), unbiased but with fireflies that dominated the references' error
        const float m = maxComponent(f / meanComponent(p)); // meanComponent(p) = 1 up to rounding
        if (depth + 1 >= s_.render.rrDepth && m < 1.0f) {
            const float q = 1.0f - m;
            if (rng.next() < q) break;
            f /= 1.0f - q;
        }
    }
    return L;
}

void PathContext::renderPixel(int x, int y, Framebuffer& fb, RayCounters& cnt,
                              Scratch& scratch) const {
    const int spp = std::max(1, s_.render.spp);
    const RenderDesc& r = s_.render;
    vec3 L(0.0f), T(0.0f);
    double depthSum = 0.0;
    float alphaSum = 0.0f, wSum = 0.0f;
    int depthCount = 0;
    // motion blur: one time per path, for every ray of it (scratch.rv walks them all)
    const bool blur = vols_.shutter.open();
    const float timeOffset =
        blur ? kern::hashToUnit(Sampler::forPixel(x, y, frameKey_, 0x7f4a7c15u).key) : 0.0f;
    for (int s = 0; s < spp; ++s) {
        // a frame of millions of samples per pixel stops within a few samples of a cancel
        if ((s & 15) == 15 && cancelRequested(vols_.cancel)) break;
        Sampler rng = Sampler::forPixel(x, y, frameKey_, std::uint32_t(s));
        if (blur) scratch.rv.setTime(sampleTime(vols_.shutter, std::uint32_t(s), timeOffset));
        // uniform over the filter's width, weighted by the filter (box of width 1: the pixel)
        const float ox = r.jitter ? (rng.next() - 0.5f) * r.filterWidth : 0.0f;
        const float oy = r.jitter ? (rng.next() - 0.5f) * r.filterWidth : 0.0f;
        const float w = kern::pixelFilterWeight(int(r.filter), ox, oy, r.filterWidth);
        const Ray ray = camera_.generate(float(x) + 0.5f + ox, float(y) + 0.5f + oy);
        ++cnt.rays;
        vec3 Ts;
        float depth, a;
        vec3 Ls = tracePath(ray, rng, Ts, a, depth, cnt, scratch);
        if (!(std::isfinite(Ls.x) && std::isfinite(Ls.y) && std::isfinite(Ls.z))) {
            ++cnt.nonFinite;
            Ls = vec3(0.0f);
        }
        alphaSum += w * a;
        L += w * Ls;
        T += w * Ts;
        wSum += w;
        if (depth > 0.0f) {
            depthSum += depth;
            ++depthCount;
        }
    }
    if (wSum > 0.0f) {
        L /= wSum;
        T /= wSum;
        alphaSum /= wSum;
    }
    const size_t i = size_t(y) * fb.width + x;
    const float alpha = alphaSum;
    fb.rgba[4 * i + 0] = L.x;
    fb.rgba[4 * i + 1] = L.y;
    fb.rgba[4 * i + 2] = L.z;
    fb.rgba[4 * i + 3] = alpha;
    if (fb.aovs.transmittance) {
        fb.transmittance[3 * i + 0] = T.x;
        fb.transmittance[3 * i + 1] = T.y;
        fb.transmittance[3 * i + 2] = T.z;
    }
    // depth of the first real collision, averaged over the samples that had one
    if (fb.aovs.depth) fb.depth[i] = depthCount ? float(depthSum / depthCount) : 0.0f;
}

} // namespace nimbus
