#include "core/fields/gardner.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/gtc/matrix_transform.hpp>

namespace nimbus {

namespace {

/// R = Rz Ry Rx (degrees), as instances rotate (core/tracking/volumes.cpp).
glm::mat3 rotation(vec3 degrees) {
    glm::mat4 m(1.0f);
    m = glm::rotate(m, glm::radians(degrees.z), vec3(0.0f, 0.0f, 1.0f));
    m = glm::rotate(m, glm::radians(degrees.y), vec3(0.0f, 1.0f, 0.0f));
    m = glm::rotate(m, glm::radians(degrees.x), vec3(1.0f, 0.0f, 0.0f));
    return glm::mat3(m);
}

/// A hash chain over kern::pcg: deterministic per seed, the same on every platform.
struct Draws {
    std::uint32_t state;
    float next() {
        state = kern::pcg(state + 0x9e3779b9u);
        return kern::hashToUnit(state);
    }
    float in(float lo, float hi) { return lo + (hi - lo) * next(); }
};

GardnerShapeDesc resolve(const GardnerEllipsoidDesc& e, const GardnerShapeDesc& d) {
    GardnerShapeDesc s = d;
    s.t1 = e.t1.value_or(d.t1);
    s.t2 = e.t2.value_or(d.t2);
    s.d = e.d.value_or(d.d);
    s.density = e.density.value_or(d.density);
    s.texture.frequency = e.frequency.value_or(d.texture.frequency);
    s.texture.terms = e.terms.value_or(d.texture.terms);
    s.texture.k = e.k.value_or(d.texture.k);
    s.texture.t0 = e.t0.value_or(d.texture.t0);
    s.texture.phase = e.phase.value_or(d.texture.phase);
    return s;
}

bool sameTexture(const kern::GardnerTexture& a, const kern::GardnerTexture& b) {
    return a.frequency == b.frequency && a.terms == b.terms && a.k == b.k && a.t0 == b.t0 &&
           a.phase == b.phase && a.offset == b.offset;
}

bool overlaps(const Box& a, const Box& b) {
    return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y &&
           a.lo.z <= b.hi.z && b.lo.z <= a.hi.z;
}

} // namespace

std::vector<GardnerEllipsoidSpec> gardnerEllipsoids(const GardnerDesc& d) {
    std::vector<GardnerEllipsoidSpec> out;
    for (const GardnerEllipsoidDesc& e : d.ellipsoids)
        out.push_back({e.center, e.radii, e.rotate, resolve(e, d.defaults)});
    if (d.scatter.enabled) {
        std::vector<GardnerEllipsoidSpec> s = gardnerScatter(d.scatter, d.defaults);
        out.insert(out.end(), s.begin(), s.end());
    }
    return out;
}

std::vector<GardnerEllipsoidSpec> gardnerScatter(const GardnerScatterDesc& s,
                                                 const GardnerShapeDesc& shape) {
    std::vector<GardnerEllipsoidSpec> out;
    if (s.count <= 0) return out;
    Draws rng{kern::pcg(s.seed ^ 0x6a09e667u)};
    GardnerShapeDesc sh = shape;
    sh.texture.offset += vec3(rng.in(0.0f, 100.0f), rng.in(0.0f, 100.0f), rng.in(0.0f, 100.0f));
    const vec3 c = s.center, E = s.extent;
    const float top = c.y + E.y;
    const int n = s.count;
    const int nBody = std::clamp(int(std::lround(0.2 * n)), 1, n);
    const int nBase = std::clamp(int(std::lround(n / 6.0)), 0, n - nBody);
    // keeps an ellipsoid's world box inside the cloud's box: shrinks it to fit, then moves it in
    auto fit = [&](GardnerEllipsoidSpec& e) {
        vec3 half = 0.5f * gardnerEllipsoidBox(e).extent();
        const float shrink = std::min(1.0f, minComponent(0.5f * E / half));
        e.radii *= shrink;
        half *= shrink;
        for (int a = 0; a < 3; ++a) {
            const float lo = a == 1 ? c.y + half.y : c[a] - 0.5f * E[a] + half[a];
            const float hi = a == 1 ? top - half.y : c[a] + 0.5f * E[a] - half[a];
            e.center[a] = std::clamp(e.center[a], lo, std::max(lo, hi));
        }
    };
    auto add = [&](vec3 center, vec3 radii, float yaw) {
        GardnerEllipsoidSpec e{center, radii, vec3(0.0f, yaw, 0.0f), sh};
        fit(e);
        out.push_back(e);
    };
    // the body: large ellipsoids, flattened, standing on the base, spread along x
    for (int i = 0; i < nBody; ++i) {
        const float rx = s.size * rng.in(0.85f, 1.15f);
        const vec3 r(rx, rx * rng.in(0.6f, 0.8f), rx * rng.in(0.7f, 1.0f));
        const float u = (float(i) + rng.in(0.3f, 0.7f)) / float(nBody) - 0.5f;
        add(vec3(c.x + u * std::max(E.x - 2.0f * r.x, 0.0f), c.y + r.y,
                 c.z + rng.in(-0.15f, 0.15f) * std::max(E.z - 2.0f * r.z, 0.0f)),
            r, rng.in(-20.0f, 20.0f));
    }
    // the flat base: wide, thin ellipsoids along the base plane
    for (int i = 0; i < nBase; ++i) {
        const float rx = s.size * rng.in(1.0f, 1.3f);
        const vec3 r(rx, rx * rng.in(0.25f, 0.35f), rx * rng.in(0.6f, 0.9f));
        add(vec3(c.x + rng.in(-0.5f, 0.5f) * std::max(E.x - 2.0f * r.x, 0.0f), c.y + r.y,
                 c.z + rng.in(-0.5f, 0.5f) * std::max(E.z - 2.0f * r.z, 0.0f)),
            r, rng.in(0.0f, 180.0f));
    }
    // heaped on top and sides: each on the upper surface of an earlier body or heap ellipsoid
    std::vector<int> parents;
    for (int i = 0; i < nBody; ++i) parents.push_back(i);
    for (int i = nBody + nBase; i < n; ++i) {
        const GardnerEllipsoidSpec p = out[size_t(
            parents[std::min(size_t(rng.in(0.0f, float(parents.size()))), parents.size() - 1)])];
        const float az = rng.in(0.0f, 6.2831853f);
        // 60% on top (elevation 45-85 degrees), 40% on the sides (10-45 degrees)
        const float el =
            glm::radians(rng.next() < 0.6f ? rng.in(45.0f, 85.0f) : rng.in(10.0f, 45.0f));
        const vec3 dir(std::cos(el) * std::cos(az), std::sin(el), std::cos(el) * std::sin(az));
        const float scale = rng.in(0.45f, 0.7f);
        const float rr = scale * std::max(p.radii.x, p.radii.z);
        const vec3 r(rr, rr * rng.in(0.75f, 0.95f), rr * rng.in(0.8f, 1.0f));
        add(p.center + 0.75f * dir * p.radii, r, rng.in(0.0f, 180.0f));
        parents.push_back(int(out.size()) - 1);
    }
    return out;
}

Box gardnerEllipsoidBox(const GardnerEllipsoidSpec& e) {
    const glm::mat3 R = rotation(e.rotate);
    vec3 half;
    for (int a = 0; a < 3; ++a) {
        float s = 0.0f;
        for (int j = 0; j < 3; ++j) s += (R[j][a] * e.radii[j]) * (R[j][a] * e.radii[j]);
        half[a] = std::sqrt(s) * (1.0f + 1e-5f);
    }
    return Box{e.center - half, e.center + half};
}

kern::GardnerEllipsoid gardnerKernelEllipsoid(const GardnerEllipsoidSpec& e) {
    const glm::mat3 R = rotation(e.rotate); // columns: the local axes in world space
    kern::GardnerEllipsoid k{};
    k.center = e.center;
    k.axisX = R[0] / e.radii.x;
    k.axisY = R[1] / e.radii.y;
    k.axisZ = R[2] / e.radii.z;
    k.t1 = e.shape.t1;
    k.t2 = e.shape.t2;
    k.d = e.shape.d;
    k.density = e.shape.density;
    return k;
}

kern::GardnerTexture gardnerKernelTexture(const GardnerTextureDesc& t) {
    kern::GardnerTexture k{};
    k.frequency = t.frequency;
    k.terms = t.terms;
    k.k = t.k;
    k.t0 = t.t0;
    k.phase = t.phase;
    k.offset = t.offset;
    return k;
}

std::shared_ptr<const GardnerCloud> makeGardnerCloud(const std::vector<GardnerEllipsoidSpec>& es) {
    auto c = std::make_shared<GardnerCloud>();
    const float inf = std::numeric_limits<float>::max();
    c->bounds = Box{vec3(inf), vec3(-inf)};
    for (const GardnerEllipsoidSpec& e : es) {
        c->ellipsoids.push_back(gardnerKernelEllipsoid(e));
        const Box b = gardnerEllipsoidBox(e);
        c->boxes.push_back(b);
        c->bounds.lo = glm::min(c->bounds.lo, b.lo);
        c->bounds.hi = glm::max(c->bounds.hi, b.hi);
        const kern::GardnerTexture t = gardnerKernelTexture(e.shape.texture);
        int index = -1;
        for (size_t i = 0; i < c->textures.size() && index < 0; ++i)
            if (sameTexture(c->textures[i], t)) index = int(i);
        if (index < 0) {
            index = int(c->textures.size());
            c->textures.push_back(t);
        }
        c->textureOf.push_back(index);
    }
    if (es.empty()) c->bounds = Box{};
    return c;
}

Box gardnerBounds(const GardnerDesc& d) {
    return makeGardnerCloud(gardnerEllipsoids(d))->bounds;
}

float GardnerField::density(vec3 p) const {
    const GardnerCloud& c = *cloud;
    float best = 0.0f;
    int cached = -1;
    float I = 0.0f;
    for (size_t i = 0; i < c.ellipsoids.size(); ++i) {
        const kern::GardnerEllipsoid& e = c.ellipsoids[i];
        if (e.density <= best || !c.boxes[i].contains(p)) continue;
        if (kern::gardnerFalloff(kern::gardnerLocal(e, p)) <= 0.0f) continue;
        if (c.textureOf[i] != cached) {
            cached = c.textureOf[i];
            I = kern::gardnerTexture(c.textures[size_t(cached)], p);
        }
        best = std::max(best, kern::gardnerEllipsoidDensity(e, I, p));
    }
    return best;
}

float GardnerField::majorant(const Box& b) const {
    const GardnerCloud& c = *cloud;
    float m = 0.0f;
    int cached = -1;
    float Imax = 0.0f;
    for (size_t i = 0; i < c.ellipsoids.size(); ++i) {
        const kern::GardnerEllipsoid& e = c.ellipsoids[i];
        if (e.density <= m || !overlaps(c.boxes[i], b)) continue;
        if (kern::gardnerR2Min(e, b.lo, b.hi) >= 1.0f) continue;
        if (c.textureOf[i] != cached) {
            cached = c.textureOf[i];
            Imax = kern::gardnerTextureBound(c.textures[size_t(cached)], b.lo, b.hi);
        }
        m = std::max(m, kern::gardnerEllipsoidBound(e, Imax, b.lo, b.hi));
    }
    return m;
}

} // namespace nimbus
