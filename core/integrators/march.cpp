#include "core/integrators/march.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/lighting/diffusion.h"
#include "core/lighting/photons.h"
#include "core/lighting/sky_volume.h"

namespace nimbus {

namespace {
/// The share of a camera ray's light below which a sample's single-scattered sky is
/// shadow-marched only at some samples (traceRay): smoke1 at albedo 0.9 with the sky's photons,
/// 640x360, 8 sky directions: 37.7-41.0 s a frame marching every sample, 13.4 s at 0.02 (the
/// images 0.23% apart, two seeds 2.5% apart either way); 12.1 s at 0.03, 11.4 s at 0.05, where
/// MarchSky.SingleScatteredSkyMatchesPathtraceDepthOne's fine steps measured 11.7% and 12.8%
/// against 9.2% (0.02: 9.6%). docs/accuracy.md, "The sky by photons where the medium absorbs".
constexpr float kSkyMarchShare = 0.02f;
/// The most paths of the sun's second scattering one march sample takes
/// (render.photon_second_share)
constexpr int kMaxSecondPaths = 256;

/// A systematic draw over a camera ray's samples by their shares w of its light (the step's
/// opacity times T): a sample with w >= share is always taken; the others lie end to end on a
/// line of their w's, and those a comb of teeth `share` apart (at a random offset per ray)
/// falls on are taken, weighted share / w. Each is taken with probability w / share, so the
/// estimate stays unbiased, and the picks are spread along the ray rather than clumped.
struct ShareComb {
    float share;
    double line = 0.0; ///< the line's length so far
    double tooth;      ///< the next tooth on it
    ShareComb(float s, float offset) : share(s), tooth(double(offset) * s) {}
    /// The weight of a sample whose share is w: 1 at or above the share, share / w where the
    /// comb takes it, else 0.
    float weight(float w) {
        if (w >= share) return 1.0f;
        const double end = line + double(w);
        float scale = 0.0f;
        if (tooth < end) {
            scale = share / w;
            tooth += share;
        }
        line = end;
        return scale;
    }
};
} // namespace

using kern::pcg;

// the in-scatter model crosses into the kernels as an int
static_assert(int(InScatter::None) == kern::INSCATTER_NONE);
static_assert(int(InScatter::Olajos) == kern::INSCATTER_OLAJOS);
static_assert(int(InScatter::Powder) == kern::INSCATTER_POWDER);
static_assert(int(PixelFilter::Box) == kern::FILTER_BOX);
static_assert(int(PixelFilter::Gaussian) == kern::FILTER_GAUSSIAN);
static_assert(int(PixelFilter::BlackmanHarris) == kern::FILTER_BLACKMAN_HARRIS);

MarchContext::MarchContext(const SceneDesc& scene, const FramePlan& plan, const VolumeSet& volumes,
                           const LightVolume* lightVolume, ScatterVolumes scatter,
                           const SurfaceQuery* surfaces, const LightVolume* gateVolume)
    : s_(scene), plan_(plan), vols_(volumes), lightVolume_(lightVolume), gateVolume_(gateVolume),
      volumes_(scatter), surfaces_(surfaces),
      skyIrradiance_(surfaces ? scene.sky : SkyDesc{SkyKind::None}, surfaces ? 65 : 2),
      camera_(scene.camera), medium_(Medium::fromDesc(scene.medium)),
      primary_(plan.step, scene.render.stepGrowth),
      shadow_(plan.shadowStep, scene.render.shadowGrowth), sky_(skyMeans(scene.sky)),
      sigmaTForward_(medium_.sigma_t - plan.forwardFraction * medium_.sigma_s),
      sigmaTMax_(maxComponent(medium_.sigma_t)),
      sigmaTMean_((medium_.sigma_t.x + medium_.sigma_t.y + medium_.sigma_t.z) / 3.0f) {
    // similarity relation (van de Hulst): multiply scattered light sees the medium as isotropic
    // with sigma_s' = sigma_s (1 - g); diffusion decays by sqrt(3 sigma_a' / sigma_t') per
    // transport optical depth (the effective transport coefficient, Jensen et al. 2001)
    for (int c = 0; c < 3; ++c) {
        const float albedo =
            medium_.sigma_tr[c] > 0.0f ? medium_.sigma_sr[c] / medium_.sigma_tr[c] : 1.0f;
        kappa_[c] = std::sqrt(3.0f * std::max(0.0f, 1.0f - albedo));
    }
    frameKey_ = pcg(frameSeedKey(scene, plan) ^ pcg(scene.render.seed));
    if (plan.skySingle)
        for (int k = 0; k < plan.skyDirections; ++k) {
            skyDirs_.push_back(kern::fibonacciDirection(k, plan.skyDirections));
            skyL_.push_back(skyRadiance(scene.sky, skyDirs_.back()) * scene.sky.ambient);
        }
}

void MarchContext::skyWeights(vec3 d, vec3* W) const {
    const int K = int(skyL_.size());
    vec3 sum(0.0f);
    for (int k = 0; k < K; ++k) {
        const vec3 ph = medium_.phase.eval(glm::dot(d, skyDirs_[size_t(k)]));
        W[k] = ph * skyL_[size_t(k)];
        sum += ph;
    }
    const vec3 inv = vec3(1.0f) / glm::max(sum, vec3(1e-30f));
    for (int k = 0; k < K; ++k) W[k] *= inv;
}

vec3 MarchContext::skySingleScatter(vec3 p, const vec3* W) const {
    const int K = int(skyL_.size());
    float tau[kMaxSkyDirections];
    volumes_.sky->sample(p, tau);
    vec3 S(0.0f);
    for (int k = 0; k < K; ++k) S += W[k] * kern::beerLambert(medium_.sigma_t * tau[k]);
    return S;
}

vec3 MarchContext::skyInScatter(vec3 p) const {
    if (!volumes_.up) {
        // cheap occlusion (Olajos 2016): light from the sky dome reaches the top of the
        // layer; near its base half the sphere sees the darker ground instead
        const Box& b = vols_.bounds;
        const float span = std::max(b.hi.y - b.lo.y, 1e-20f);
        const float h = std::clamp((p.y - b.lo.y) / span, 0.0f, 1.0f);
        return kern::skyHeightInScatter(sky_.sphere, h, kAmbientGround);
    }
    return kern::skyColumnInScatter(volumes_.up->sample(p), volumes_.down->sample(p),
                                    medium_.sigma_tr, kappa_, sky_.up, sky_.down,
                                    s_.render.skyOpenness);
}

vec3 MarchContext::skySingleScatterMarched(vec3 p, vec3 d, std::uint32_t rng, RayCounters& cnt,
                                           RayVolumes& rv, float rhoP) const {
    // K directions drawn from the phase function around d, stratified: a 2D Fibonacci lattice
    // ((j + 1/2) / K, j / golden ratio) shifted by a random offset per sample (Cranley-Patterson
    // rotation) drives the phase function's inverse CDF and the azimuth; each direction weighs
    // eval / pdf (1 but for the Mie table) times the sky radiance times the transmittance of a
    // shadow march. Unbiased; measured against fixed directions turned at random per sample,
    // the phase sampling had 0.75x the noise on the default scene (docs/accuracy.md)
    const float ox = kern::hashToUnit(rng = pcg(rng)), oy = kern::hashToUnit(rng = pcg(rng));
    const int K = plan_.skyDirections;
    vec3 S(0.0f);
    for (int j = 0; j < K; ++j) {
        const vec2 u = kern::fibonacciPoint(j, K, vec2(ox, oy));
        // the lobe of two-lobe kinds (and the table's isotropic part) picked at random
        const float lobe = kern::hashToUnit(pcg(rng ^ std::uint32_t(2 * j + 1)));
        const PhaseSample ps = medium_.phase.sample(vec2(u.x, lobe));
        if (!(ps.pdf > 0.0f)) continue;
        const vec3 w = kern::phaseDirection(d, ps.cosTheta, u.y);
        if (surfaces_ && surfaces_->occluded(Ray{p, w}, 1e-4f, std::numeric_limits<float>::max()))
            continue;
        const float tau = densityIntegral(p, w, pcg(rng ^ std::uint32_t(2 * j)), cnt, rv, rhoP);
        S += ps.weight * skyRadiance(s_.sky, w) * kern::beerLambert(medium_.sigma_t * tau);
    }
    return S * (s_.sky.ambient / float(K));
}

namespace {

// The densities around a march step that render.step_tau's test takes besides its own sample's
// (kern::splitDensity): at the sample before, while the visited steps follow each other (0 after
// a stretch skipped as empty, where the density is 0 too), or at a shadow ray's start, and at the
// next step's sample, read ahead. That sample is the one marchSegments visits next, so the density
// read ahead is used when it comes, not read again. (The GLSL march: RtStepper.)
struct StepNeighbours {
    static constexpr std::int64_t kAnyStep = std::numeric_limits<std::int64_t>::min();
    static constexpr std::int64_t kNoStep = kAnyStep + 1;
    std::int64_t prevN = kNoStep; ///< the step prev belongs to (kAnyStep: a shadow ray's start)
    float prev = 0.0f;
    std::int64_t nextN = kNoStep; ///< the step next belongs to
    float next = 0.0f;
    float around = 0.0f; ///< the larger of the current step's neighbours

    /// Starts from a shadow ray's origin, whose density is `rho`: marchSegments' edge steps
    /// then count the first step as following one that saw density where it is above 0.
    EdgeSteps start(float rho) {
        prev = rho;
        prevN = rho > 0.0f ? kAnyStep : kNoStep;
        return rho > 0.0f ? EdgeSteps::kFromStart : EdgeSteps::kEdges;
    }
    /// How many sub-steps a step of length dt, its sample's density rho, is split into, its
    /// optical depth per unit density weighted by `weight` (render.step_tau: kern::substeps).
    /// With `majorant` above 0 (a camera ray's step, the majorant of the cells it reaches
    /// into) the step is also split as a step of that density would be: where the samples miss
    /// a thin sheet of density between them (a cloud's edge seen grazing), its optical depth is
    /// all or nothing with the jitter, and the transmittance too high on average.
    int substeps(float weight, float rho, float dt, float stepTau, float majorant = 0.0f) const {
        return kern::substeps(weight * std::max(kern::splitDensity(rho, around), majorant) * dt,
                              stepTau);
    }
    /// The density at step n's sample ts (the step starting at `from`; 0 without a look where
    /// marchSegments says the sample lies in an empty stretch); with readAhead also at the next
    /// step's sample tNext (-infinity where there is none).
    float visit(RayVolumes& rv, std::int64_t n, float ts, float from, float tNext, bool empty,
                bool readAhead) {
        const float here = empty ? 0.0f : nextN == n ? next : rv.densityAhead(ts, from);
        around = prevN == n - 1 || prevN == kAnyStep ? prev : 0.0f;
        prev = here;
        prevN = n;
        nextN = kNoStep;
        if (readAhead && tNext > ts) {
            next = rv.densityAhead(tNext, from);
            nextN = n + 1;
            around = std::max(around, next);
        }
        return here;
    }
};

} // namespace

float MarchContext::stepMajorant(RayVolumes& rv, float t, float dt, float jitter) const {
    // a step spans a few cells at most: those at its ends and at its sample
    const float tA = t - jitter * dt;
    return std::max(rv.cellMajorant(t), std::max(rv.cellMajorant(tA), rv.cellMajorant(tA + dt)));
}

float MarchContext::sunDensityIntegral(vec3 p, std::uint32_t rng, RayCounters& cnt, RayVolumes& rv,
                                       float rhoP) const {
    return densityIntegral(p, s_.sun.direction, rng, cnt, rv, rhoP);
}

float MarchContext::densityIntegral(vec3 p, vec3 w, std::uint32_t rng, RayCounters& cnt,
                                    RayVolumes& rv, float rhoP, float stopAt, float* tStop) const {
    float tBase = 0.0f;
    const Ray ray{p, w};
    const float jitter = s_.render.jitter ? kern::hashToUnit(pcg(rng)) : 0.5f;
    // stop once the sun is blocked for every channel (transmittance < 1e-5)
    const float tauStop = 11.5f / std::max(minComponent(medium_.sigma_t), 1e-12f);
    if (!rv.begin(vols_, ray, 0.0f, std::numeric_limits<float>::max())) return 0.0f;
    if (rv.tIn() > 0.0f) {
        // from outside every volume (a surface, a gap between instances): the step schedule
        // starts where the volumes do, not at p, so its steps have not grown on the way
        tBase = rv.tIn();
        const Ray entry{ray.at(rv.tIn()), ray.d};
        if (!rv.begin(vols_, entry, 0.0f, std::numeric_limits<float>::max())) return 0.0f;
        rhoP = 0.0f; // (the march starts where it enters, with nothing before it)
    }
    float tau = 0.0f;
    const float sigmaTMin = minComponent(medium_.sigma_t);
    StepNeighbours nb;
    const bool split = plan_.stepTau > 0.0f;
    const EdgeSteps edges =
        split ? nb.start(rhoP >= 0.0f ? rhoP : rv.density(0.0f)) : EdgeSteps::kNone;
    marchSegments(rv, shadow_, rv.tIn(), rv.tOut(), jitter, edges,
                  [&](float t, float dt, std::int64_t n, float tNext, bool empty) {
                      // a step whose optical depth, times the transmittance in front of it, is
                      // above render.step_tau is split (kern::substeps): one jittered point of a
                      // thick step would stand for all of it; behind an opaque stretch the step's
                      // error no longer shows
                      const float rho = nb.visit(rv, n, t, t - jitter * dt, tNext, empty, split);
                      const int k = split ? nb.substeps(std::exp(-sigmaTMin * tau) * sigmaTMax_,
                                                        rho, dt, plan_.stepTau)
                                          : 1;
                      if (k == 1) {
                          if (empty) return true;
                          ++cnt.shadowSamples;
                          if (tStop && rho > 0.0f && tau + rho * dt >= stopAt) {
                              *tStop = tBase + (t - jitter * dt) + (stopAt - tau) / rho;
                              tau = stopAt;
                              return false;
                          }
                          tau += rho * dt;
                      } else {
                          // k sub-steps, each sampled at its own turn of the jitter
                          // (kern::substepOffset)
                          const float h = dt / float(k), t0 = t - jitter * dt;
                          for (int j = 0; j < k && tau <= tauStop; ++j) {
                              ++cnt.shadowSamples;
                              const float rj = rv.density(kern::substepT(t0, h, j, jitter));
                              if (tStop && rj > 0.0f && tau + rj * h >= stopAt) {
                                  *tStop = tBase + t0 + float(j) * h + (stopAt - tau) / rj;
                                  tau = stopAt;
                                  return false;
                              }
                              tau += rj * h;
                          }
                      }
                      return tau <= tauStop;
                  });
    return tau;
}

vec3 MarchContext::secondSun(vec3 p, vec3 d, std::uint32_t rng, RayCounters& cnt,
                             RayVolumes& rv) const {
    // One path from p of up to plan_.secondDepth - 1 vertices: at each, a direction w toward
    // the light's origin drawn from the phase function about the direction the light leaves
    // in (its weight eval / pdf), a flight along w to a collision y sampled by the march's own
    // density integral (the mean channel's extinction; the others weighted by their
    // transmittance over it), and the sun's next-event estimate at y. The estimate at the
    // k-th vertex has the expectation of the in-scattered radiance of the sun's light
    // scattered exactly k + 1 times, per unit phase-normalised scattering at p, as a photon
    // voxel's S(x) holds for the higher orders (core/lighting/photons.h). A flight that
    // escapes or meets a surface ends the path.
    vec3 sum(0.0f), beta(1.0f);
    vec3 x = p, out = d;
    for (int k = 2; k <= plan_.secondDepth; ++k) {
        const float u1 = kern::hashToUnit(rng = pcg(rng)), u2 = kern::hashToUnit(rng = pcg(rng));
        const float u3 = kern::hashToUnit(rng = pcg(rng)), lobe = kern::hashToUnit(rng = pcg(rng));
        const PhaseSample ps = medium_.phase.sample(vec2(u1, lobe));
        if (!(ps.pdf > 0.0f)) break;
        const vec3 w = kern::phaseDirection(out, ps.cosTheta, u2);
        const float target = -std::log(std::max(1.0f - u3, 1e-12f)) / sigmaTMean_;
        float tHit = -1.0f;
        const std::uint64_t flight = cnt.shadowSamples; // (the flights' lookups: their own)
        densityIntegral(x, w, pcg(rng ^ 0x3c6ef372u), cnt, rv, -1.0f, target, &tHit);
        cnt.secondSamples += cnt.shadowSamples - flight;
        cnt.shadowSamples = flight;
        if (!(tHit >= 0.0f)) break;
        if (surfaces_ && surfaces_->occluded(Ray{x, w}, 1e-4f, tHit)) break;
        const vec3 y = x + w * tHit;
        beta *= ps.weight * medium_.sigma_s * glm::exp(-(medium_.sigma_t - sigmaTMean_) * target) /
                sigmaTMean_;
        const float tauSun = sunOpticalDepth(y, pcg(rng ^ 0xa54ff53au), cnt, rv, -1.0f);
        if (std::isfinite(tauSun))
            sum += beta * medium_.phase.eval(glm::dot(w, s_.sun.direction)) *
                   kern::beerLambert(medium_.sigma_t * tauSun);
        x = y;
        out = w;
    }
    return sum * s_.sun.irradiance * s_.render.msStrength;
}

float MarchContext::sunOpticalDepth(vec3 p, std::uint32_t rng, RayCounters& cnt, RayVolumes& rv,
                                    float rhoP) const {
    if (surfaces_ &&
        surfaces_->occluded(Ray{p, s_.sun.direction}, 1e-4f, std::numeric_limits<float>::max()))
        return std::numeric_limits<float>::infinity();
    if (lightVolume_ && lightVolume_->bounds.contains(p)) return lightVolume_->sample(p);
    return sunDensityIntegral(p, rng, cnt, rv, rhoP);
}

vec3 MarchContext::surfaceRadiance(const Ray& ray, const SurfaceHit& hit, std::uint32_t rng,
                                   RayCounters& cnt, RayVolumes& rv) const {
    // Lambertian: albedo / pi times the irradiance of the sun (shadowed by every volume and
    // surface) and of the sky (clouds ignored: an approximation pathtrace does not make)
    const vec3 p = ray.at(hit.t) + hit.normal * (1e-4f * std::max(1.0f, hit.t));
    // (SDF solids: the sky light times their ambient occlusion, the sun's times their soft
    // shadow; other surfaces have ao = 1 and a visibility of 0 or 1)
    vec3 E = skyIrradiance_(hit.normal) * hit.ao;
    const float cosSun = glm::dot(hit.normal, s_.sun.direction);
    const float vis = plan_.shadows && cosSun > 0.0f && surfaces_
                          ? surfaces_->sunVisibility(Ray{p, s_.sun.direction}, 1e-4f,
                                                     std::numeric_limits<float>::max())
                          : 1.0f;
    if (plan_.shadows && cosSun > 0.0f && vis > 0.0f) {
        const float tau = lightVolume_ && lightVolume_->bounds.contains(p)
                              ? lightVolume_->sample(p)
                              : sunDensityIntegral(p, rng, cnt, rv);
        E += s_.sun.irradiance * (cosSun * vis) * kern::beerLambert(medium_.sigma_t * tau);
    }
    return hit.albedo * E * 0.318309886f;
}

MarchContext::Sample MarchContext::traceRay(const Ray& ray, std::uint32_t pixelKey, float jitter,
                                            RayCounters& cnt, Scratch& scratch) const {
    ++cnt.rays;

    const vec3 sunDir = s_.sun.direction;
    const float cosTheta = glm::dot(ray.d, sunDir);
    const RenderDesc& r = s_.render;

    // T: the camera ray's transmittance (alpha, the sky behind, every term but one); TF: the
    // same under sigma_t - f sigma_s, which carries the sun's single scattering when the
    // forward peak is kept in the beams (plan_.forwardFraction = f > 0)
    vec3 L(0.0f), T(1.0f), TF(1.0f);
    const bool forward = plan_.forwardFraction > 0.0f;
    float depth = 0.0f;
    bool depthSet = false;
    const float eps = r.epsilon;

    float tMax = std::numeric_limits<float>::max();
    SurfaceHit hit;
    const bool surface = surfaces_ && surfaces_->intersect(ray, 0.0f, tMax, hit);
    if (surface) tMax = hit.t;

    // the single-scattered sky's weights, computed at the ray's first sample in the medium
    bool skyWeighted = false;
    // the samples whose sky is shadow-marched (plan_.skySingle without the sky volume), by a
    // comb of teeth kSkyMarchShare apart over the samples' shares of the ray's light
    ShareComb skyComb(kSkyMarchShare, kern::hashToUnit(pcg(pixelKey ^ 0x6a09e667u)));
    // the sun's orders from the second (plan_.secondShare, render.photon_second_share): a comb of
    // teeth `share` apart; a sample with w >= share takes ceil(w / share) paths (at most
    // kMaxSecondPaths), so that each path stands for about `share` of the ray's light and a
    // pixel's estimate is the mean of about 1 / share of them
    const float share = plan_.secondShare;
    ShareComb secondComb(share, kern::hashToUnit(pcg(pixelKey ^ 0x510e527fu)));
    RayVolumes& rv = scratch.primary;
    if (rv.begin(vols_, ray, 0.0f, tMax)) {
        // one sample of the march: its position t, the length dt it stands for, its index n
        // (the key of its random numbers), the density there and where t lies in its step (a
        // fraction f). The light is looked at where the step's transmittance puts it
        // (kern::lightFraction), the density at t.
        auto visit = [&](float t, float dt, std::int64_t n, float rho, float f) {
            ++cnt.primarySamples;
            if (rho <= 0.0f) return true;
            const vec3 p = ray.at(t + dt * (kern::lightFraction(f, sigmaTMean_ * rho * dt) - f));
            vec3 S(0.0f), SF(0.0f); // SF: what TF carries
            // past the point where T has fallen below eps (only the forward beam goes on),
            // every term T carries is dropped, as the march itself would stop there
            const bool beamT = !forward || maxComponent(T) >= eps;
            // the sample's share of the camera ray's light (the combs' w), where a comb asks
            auto lightShare = [&] {
                return maxComponent(T * (vec3(1.0f) - glm::exp(-medium_.sigma_t * (rho * dt))));
            };
            if (plan_.shadows && plan_.scatters) {
                const float tau = sunOpticalDepth(
                    p, pcg(pixelKey ^ std::uint32_t(std::uint64_t(n) * 0x9e3779b9ull)), cnt,
                    scratch.shadow, rho);
                if (std::isfinite(tau)) { // not behind a surface
                    vec3 sun(0.0f);
                    float weight = 1.0f, extinction = 1.0f;
                    PhaseFunction octavePhase = medium_.phase;
                    // traced photons carry every higher order: the octaves stand down
                    const int octaves = volumes_.photons || !beamT ? 1 : r.octaves;
                    vec3 sunForward(0.0f), higher(0.0f);
                    for (int i = 0; i < octaves; ++i) {
                        const vec3 ph = octavePhase.eval(cosTheta);
                        // the single scattering (octave 0) in the beams' extinction
                        if (i == 0 && forward)
                            sunForward = kern::octaveSun(ph, sigmaTForward_, tau, 1.0f, 1.0f);
                        else if (i == 0)
                            sun += kern::octaveSun(ph, medium_.sigma_t, tau, weight, extinction);
                        else
                            higher += kern::octaveSun(ph, medium_.sigma_t, tau, weight, extinction);
                        weight *= r.octaveContribution;
                        extinction *= r.octaveExtinction;
                        octavePhase = octavePhase.octave(r.octaveEccentricity);
                    }
                    // the octave gate: the octaves above the first need a cloud along the sun's
                    // line to scatter in (render.octave_gate; the density integral away from
                    // the sun by a second shadow march, or where the sun-depth volume holds p,
                    // that volume read where the line leaves it on the far side)
                    if (octaves > 1 && r.octaveGate > 0.0f && maxComponent(higher) > 0.0f) {
                        float line = tau;
                        if (kern::octaveGateNeedsAway(medium_.sigma_s, r.octaveGate, tau) > 0.0f) {
                            if (gateVolume_ && gateVolume_->bounds.contains(p))
                                line = std::max(tau, gateVolume_->sample(kern::boxExitPoint(
                                                         p, -sunDir, gateVolume_->bounds.lo,
                                                         gateVolume_->bounds.hi)));
                            else
                                line += densityIntegral(
                                    p, -sunDir,
                                    pcg(pixelKey ^ std::uint32_t(std::uint64_t(n) * 0xc2b2ae35ull)),
                                    cnt, scratch.shadow, rho);
                        }
                        higher *= kern::octaveGateFactor(medium_.sigma_s, r.octaveGate, line);
                    }
                    sun += higher;
                    const vec3 in =
                        s_.sun.irradiance * kern::inScatterFactor(int(plan_.inScatter), rho, tau,
                                                                  medium_.sigma_t, r.inScatterC,
                                                                  r.inScatterStrength);
                    S += in * sun;
                    SF = in * sunForward;
                }
            }
            // the light scattered more than once that photons carry: the sun's, and the
            // sky's with render.photon_sky (core/lighting/photons.h)
            if (volumes_.photons && beamT) S += volumes_.photons->sample(p);
            // the sun's light scattered 2 .. plan_.secondDepth times, which the photons leave
            // out (core/lighting/photons.h, PhotonParams::sunRecordFrom): paths from here
            if (share > 0.0f && volumes_.photons && beamT) {
                const float w = lightShare();
                const float scale = secondComb.weight(w);
                const int paths =
                    w > share ? std::min(kMaxSecondPaths, int(std::ceil(w / share))) : 1;
                if (scale > 0.0f)
                    for (int q = 0; q < paths; ++q)
                        S += (scale / float(paths)) *
                             secondSun(p, ray.d,
                                       pcg(pixelKey ^
                                           std::uint32_t(std::uint64_t(n) * 0x27d4eb2full) ^
                                           (0x165667b1u + 0x9e3779b9u * std::uint32_t(q))),
                                       cnt, scratch.shadow);
            }
            // (below the march's tolerance T's terms are not evaluated)
            if (beamT) {
                if (volumes_.diffusion) {
                    // sun light scattered more than once and the sky light it carries
                    // (diffusion.h): the P1 radiance scattered toward the camera by the
                    // phase function
                    vec3 grad[3];
                    const vec3 phi = volumes_.diffusion->sample(p, grad);
                    vec3 ms;
                    for (int c = 0; c < 3; ++c)
                        ms[c] = kern::p1Radiance(phi[c], grad[c], medium_.sigma_tr[c], rho,
                                                 medium_.g, r.msP1, -ray.d);
                    S += ms * kern::NB_INV_4PI;
                }
                // the sky's single scattering (the plan's skySingle: alone, or under sky
                // photons), else its ambient term where no grid carries the sky
                if (volumes_.sky) {
                    if (!skyWeighted) {
                        scratch.skyWeights.resize(skyL_.size());
                        skyWeights(ray.d, scratch.skyWeights.data());
                        skyWeighted = true;
                    }
                    S += skySingleScatter(p, scratch.skyWeights.data());
                } else if (plan_.skySingle) {
                    const float scale = skyComb.weight(lightShare());
                    if (scale > 0.0f)
                        S += scale *
                             skySingleScatterMarched(
                                 p, ray.d,
                                 pcg(pixelKey ^ std::uint32_t(std::uint64_t(n) * 0x85ebca6bull) ^
                                     0x2545f491u),
                                 cnt, scratch.shadow, rho);
                } else if (plan_.ambient && !volumes_.diffusion) {
                    S += skyInScatter(p);
                }
            }
            kern::marchStep(S, medium_.sigma_s, medium_.sigma_t, rho, dt, L, T);
            if (forward) kern::marchStep(SF, medium_.sigma_s, sigmaTForward_, rho, dt, L, TF);
            if (!depthSet && (T.x + T.y + T.z) < 1.5f) {
                depth = t;
                depthSet = true;
            }
            // the forward beam reaches further: it alone decides where the march may stop
            return maxComponent(forward ? TF : T) >= eps;
        };
        StepNeighbours nb;
        marchSegments(rv, primary_, rv.tIn(), rv.tOut(), jitter,
                      plan_.stepTau > 0.0f ? EdgeSteps::kEdges : EdgeSteps::kNone,
                      [&](float t, float dt, std::int64_t n, float tNext, bool empty) {
                          // split as the shadow march's steps are (densityIntegral), by the
                          // transmittance of the beam that carries the light to the camera
                          const float rho = nb.visit(rv, n, t, t - jitter * dt, tNext, empty,
                                                     plan_.stepTau > 0.0f);
                          const int k = nb.substeps(
                              maxComponent(forward ? TF : T) * sigmaTMax_, rho, dt, plan_.stepTau,
                              plan_.stepTau > 0.0f ? stepMajorant(rv, t, dt, jitter) : 0.0f);
                          if (k == 1) return empty || visit(t, dt, n, rho, jitter);
                          const float h = dt / float(k), t0 = t - jitter * dt;
                          for (int j = 0; j < k; ++j) {
                              const float tj = kern::substepT(t0, h, j, jitter);
                              if (!visit(tj, h, substepIndex(n, j), rv.density(tj),
                                         kern::substepOffset(j, jitter)))
                                  return false;
                          }
                          return true;
                      });
    }

    float alpha = 1.0f - (T.x + T.y + T.z) / 3.0f;
    if (surface && hit.holdout) {
        // a matte: nothing of it or behind it, alpha only where the cloud in front is
    } else if (surface) {
        if (maxComponent(T) >= eps)
            L += T * surfaceRadiance(ray, hit, pcg(pixelKey ^ 0x51ed27u), cnt, scratch.shadow);
        alpha = 1.0f;
        if (!depthSet) depth = hit.t;
    } else if (r.background == Background::Sky) {
        L += T * skyRadiance(s_.sky, ray.d);
        alpha = 1.0f;
    }
    return Sample{L, T, alpha, depth};
}

void MarchContext::renderPixel(int x, int y, Framebuffer& fb, RayCounters& cnt,
                               Scratch& scratch) const {
    const std::uint32_t pixelKey = pcg(std::uint32_t(x) ^ pcg(std::uint32_t(y) ^ pcg(frameKey_)));
    const RenderDesc& r = s_.render;
    vec4 out(0.0f);
    vec3 T(0.0f);
    float depth = 0.0f;
    const int n = std::max(1, r.pixelSamples);
    // motion blur: every camera sample, and its shadow rays, at its own time in the shutter
    const bool blur = vols_.shutter.open();
    const float timeOffset = blur ? kern::hashToUnit(pcg(pixelKey ^ 0x7f4a7c15u)) : 0.0f;
    auto setTime = [&](int k) {
        if (!blur) return;
        const float dt = sampleTime(vols_.shutter, std::uint32_t(k), timeOffset);
        scratch.primary.setTime(dt);
        scratch.shadow.setTime(dt);
    };
    if (n == 1) {
        setTime(0);
        // one ray through the pixel centre
        const float jitter = r.jitter ? kern::hashToUnit(pixelKey) : 0.5f;
        const Sample smp = traceRay(camera_.generate(float(x) + 0.5f, float(y) + 0.5f), pixelKey,
                                    jitter, cnt, scratch);
        out = vec4(smp.L, smp.alpha);
        T = smp.T;
        depth = smp.depth;
    } else {
        // stratified over the filter's width, each sample weighted by the filter; every sample
        // has its own stream (its jitter along the ray, its shadow rays)
        float wSum = 0.0f, depthW = 0.0f;
        for (int k = 0; k < n; ++k) {
            if ((k & 15) == 15 && cancelRequested(vols_.cancel)) break; // core/cancel.h
            const std::uint32_t key = pcg(pixelKey ^ pcg(std::uint32_t(k) + 1u));
            const float ux = r.jitter ? kern::hashToUnit(pcg(key ^ 0x1b873593u)) : 0.5f;
            const float uy = r.jitter ? kern::hashToUnit(pcg(key ^ 0x85ebca6bu)) : 0.5f;
            const vec2 o = kern::pixelSampleOffset(k, n, ux, uy, r.filterWidth);
            const float w = kern::pixelFilterWeight(int(r.filter), o.x, o.y, r.filterWidth);
            if (!(w > 0.0f)) continue;
            const float jitter = r.jitter ? kern::hashToUnit(key) : 0.5f;
            setTime(k);
            const Sample smp =
                traceRay(camera_.generate(float(x) + 0.5f + o.x, float(y) + 0.5f + o.y), key,
                         jitter, cnt, scratch);
            if (!(std::isfinite(smp.L.x) && std::isfinite(smp.L.y) && std::isfinite(smp.L.z))) {
                ++cnt.nonFinite;
                continue;
            }
            out += w * vec4(smp.L, smp.alpha);
            T += w * smp.T;
            wSum += w;
            if (smp.depth > 0.0f) {
                depth += w * smp.depth;
                depthW += w;
            }
        }
        if (wSum > 0.0f) {
            out /= wSum;
            T /= wSum;
        }
        if (depthW > 0.0f) depth /= depthW;
    }
    const bool finite = std::isfinite(out.x) && std::isfinite(out.y) && std::isfinite(out.z) &&
                        std::isfinite(out.w);
    if (!finite) {
        ++cnt.nonFinite;
        out = vec4(0.0f);
    }
    const size_t i = size_t(y) * fb.width + x;
    fb.rgba[4 * i + 0] = out.x;
    fb.rgba[4 * i + 1] = out.y;
    fb.rgba[4 * i + 2] = out.z;
    fb.rgba[4 * i + 3] = out.w;
    if (fb.aovs.transmittance) {
        fb.transmittance[3 * i + 0] = T.x;
        fb.transmittance[3 * i + 1] = T.y;
        fb.transmittance[3 * i + 2] = T.z;
    }
    if (fb.aovs.depth) fb.depth[i] = depth;
}

} // namespace nimbus
