#include "core/march.h"

#include "core/diffusion.h"
#include "core/photons.h"
#include "core/sky.h"

#include <algorithm>
#include <limits>

#include "core/phase.h"

namespace nimbus {

using kern::pcg;

MarchContext::MarchContext(const SceneDesc& scene, const FramePlan& plan, const VolumeSet& volumes,
                           const LightVolume* lightVolume, ScatterVolumes scatter,
                           const SurfaceQuery* surfaces)
    : s_(scene), plan_(plan), vols_(volumes), lightVolume_(lightVolume), volumes_(scatter),
      surfaces_(surfaces),
      skyIrradiance_(surfaces ? scene.sky : SkyDesc{SkyKind::None}, surfaces ? 65 : 2),
      camera_(scene.camera), phase_(PhaseFunction::fromMedium(scene.medium)),
      primary_(scene.render.step, scene.render.stepGrowth),
      shadow_(scene.render.shadowStep, scene.render.shadowGrowth) {
    sigmaS_ = scene.medium.sigma_s * scene.medium.densityScale;
    sigmaT_ = (scene.medium.sigma_s + scene.medium.sigma_a) * scene.medium.densityScale;
    // mean sky radiance over the sphere, the in-scattered ambient of an isotropic medium
    switch (scene.sky.kind) {
    case SkyKind::None:
        ambient_ = vec3(0.0f);
        break;
    case SkyKind::Uniform:
        ambient_ = scene.sky.zenith * scene.sky.ambient;
        break;
    case SkyKind::Gradient:
        ambient_ = 0.5f * (scene.sky.zenith + scene.sky.horizon) * scene.sky.ambient;
        break;
    }
    // the sky over each hemisphere: a gradient sky mixes horizon and zenith by sqrt(y), whose
    // mean over the upper hemisphere (y uniform in [0, 1]) is 2/3; below the horizon it is the
    // horizon radiance
    skyUp_ = skyDown_ = ambient_;
    if (scene.sky.kind == SkyKind::Gradient) {
        skyUp_ = (scene.sky.horizon + 2.0f * scene.sky.zenith) / 3.0f * scene.sky.ambient;
        skyDown_ = scene.sky.horizon * scene.sky.ambient;
    }
    // similarity relation (van de Hulst): multiply scattered light sees the medium as isotropic
    // with sigma_s' = sigma_s (1 - g); diffusion decays by sqrt(3 sigma_a' / sigma_t') per
    // transport optical depth (the effective transport coefficient, Jensen et al. 2001)
    const float g = g_ = phase_.meanCosine();
    const vec3 sigmaSr = scene.medium.sigma_s * (1.0f - g) * scene.medium.densityScale;
    sigmaTr_ = sigmaSr + scene.medium.sigma_a * scene.medium.densityScale;
    for (int c = 0; c < 3; ++c) {
        const float albedo = sigmaTr_[c] > 0.0f ? sigmaSr[c] / sigmaTr_[c] : 1.0f;
        kappa_[c] = std::sqrt(3.0f * std::max(0.0f, 1.0f - albedo));
    }
    frameKey_ = pcg(std::uint32_t(plan.frame) ^ pcg(scene.render.seed));
}

vec3 MarchContext::skyInScatter(vec3 p) const {
    if (!volumes_.up) {
        // cheap occlusion (Olajos 2016): light from the sky dome reaches the top of the
        // layer; near its base half the sphere sees the darker ground instead
        const Box& b = vols_.bounds;
        const float span = std::max(b.hi.y - b.lo.y, 1e-20f);
        const float h = std::clamp((p.y - b.lo.y) / span, 0.0f, 1.0f);
        return ambient_ * (kAmbientGround + (1.0f - kAmbientGround) * h);
    }
    // Each hemisphere's sky weighted by the openness of the column above / below; the weights
    // are normalised, so an albedo-1 medium under a uniform sky returns that sky (the white
    // furnace: multiply scattered light fills a conservative cloud evenly); absorption decays
    // the light with the transport depth to the nearer open side.
    const float up = volumes_.up->sample(p), down = volumes_.down->sample(p);
    vec3 L;
    for (int c = 0; c < 3; ++c) {
        const float tu = sigmaTr_[c] * up, td = sigmaTr_[c] * down;
        const float share = kern::skyUpperShare(tu, td, s_.render.skyOpenness);
        L[c] = glm::mix(skyDown_[c], skyUp_[c], share) * std::exp(-kappa_[c] * std::min(tu, td));
    }
    return L;
}

vec3 MarchContext::skyRadiance(vec3 d) const {
    return nimbus::skyRadiance(s_.sky, d);
}

float MarchContext::sunDensityIntegral(vec3 p, std::uint32_t rng, MarchCounters& cnt) const {
    const Ray ray{p, s_.sun.direction};
    const float jitter = s_.render.jitter ? kern::hashToUnit(pcg(rng)) : 0.5f;
    // stop once the sun is blocked for every channel (transmittance < 1e-5)
    const float tauStop = 11.5f / std::max(minComponent(sigmaT_), 1e-12f);
    RayVolumes rv;
    if (!rv.begin(vols_, ray, 0.0f, std::numeric_limits<float>::max())) return 0.0f;
    if (rv.tIn() > 0.0f) {
        // from outside every volume (a surface, a gap between instances): the step schedule
        // starts where the volumes do, not at p, so its steps have not grown on the way
        const Ray entry{ray.at(rv.tIn()), ray.d};
        if (!rv.begin(vols_, entry, 0.0f, std::numeric_limits<float>::max())) return 0.0f;
    }
    float tau = 0.0f;
    marchSegments(rv, shadow_, rv.tIn(), rv.tOut(), jitter, [&](float t, float dt, std::int64_t) {
        ++cnt.shadowSamples;
        tau += rv.density(t) * dt;
        return tau <= tauStop;
    });
    return tau;
}

float MarchContext::sunOpticalDepth(vec3 p, std::uint32_t rng, MarchCounters& cnt) const {
    if (surfaces_ &&
        surfaces_->occluded(Ray{p, s_.sun.direction}, 1e-4f, std::numeric_limits<float>::max()))
        return std::numeric_limits<float>::infinity();
    if (lightVolume_ && lightVolume_->bounds.contains(p)) return lightVolume_->sample(p);
    return sunDensityIntegral(p, rng, cnt);
}

vec3 MarchContext::surfaceRadiance(const Ray& ray, const SurfaceHit& hit, std::uint32_t rng,
                                   MarchCounters& cnt) const {
    // Lambertian: albedo / pi times the irradiance of the sun (shadowed by every volume and
    // surface) and of the sky (clouds ignored: an approximation pathtrace does not make)
    const vec3 p = ray.at(hit.t) + hit.normal * (1e-4f * std::max(1.0f, hit.t));
    vec3 E = skyIrradiance_(hit.normal);
    const float cosSun = glm::dot(hit.normal, s_.sun.direction);
    if (plan_.shadows && cosSun > 0.0f)
        E += s_.sun.irradiance * cosSun * kern::beerLambert(sigmaT_ * sunOpticalDepth(p, rng, cnt));
    return hit.albedo * E * 0.318309886f;
}

float MarchContext::inScatterFactor(float rho, float tau) const {
    switch (s_.render.inScatter) {
    case InScatter::None:
        return 1.0f;
    case InScatter::Olajos:
        // Olajos 2016: in-scatter probability S(d) = 1 - e^{-c d} of the local density
        return glm::mix(1.0f, kern::inScatterOlajos(rho, s_.render.inScatterC),
                        s_.render.inScatterStrength);
    case InScatter::Powder: {
        // Schneider 2015: beer-powder 2 e^{-d}(1 - e^{-2d}) = Beer * 2 (1 - e^{-2d}), d the
        // mean optical depth toward the sun
        const float d = tau * (sigmaT_.x + sigmaT_.y + sigmaT_.z) / 3.0f;
        return glm::mix(1.0f, 2.0f * (1.0f - std::exp(-2.0f * d)), s_.render.inScatterStrength);
    }
    }
    return 1.0f;
}

void MarchContext::renderPixel(int x, int y, Framebuffer& fb, MarchCounters& cnt) const {
    const std::uint32_t pixelKey = pcg(std::uint32_t(x) ^ pcg(std::uint32_t(y) ^ pcg(frameKey_)));
    const float jitter = s_.render.jitter ? kern::hashToUnit(pixelKey) : 0.5f;
    const Ray ray = camera_.generate(float(x) + 0.5f, float(y) + 0.5f);
    ++cnt.rays;

    const vec3 sunDir = s_.sun.direction;
    const float cosTheta = glm::dot(ray.d, sunDir);

    vec3 L(0.0f), T(1.0f);
    float depth = 0.0f;
    bool depthSet = false;
    const float eps = s_.render.epsilon;

    float tMax = std::numeric_limits<float>::max();
    SurfaceHit hit;
    const bool surface = surfaces_ && surfaces_->intersect(ray, 0.0f, tMax, hit);
    if (surface) tMax = hit.t;

    RayVolumes rv;
    if (rv.begin(vols_, ray, 0.0f, tMax)) {
        marchSegments(
            rv, primary_, rv.tIn(), rv.tOut(), jitter, [&](float t, float dt, std::int64_t n) {
                const vec3 p = ray.at(t);
                ++cnt.primarySamples;
                const float rho = rv.density(t);
                if (rho <= 0.0f) return true;
                vec3 S(0.0f);
                if (plan_.shadows) {
                    const float tau =
                        sunOpticalDepth(p, pcg(pixelKey ^ std::uint32_t(n * 0x9e3779b9ll)), cnt);
                    if (std::isfinite(tau)) { // not behind a surface
                        vec3 sun(0.0f);
                        float weight = 1.0f, extinction = 1.0f;
                        PhaseFunction octavePhase = phase_;
                        // traced photons carry every higher order: the octaves stand down
                        const int octaves = volumes_.photons ? 1 : s_.render.octaves;
                        for (int i = 0; i < octaves; ++i) {
                            sun += weight * octavePhase.eval(cosTheta) *
                                   kern::beerLambert(sigmaT_ * (tau * extinction));
                            weight *= s_.render.octaveContribution;
                            extinction *= s_.render.octaveExtinction;
                            octavePhase = octavePhase.octave(s_.render.octaveEccentricity);
                        }
                        S += s_.sun.irradiance * sun * inScatterFactor(rho, tau);
                    }
                    // the sun light scattered more than once (core/photons.h)
                    if (volumes_.photons) S += volumes_.photons->sample(p);
                }
                if (volumes_.diffusion) {
                    // sun light scattered more than once and all sky light (core/diffusion.h): the
                    // P1 radiance (phi + 3 F.w) / 4 pi, F = -D grad phi the net flux, D = 1 / 3
                    // sigma_t', scattered toward the camera by the phase function, whose first
                    // moment is g: S = (phi + 3 g F.w_o) / 4 pi, |F| <= phi (flux limit)
                    vec3 grad[3];
                    const vec3 phi = volumes_.diffusion->sample(p, grad);
                    vec3 ms;
                    for (int c = 0; c < 3; ++c) {
                        vec3 F = -grad[c] / (3.0f * sigmaTr_[c] * rho + 1e-30f);
                        const float len = glm::length(F);
                        if (len > phi[c]) F *= phi[c] / len;
                        ms[c] = std::max(0.0f,
                                         phi[c] + 3.0f * g_ * s_.render.msP1 * glm::dot(F, -ray.d));
                    }
                    S += ms * kern::NB_INV_4PI;
                } else if (plan_.ambient) {
                    S += skyInScatter(p);
                }
                kern::integrateStep(S * (sigmaS_ * rho), sigmaT_ * rho, dt, L, T);
                if (!depthSet && (T.x + T.y + T.z) < 1.5f) {
                    depth = t;
                    depthSet = true;
                }
                return maxComponent(T) >= eps;
            });
    }

    float alpha = 1.0f - (T.x + T.y + T.z) / 3.0f;
    if (surface && hit.holdout) {
        // a matte: nothing of it or behind it, alpha only where the cloud in front is
    } else if (surface) {
        if (maxComponent(T) >= eps)
            L += T * surfaceRadiance(ray, hit, pcg(pixelKey ^ 0x51ed27u), cnt);
        alpha = 1.0f;
        if (!depthSet) depth = hit.t;
    } else if (s_.render.background == Background::Sky) {
        L += T * skyRadiance(ray.d);
        alpha = 1.0f;
    }
    vec4 out(L, alpha);
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
