/// @file sky.h
/// @brief Sky radiance by direction: uniform, or a gradient from the horizon (and below) to the
/// zenith. Shared by every integrator.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/kernels/kernels.h"
#include "core/scene.h"

namespace nimbus {

/// The sky's radiance toward the unit direction d: the kernel skyRadianceToward
/// (core/kernels/lighting.glsl), which the GPU pass runs too.
inline vec3 skyRadiance(const SkyDesc& sky, vec3 d) {
    return kern::skyRadianceToward(int(sky.kind), sky.zenith, sky.horizon, d);
}

/// Mean sky radiance over the sphere and over the upper and lower hemispheres, times the sky's
/// ambient scale: what an isotropic medium in-scatters (march's ambient term; the diffusion's
/// boundary takes skyBoundaryRadiance below). A gradient sky mixes horizon and zenith by sqrt(y),
/// whose mean over the upper hemisphere (y uniform in [0, 1]) is 2/3; below the horizon it is the
/// horizon radiance.
struct SkyMeans {
    vec3 sphere{0.0f};
    vec3 up{0.0f};
    vec3 down{0.0f};
};

inline SkyMeans skyMeans(const SkyDesc& sky) {
    SkyMeans m;
    switch (sky.kind) {
    case SkyKind::None:
        return m;
    case SkyKind::Uniform:
        m.sphere = sky.zenith * sky.ambient;
        m.up = m.down = m.sphere;
        return m;
    case SkyKind::Gradient:
        m.sphere = 0.5f * (sky.zenith + sky.horizon) * sky.ambient;
        m.up = (sky.horizon + 2.0f * sky.zenith) / 3.0f * sky.ambient;
        m.down = sky.horizon * sky.ambient;
        return m;
    }
    return m;
}

/// Irradiance of the sky on a surface by normal: the cosine-weighted integral of skyRadiance
/// over the hemisphere around n, ignoring clouds. The sky depends on d.y only, so the
/// irradiance depends on n.y only: tabulated once, interpolated.
class SkyIrradiance {
  public:
    explicit SkyIrradiance(const SkyDesc& sky, int entries = 65) : table_(size_t(entries)) {
        constexpr float kPi = std::numbers::pi_v<float>;
        const int nt = 48, np = 96; // midpoint quadrature over (cos theta, phi)
        for (int e = 0; e < entries; ++e) {
            const float ny = -1.0f + 2.0f * float(e) / float(entries - 1);
            const vec3 n(std::sqrt(std::max(0.0f, 1.0f - ny * ny)), ny, 0.0f);
            // orthonormal frame around n
            const vec3 a = std::abs(n.y) < 0.9f ? vec3(0.0f, 1.0f, 0.0f) : vec3(1.0f, 0.0f, 0.0f);
            const vec3 t1 = glm::normalize(glm::cross(a, n)), t2 = glm::cross(n, t1);
            vec3 sum(0.0f);
            for (int i = 0; i < nt; ++i) {
                const float c = (float(i) + 0.5f) / float(nt), sn = std::sqrt(1.0f - c * c);
                for (int j = 0; j < np; ++j) {
                    const float phi = 2.0f * kPi * (float(j) + 0.5f) / float(np);
                    const vec3 d = c * n + sn * (std::cos(phi) * t1 + std::sin(phi) * t2);
                    sum += skyRadiance(sky, d) * c;
                }
            }
            table_[size_t(e)] = sum * (2.0f * kPi / float(nt * np));
        }
    }
    vec3 operator()(vec3 n) const {
        const float x = (std::clamp(n.y, -1.0f, 1.0f) + 1.0f) * 0.5f * float(table_.size() - 1);
        const size_t i = std::min(size_t(x), table_.size() - 2);
        return glm::mix(table_[i], table_[i + 1], x - float(i));
    }

  private:
    std::vector<vec3> table_;
};

/// The sky as the diffusion grid's boundary takes it (core/lighting/diffusion.h): for a voxel face
/// of outward normal up (+y), down (-y) and sideways (+x, the sky depends on y alone), the
/// isotropic radiance that carries the same current into the face as the sky does, its
/// irradiance on that face over pi (the cosine-weighted mean over the hemisphere the face looks
/// at), times the ambient scale. Marshak's condition balances currents, so this is its sky; the
/// plain mean over the hemisphere (SkyMeans) weighs the horizon as much as the zenith on an
/// upward face, where the current weighs it by cos = 0 (gradient sky: 0.2 horizon + 0.8 zenith
/// against 1/3 + 2/3). A uniform sky gives its own radiance on every face (the white furnace).
struct SkyFaces {
    vec3 up{0.0f};
    vec3 down{0.0f};
    vec3 side{0.0f};
};

inline SkyFaces skyBoundaryRadiance(const SkyDesc& sky) {
    SkyFaces m;
    if (sky.kind == SkyKind::None) return m;
    // three entries: the table's normals y = -1, 0, 1, the same quadrature as the full table's
    const SkyIrradiance irr(sky, 3);
    const float s = sky.ambient / std::numbers::pi_v<float>;
    m.up = irr(vec3(0.0f, 1.0f, 0.0f)) * s;
    m.down = irr(vec3(0.0f, -1.0f, 0.0f)) * s;
    m.side = irr(vec3(1.0f, 0.0f, 0.0f)) * s;
    return m;
}

} // namespace nimbus
