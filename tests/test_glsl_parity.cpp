// GLSL parity: every value-returning function of core/kernels/*.glsl, evaluated on thousands of
// inputs by C++ and by an OpenGL compute shader (headless EGL, Mesa llvmpipe) built from the text
// embedded in nimbus_core; also the embedding itself and the PhaseKind mirror.
//
// Adding a kernel: one row in parityCases() below (GLSL call, C++ call, input draw, tolerance;
// see tests/gl/kernel_parity.h), and a GlslType for any new struct it takes or returns.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <limits>
#include <regex>
#include <set>
#include <sstream>

#include "core/fields/gardner.h"
#include "core/kernels/enum_mirrors.h"
#include "core/kernels/kernels.h"
#include "core/kernels/source.h"
#include "core/sdf/sdf.h"
#include "plugin/realtime/gl_compute.h"
#include "tests/gl/kernel_parity.h"

using namespace nimbus;
using namespace nimbus::kern;
using parity::Draw;
using parity::Field;
using parity::kernelBlock;
using parity::KernelCase;
using parity::kernelCase;
using parity::Tolerance;
using parity::Word;

// ------------------------------------------------------------------ kernel structs in GLSL

namespace nimbus::parity {

template <> struct GlslType<CloudLayer> {
    static_assert(sizeof(CloudLayer) == 15 * 4, "CloudLayer changed: update its GlslType");
    static std::string type() { return "CloudLayer"; }
    static std::vector<Field> fields() {
        std::vector<Field> f;
        for (const char* n :
             {"bottom", "top", "heightA", "heightB", "coverage", "softness", "erosion",
              "towerSpacing", "towerRadiusMin", "towerRadiusMax", "towerHeightMin",
              "towerHeightMax", "towerProbability", "towerAnisotropy"})
            f.push_back({std::string(".") + n, Word::Float});
        f.push_back({".seed", Word::Uint});
        return f;
    }
    static void put(const CloudLayer& L, std::uint32_t* w) {
        const float v[] = {L.bottom,           L.top,
                           L.heightA,          L.heightB,
                           L.coverage,         L.softness,
                           L.erosion,          L.towerSpacing,
                           L.towerRadiusMin,   L.towerRadiusMax,
                           L.towerHeightMin,   L.towerHeightMax,
                           L.towerProbability, L.towerAnisotropy};
        for (int i = 0; i < 14; ++i) w[i] = std::bit_cast<std::uint32_t>(v[i]);
        w[14] = L.seed;
    }
};

template <> struct GlslType<CumulusParams> {
    static_assert(sizeof(CumulusParams) == 28 * 4, "CumulusParams changed: update its GlslType");
    static std::string type() { return "CumulusParams"; }
    static std::vector<Field> fields() {
        std::vector<Field> f;
        for (const Field& l : GlslType<CloudLayer>::fields())
            f.push_back({".layer" + l.access, l.kind});
        f.push_back({".density", Word::Float});
        f.push_back({".basePeriod", Word::Float});
        f.push_back({".baseLattice", Word::Int});
        f.push_back({".baseOctaves", Word::Int});
        f.push_back({".detailPeriod", Word::Float});
        f.push_back({".detailLattice", Word::Int});
        f.push_back({".detailOctaves", Word::Int});
        for (const char* v : {".baseOffset", ".detailOffset"})
            for (const char* c : {".x", ".y", ".z"}) f.push_back({std::string(v) + c, Word::Float});
        return f;
    }
    static void put(const CumulusParams& C, std::uint32_t* w) {
        GlslType<CloudLayer>::put(C.layer, w);
        w[15] = std::bit_cast<std::uint32_t>(C.density);
        w[16] = std::bit_cast<std::uint32_t>(C.basePeriod);
        w[17] = std::bit_cast<std::uint32_t>(C.baseLattice);
        w[18] = std::bit_cast<std::uint32_t>(C.baseOctaves);
        w[19] = std::bit_cast<std::uint32_t>(C.detailPeriod);
        w[20] = std::bit_cast<std::uint32_t>(C.detailLattice);
        w[21] = std::bit_cast<std::uint32_t>(C.detailOctaves);
        const float v[] = {C.baseOffset.x,   C.baseOffset.y,   C.baseOffset.z,
                           C.detailOffset.x, C.detailOffset.y, C.detailOffset.z};
        for (int i = 0; i < 6; ++i) w[22 + i] = std::bit_cast<std::uint32_t>(v[i]);
    }
};

template <> struct GlslType<SdfTreeNode> {
    static_assert(sizeof(SdfTreeNode) == 36 * 4, "SdfTreeNode changed: update its GlslType");
    static std::string type() { return "SdfTreeNode"; }
    static std::vector<Field> fields() {
        std::vector<Field> f;
        for (const char* v : {".col0", ".col1", ".col2", ".localOffset", ".p0", ".p1"})
            for (const char* c : {".x", ".y", ".z", ".w"})
                f.push_back({std::string(v) + c, Word::Float});
        f.push_back({".kind", Word::Int});
        f.push_back({".childCount", Word::Int});
        f.push_back({".factor", Word::Float});
        f.push_back({".k", Word::Float});
        f.push_back({".amplitude", Word::Float});
        f.push_back({".noiseKind", Word::Int});
        f.push_back({".frequency", Word::Float});
        f.push_back({".octaves", Word::Int});
        f.push_back({".gain", Word::Float});
        f.push_back({".seed", Word::Uint});
        f.push_back({".pad0", Word::Int});
        f.push_back({".pad1", Word::Int});
        return f;
    }
    // the struct is 36 four-byte words in the order of fields() (std430 = C++: vec4s first)
    static void put(const SdfTreeNode& n, std::uint32_t* w) { std::memcpy(w, &n, sizeof n); }
};

template <> struct GlslType<Tower> {
    static_assert(sizeof(Tower) == 8 * 4, "Tower changed: update its GlslType");
    static std::string type() { return "Tower"; }
    static std::vector<Field> fields() {
        return {{".center.x", Word::Float}, {".center.y", Word::Float}, {".sigmaX", Word::Float},
                {".sigmaZ", Word::Float},   {".cosA", Word::Float},     {".sinA", Word::Float},
                {".height", Word::Float},   {".present", Word::Bool}};
    }
    static void put(const Tower& t, std::uint32_t* w) {
        const float v[] = {t.center.x, t.center.y, t.sigmaX, t.sigmaZ, t.cosA, t.sinA, t.height};
        for (int i = 0; i < 7; ++i) w[i] = std::bit_cast<std::uint32_t>(v[i]);
        w[7] = t.present ? 1u : 0u;
    }
};

template <> struct GlslType<PhaseParams> {
    static_assert(sizeof(PhaseParams) == 6 * 4, "PhaseParams changed: update its GlslType");
    static std::string type() { return "PhaseParams"; }
    static std::vector<Field> fields() {
        return {{".kind", Word::Int},    {".g", Word::Float},     {".g2", Word::Float},
                {".blend", Word::Float}, {".alpha", Word::Float}, {".diameter", Word::Float}};
    }
    static void put(const PhaseParams& p, std::uint32_t* w) {
        w[0] = std::bit_cast<std::uint32_t>(p.kind);
        const float v[] = {p.g, p.g2, p.blend, p.alpha, p.diameter};
        for (int i = 0; i < 5; ++i) w[1 + i] = std::bit_cast<std::uint32_t>(v[i]);
    }
};

template <> struct GlslType<GardnerTexture> {
    static_assert(sizeof(GardnerTexture) == 8 * 4, "GardnerTexture changed: update its GlslType");
    static std::string type() { return "GardnerTexture"; }
    static std::vector<Field> fields() {
        return {{".frequency", Word::Float}, {".terms", Word::Int},     {".k", Word::Float},
                {".t0", Word::Float},        {".phase", Word::Float},   {".offset.x", Word::Float},
                {".offset.y", Word::Float},  {".offset.z", Word::Float}};
    }
    static void put(const GardnerTexture& t, std::uint32_t* w) {
        w[0] = std::bit_cast<std::uint32_t>(t.frequency);
        w[1] = std::bit_cast<std::uint32_t>(t.terms);
        const float v[] = {t.k, t.t0, t.phase, t.offset.x, t.offset.y, t.offset.z};
        for (int i = 0; i < 6; ++i) w[2 + i] = std::bit_cast<std::uint32_t>(v[i]);
    }
};

template <> struct GlslType<GardnerEllipsoid> {
    static_assert(sizeof(GardnerEllipsoid) == 16 * 4,
                  "GardnerEllipsoid changed: update its GlslType");
    static std::string type() { return "GardnerEllipsoid"; }
    static std::vector<Field> fields() {
        std::vector<Field> f;
        for (const char* v : {".center", ".axisX", ".axisY", ".axisZ"})
            for (const char* c : {".x", ".y", ".z"}) f.push_back({std::string(v) + c, Word::Float});
        for (const char* n : {".t1", ".t2", ".d", ".density"}) f.push_back({n, Word::Float});
        return f;
    }
    static void put(const GardnerEllipsoid& e, std::uint32_t* w) {
        const float v[] = {e.center.x, e.center.y, e.center.z, e.axisX.x, e.axisX.y, e.axisX.z,
                           e.axisY.x,  e.axisY.y,  e.axisY.z,  e.axisZ.x, e.axisZ.y, e.axisZ.z,
                           e.t1,       e.t2,       e.d,        e.density};
        for (int i = 0; i < 16; ++i) w[i] = std::bit_cast<std::uint32_t>(v[i]);
    }
};

} // namespace nimbus::parity

namespace {

// ------------------------------------------------------------------ input draws

vec3 noisePoint(Draw& d) { // noise coordinates: mostly moderate, some lattice points, some large
    if (d.chance(0.1f)) return vec3(float(d.i(-8, 8)), float(d.i(-8, 8)), float(d.i(-8, 8)));
    if (d.chance(0.1f)) return d.v3(-1e4f, 1e4f);
    return d.v3(-40.0f, 40.0f, {0.0f, -0.0f, 0.5f, -0.5f, 1.0f, -1.0f});
}
int period(Draw& d) {
    return d.i(1, 64, {1, 2, 3, 4, 16, 64});
}

CloudLayer layer(Draw& d) {
    CloudLayer L{};
    L.bottom = d.f(0.0f, 2.0f);
    L.top = L.bottom + d.f(0.5f, 3.0f);
    L.heightA = d.f(1.0f, 60.0f, {50.0f});
    L.heightB = d.f(0.1f, 5.0f, {0.5f});
    L.coverage = d.f(0.0f, 1.0f, {0.0f, 1.0f, 0.85f});
    L.softness = d.f(0.02f, 0.5f, {0.25f});
    L.erosion = d.f(0.0f, 0.95f, {0.0f, 0.3f});
    L.towerSpacing = d.f(0.5f, 6.0f, {4.5f});
    L.towerRadiusMax = L.towerSpacing * d.f(0.3f, 1.0f, {1.0f});
    L.towerRadiusMin = L.towerRadiusMax * d.f(0.2f, 1.0f, {1.0f});
    L.towerHeightMin = d.f(0.1f, 0.6f, {0.25f});
    L.towerHeightMax = d.f(0.6f, 1.0f, {1.0f});
    L.towerProbability = d.f(0.0f, 1.0f, {0.0f, 1.0f, 0.6f});
    L.towerAnisotropy = d.f(0.0f, 0.9f, {0.0f, 0.9f});
    L.seed = d.u({0u, 1u, 0xffffffffu});
    return L;
}

float asymmetry(Draw& d) { // g of HG-like lobes, up to 1e-4 from +-1
    return d.f(
        -0.99f, 0.99f,
        {0.0f, 1e-4f, -1e-4f, 0.25f, -0.25f, 0.9f, -0.9f, 0.999f, -0.999f, 0.9999f, -0.9999f});
}
float cosine(Draw& d) {
    return d.f(-1.0f, 1.0f, {-1.0f, 1.0f, 0.0f, -0.99999f, 0.99999f});
}
float unit(Draw& d) {
    return d.f(0.0f, 1.0f, {0.0f, 1.0f, 0.5f, 0.99999994f, 1e-7f});
}
float draineAlpha(Draw& d) {
    return d.chance(0.3f) ? d.logUniform(1.0f, 1000.0f) : d.f(0.0f, 2.0f, {0.0f, 1.0f});
}
float heightFraction(Draw& d) {
    return d.f(-0.5f, 1.5f, {0.0f, 1.0f, -0.0f, 1e-6f, 0.999999f, 0.5f});
}

/// A cumulus layer of one frame: the scene file's range of periods, lattices and octaves.
CumulusParams cumulus(Draw& d) {
    CumulusParams C{};
    C.layer = layer(d);
    C.density = d.f(0.1f, 2.0f, {1.0f});
    C.basePeriod = d.f(2.0f, 20.0f, {12.0f});
    C.baseLattice = d.i(1, 8, {4});
    C.baseOctaves = d.i(1, 5, {4});
    C.detailPeriod = d.f(0.5f, 4.0f, {2.0f});
    C.detailLattice = d.i(1, 8, {4});
    C.detailOctaves = d.i(1, 4, {3});
    C.baseOffset = d.v3(-20.0f, 20.0f, {0.0f});
    C.detailOffset = d.v3(-20.0f, 20.0f, {0.0f});
    return C;
}
/// A point in or near a cumulus layer's altitude range.
vec3 layerPoint(Draw& d, const CumulusParams& C) {
    const float h = heightFraction(d);
    return vec3(d.f(-40.0f, 40.0f, {0.0f}), C.layer.bottom + h * (C.layer.top - C.layer.bottom),
                d.f(-40.0f, 40.0f, {0.0f}));
}

struct PhaseKindDraw {
    const char* name;
    PhaseParams (*draw)(Draw&);
};
const PhaseKindDraw kPhaseKinds[] = {
    {"isotropic", [](Draw&) { return phaseParamsIsotropic(); }},
    {"hg", [](Draw& d) { return phaseParamsHG(asymmetry(d)); }},
    {"dual_hg",
     [](Draw& d) {
         const float g1 = asymmetry(d), g2 = asymmetry(d);
         return phaseParamsDualHG(g1, g2, d.f(0.0f, 1.0f, {0.0f, 1.0f, 0.5f}));
     }},
    {"draine",
     [](Draw& d) {
         const float g = asymmetry(d);
         return phaseParamsDraine(g, draineAlpha(d));
     }},
    {"mie_approx",
     [](Draw& d) {
         return phaseParamsMieApprox(d.f(5.0f, 50.0f, {5.0f, 50.0f}));
     }},
    {"mie_table", // the kernel's stand-in: HG with the table's mean cosine
     [](Draw& d) {
         PhaseParams p = phaseParamsHG(d.f(0.5f, 0.95f));
         p.kind = PHASE_MIE_TABLE;
         return p;
     }},
};
static_assert(std::size(kPhaseKinds) == 6, "one draw per PhaseKind");

PhaseParams anyPhase(Draw& d) {
    return kPhaseKinds[d.i(0, 5)].draw(d);
}

/// A Gardner texture in the scene file's ranges (frequencies of world-sized clouds).
GardnerTexture gardnerTex(Draw& d) {
    GardnerTexture t{};
    t.frequency = d.f(0.05f, 0.5f, {0.2f});
    t.terms = d.i(1, 6, {1, 5});
    t.k = d.f(0.1f, 2.0f, {1.0f});
    t.t0 = d.f(0.0f, 2.0f, {0.0f, 0.5f});
    t.phase = d.f(-3.0f, 3.0f, {0.0f, 1.5707964f});
    t.offset = d.v3(-50.0f, 50.0f, {0.0f});
    return t;
}
/// A rotated Gardner ellipsoid (its kernel form as the field builds it).
GardnerEllipsoid gardnerEll(Draw& d) {
    GardnerEllipsoidSpec e;
    e.center = d.v3(-10.0f, 10.0f, {0.0f});
    e.radii = d.v3(0.2f, 6.0f, {1.0f});
    e.rotate = d.v3(-180.0f, 180.0f, {0.0f, 90.0f});
    e.shape.t1 = d.f(-0.2f, 0.5f, {0.0f});
    e.shape.t2 = e.shape.t1 + d.f(0.0f, 0.5f, {0.0f});
    e.shape.d = d.f(0.01f, 1.0f, {0.15f});
    e.shape.density = d.f(0.0f, 2.0f, {1.0f});
    return gardnerKernelEllipsoid(e);
}
/// A point near an ellipsoid (inside, on the edge or outside).
vec3 gardnerPoint(Draw& d, const GardnerEllipsoid& e) {
    const vec3 q = d.v3(-1.3f, 1.3f, {0.0f});
    const glm::mat3 L(e.axisX, e.axisY, e.axisZ); // rows of local-from-world, as columns
    return e.center + glm::inverse(glm::transpose(L)) * q;
}

// ------------------------------------------------------------------ llvmpipe's error model
//
// Measured on llvmpipe (Mesa 22.3.6, LLVM 15) against glibc, 2^16-2^20 inputs per function:
// +, -, *, /, sqrt and inversesqrt are correctly rounded and nothing is fused into a
// multiply-add; sin and cos are within 1 ulp; exp is within 0.7 of the bound GLSL 4.30 allows,
// (3 + 2|x|) ulp (it is exp2(x log2 e): the rounding of x log2 e grows with |x|); denormals are
// flushed to zero; mix(x, y, a) is x + a (y - x) (glm: x (1 - a) + y a), 1 ulp of the operands
// apart where the result is near 0. GLSL also lets the compiler reassociate float expressions
// (no `precise` in the kernels) and Mesa's optimiser does: a few ulp beyond rounding.
// Tolerances below follow from these: kernels of +, -, *, / and sqrt get the default 4 ulp;
// where a formula goes through exp(), its allowance propagates exp's error bound through the
// formula, input by input (first order), on top of the 4 ulp.

constexpr double kUlpRel = 0x1p-23; // an ulp is at most this times the value

/// The absolute error GLSL's exp(x) may have: (3 + 2|x|) ulp of the result (the spec's
/// bound), or FLT_MIN where the result is that small (denormals may flush to zero).
double expError(double x) {
    const double e = std::exp(x);
    const double tiny = double(std::numeric_limits<float>::min());
    return e < tiny ? tiny : (3.0 + 2.0 * std::abs(x)) * kUlpRel * e;
}

// "4 ulp of 1": the absolute tolerance of values whose scale is 1 (cosines, unit vectors,
// densities in [0, 1]) where a formula cancels toward 0.
constexpr float kAbs1 = 0x1p-22f;

const std::string kWhyUnitScale =
    "value on a scale of 1 that cancels toward 0 (reassociation, mix): 4 ulp of 1 absolute";

// heightDistribution (1 - e^{-a h}) e^{-b h}: the cancellation in 1 - e^{-a h} turns exp's
// relative error into an absolute one (GLSL has no expm1).
double heightDistributionError(double h, double a, double b) {
    return expError(-a * h) * std::exp(-b * h) +
           std::abs(1.0 - std::exp(-a * h)) * expError(-b * h);
}
double heightProfileError(float h, float a, float b) {
    if (h <= 0.0f || h >= 1.0f) return 0.0;
    const double peak = heightDistributionPeak(a, b);
    const double hdPeak = heightDistribution(float(peak), a, b);
    return (heightDistributionError(h, a, b) +
            heightProfile(h, a, b) * heightDistributionError(peak, a, b)) /
           hdPeak;
}
double heightProfileMaxError(float h0, float h1, float a, float b) {
    if (h1 <= 0.0f || h0 >= 1.0f) return 0.0;
    const float hp =
        glm::clamp(heightDistributionPeak(a, b), std::max(h0, 1e-6f), std::min(h1, 1.0f - 1e-6f));
    return heightProfileError(hp, a, b);
}

// Sampling: an error dxi in the variable that is uniform under HG moves the sampled cosine by
// dxi / p(cos), p = 2 pi phaseHG the density of cos.
double hgCosError(float cosTheta, float g, double dxi) {
    const double p = 2.0 * NB_PI * double(phaseHG(cosTheta, g));
    return std::min(2.0, dxi / std::max(p, 1e-30));
}
// Draine's Newton iteration stops at a step of 2.5e-7 norm (or a bracket of 1e-7) in that
// variable: the two sides may stop at different iterates, 4 thresholds apart at most.
double draineCosError(float cosTheta, float g, float alpha) {
    const double norm = 1.0 + alpha * (1.0 + 2.0 * g * g) / 3.0;
    return hgCosError(cosTheta, g, 4.0 * 2.5e-7 * norm);
}
// The sampled cosine's allowance for each kind (beyond kAbs1).
double phaseSampleError(const PhaseParams& p, vec2 u) {
    const float c = phaseSample(p, u);
    switch (p.kind) {
    case PHASE_DRAINE:
        return draineCosError(c, p.g, p.alpha);
    case PHASE_MIE_APPROX:
        return u.y < p.blend ? draineCosError(c, p.g2, p.alpha) : 0.0;
    default:
        return 0.0;
    }
}
// phaseDirection: sin = sqrt(1 - cos^2) turns an error dc in cos into at most
// min(sqrt(d), d / sin) with d = 2 |cos| dc + dc^2 (steep near cos = +-1).
double directionError(float cosTheta, double dc) {
    const double s = std::sqrt(std::max(0.0, 1.0 - double(cosTheta) * cosTheta));
    const double d = 2.0 * std::abs(cosTheta) * dc + dc * dc;
    return dc + std::min(std::sqrt(d), s > 0.0 ? d / s : std::sqrt(d));
}
double stepIntegralError(float S, float sigma_t, float dt) {
    if (sigma_t * dt < 0.01f) return 0.0; // the series: arithmetic only
    return std::abs(S) * expError(-double(sigma_t) * dt) / sigma_t;
}

// ------------------------------------------------------------------ the table

std::vector<KernelCase> makeCases() {
    using parity::NoAllowance;
    std::vector<KernelCase> c;
    const Tolerance exact{.ulps = 0, .why = "integer arithmetic or exact float steps: bit-exact"};
    const Tolerance unitScale{.ulps = 4, .abs = kAbs1, .why = kWhyUnitScale};
    const std::string whyExp = "exp's error bound ((3 + 2|x|) ulp) through the formula";
    const Tolerance viaExp{.ulps = 4, .why = whyExp};

    // hash.glsl: integer arithmetic, bit-exact (hashToUnit's float is exact too)
    c.push_back(kernelCase(
        "pcg", "pcg(a0)", [](uint v) { return pcg(v); },
        [](Draw& d) {
            return std::tuple(d.u({0u, 1u, 0xffffffffu, 0x80000000u}));
        },
        exact));
    c.push_back(kernelCase(
        "pcg3d", "pcg3d(a0)", [](uvec3 v) { return pcg3d(v); },
        [](Draw& d) {
            return std::tuple(uvec3(d.u({0u, 0xffffffffu}), d.u({0u}), d.u({0u, 1u})));
        },
        exact));
    c.push_back(kernelCase(
        "hashToUnit", "hashToUnit(a0)", [](uint h) { return hashToUnit(h); },
        [](Draw& d) {
            return std::tuple(d.u({0u, 0xffffffffu, 0xffu, 0x100u}));
        },
        exact));
    c.push_back(kernelCase(
        "hashToUnit3", "hashToUnit3(a0)", [](uvec3 h) { return hashToUnit3(h); },
        [](Draw& d) {
            return std::tuple(uvec3(d.u({0u, 0xffffffffu}), d.u(), d.u({0xffu})));
        },
        exact));
    auto lattice = [](Draw& d, int per) { // multiples of the period and their neighbours
        if (d.chance(0.3f)) return per * d.i(-1000, 1000) + d.i(-1, 1);
        return d.i(-(1 << 30), 1 << 30, {0, -1, 1, (1 << 24) + 1, -(1 << 24) - 1});
    };
    c.push_back(kernelCase(
        "wrapLattice", "wrapLattice(a0, a1)", [](int a, int p) { return wrapLattice(a, p); },
        [lattice](Draw& d) {
            const int p = period(d);
            return std::tuple(lattice(d, p), p);
        },
        exact));
    c.push_back(kernelCase(
        "wrapLattice3", "wrapLattice3(a0, a1)", [](ivec3 v, int p) { return wrapLattice3(v, p); },
        [lattice](Draw& d) {
            const int p = period(d);
            return std::tuple(ivec3(lattice(d, p), lattice(d, p), lattice(d, p)), p);
        },
        exact));
    c.push_back(kernelCase(
        "latticeHash3", "latticeHash3(a0, a1, a2)",
        [](ivec3 v, int p, uint seed) { return latticeHash3(v, p, seed); },
        [](Draw& d) {
            return std::tuple(ivec3(d.i(-5000, 5000, {0, -1}), d.i(-5000, 5000), d.i(-50, 50)),
                              d.i(1, 1 << 20, {1, 16, CLOUD_TOWER_PERIOD}), d.u({0u, 1u}));
        },
        exact));

    // noise.glsl
    const Tolerance noiseMix{
        .ulps = 4,
        .abs = 0x1p-21f,
        .why = "mix() differs from glm's by 1 ulp of the corner values (|n| <= 2) where the "
               "noise is near 0: 2^-21 absolute"};
    c.push_back(kernelCase(
        "perlinFade", "perlinFade(a0)", [](vec3 t) { return perlinFade(t); },
        [](Draw& d) {
            return std::tuple(d.v3(-0.5f, 1.5f, {0.0f, 1.0f, 0.5f}));
        }));
    c.push_back(kernelCase(
        "perlinGrad", "perlinGrad(a0, a1)", [](uint h, vec3 f) { return perlinGrad(h, f); },
        [](Draw& d) {
            return std::tuple(d.u(), d.v3(-1.0f, 2.0f, {0.0f, 1.0f}));
        }));
    c.push_back(kernelCase(
        "perlinCorner", "perlinCorner(a0, a1, a2, a3, a4)",
        [](ivec3 cell, ivec3 o, vec3 f, int p, uint seed) {
            return perlinCorner(cell, o, f, p, seed);
        },
        [](Draw& d) {
            return std::tuple(ivec3(d.i(-100, 100), d.i(-100, 100), d.i(-100, 100)),
                              ivec3(d.i(0, 1), d.i(0, 1), d.i(0, 1)),
                              d.v3(0.0f, 1.0f, {0.0f, 0.5f}), period(d), d.u({0u}));
        }));
    c.push_back(kernelCase(
        "perlinNoise", "perlinNoise(a0, a1, a2)",
        [](vec3 p, int per, uint seed) { return perlinNoise(p, per, seed); },
        [](Draw& d) {
            return std::tuple(noisePoint(d), period(d), d.u({0u, 5u}));
        },
        noiseMix));
    c.push_back(kernelCase(
        "worleyNoise", "worleyNoise(a0, a1, a2)",
        [](vec3 p, int per, uint seed) { return worleyNoise(p, per, seed); },
        [](Draw& d) {
            return std::tuple(noisePoint(d), period(d), d.u({0u, 5u}));
        }));
    auto fbmArgs = [](Draw& d) {
        const vec3 p = noisePoint(d) * 0.25f;
        return std::tuple(p, period(d), d.i(1, 6, {1, 6}), d.f(0.3f, 0.7f, {0.5f}), d.u({0u, 1u}));
    };
    c.push_back(kernelCase(
        "perlinFbm", "perlinFbm(a0, a1, a2, a3, a4)",
        [](vec3 p, int per, int oct, float gain, uint seed) {
            return perlinFbm(p, per, oct, gain, seed);
        },
        fbmArgs, noiseMix));
    c.push_back(kernelCase(
        "worleyFbm", "worleyFbm(a0, a1, a2, a3, a4)",
        [](vec3 p, int per, int oct, float gain, uint seed) {
            return worleyFbm(p, per, oct, gain, seed);
        },
        fbmArgs));
    c.push_back(kernelCase(
        "remapRange", "remapRange(a0, a1, a2, a3, a4)",
        [](float v, float lo0, float hi0, float lo1, float hi1) {
            return remapRange(v, lo0, hi0, lo1, hi1);
        },
        [](Draw& d) {
            const float lo0 = d.f(-2.0f, 1.0f, {0.0f, 0.35f});
            const float hi0 = lo0 + d.f(0.01f, 3.0f, {1.0f, 0.5f});
            return std::tuple(d.f(-3.0f, 3.0f, {0.0f, 1.0f, lo0, hi0}), lo0, hi0,
                              d.f(-1.0f, 1.0f, {0.0f}), d.f(1.0f, 2.0f, {1.0f}));
        }));
    c.push_back(kernelCase(
        "perlinWorley", "perlinWorley(a0, a1, a2, a3)",
        [](vec3 p, int per, int oct, uint seed) { return perlinWorley(p, per, oct, seed); },
        [](Draw& d) {
            return std::tuple(noisePoint(d) * 0.25f, period(d), d.i(1, 5, {1, 4}), d.u({1u}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-20f,
                  .why = "perlinFbm's 2^-21 (mix), doubled by the stretch from [0.35, 0.85]"}));

    // cloud.glsl
    auto rates = [](Draw& d) {
        return std::pair(d.f(0.5f, 60.0f, {50.0f, 1.0f}), d.f(0.1f, 5.0f, {0.5f}));
    };
    c.push_back(kernelCase(
        "heightDistribution", "heightDistribution(a0, a1, a2)",
        [](float h, float a, float b) { return heightDistribution(h, a, b); },
        [rates](Draw& d) {
            auto [a, b] = rates(d);
            return std::tuple(heightFraction(d), a, b);
        },
        viaExp, [](float h, float a, float b) { return float(heightDistributionError(h, a, b)); }));
    c.push_back(kernelCase(
        "heightDistributionPeak", "heightDistributionPeak(a0, a1)",
        [](float a, float b) { return heightDistributionPeak(a, b); },
        [rates](Draw& d) {
            auto [a, b] = rates(d);
            return std::tuple(a, b);
        }));
    c.push_back(kernelCase(
        "heightProfile", "heightProfile(a0, a1, a2)",
        [](float h, float a, float b) { return heightProfile(h, a, b); },
        [rates](Draw& d) {
            auto [a, b] = rates(d);
            const float h = d.chance(0.1f) ? heightDistributionPeak(a, b) : heightFraction(d);
            return std::tuple(h, a, b);
        },
        viaExp, [](float h, float a, float b) { return float(heightProfileError(h, a, b)); }));
    c.push_back(kernelCase(
        "heightProfileMax", "heightProfileMax(a0, a1, a2, a3)",
        [](float h0, float h1, float a, float b) { return heightProfileMax(h0, h1, a, b); },
        [rates](Draw& d) {
            auto [a, b] = rates(d);
            const float h0 = heightFraction(d);
            return std::tuple(h0, h0 + d.f(0.0f, 1.0f, {0.0f}), a, b);
        },
        viaExp,
        [](float h0, float h1, float a, float b) {
            return float(heightProfileMaxError(h0, h1, a, b));
        }));
    c.push_back(kernelCase(
        "cloudTower", "cloudTower(a0, a1, a2)",
        [](CloudLayer L, int i, int j) { return cloudTower(L, i, j); },
        [](Draw& d) {
            return std::tuple(layer(d), d.i(-100000, 100000, {0, -1}), d.i(-1000, 1000, {0}));
        }));
    c.push_back(kernelCase(
        "cloudTowerFromDraw", "cloudTowerFromDraw(a0, a1, a2, a3)",
        [](CloudLayer L, int i, int j, uvec3 h0) { return cloudTowerFromDraw(L, i, j, h0); },
        [](Draw& d) {
            const int i = d.i(-100000, 100000, {0, -1}), j = d.i(-1000, 1000, {0});
            const CloudLayer L = layer(d);
            return std::tuple(L, i, j, latticeHash3(ivec3(i, j, 0), CLOUD_TOWER_PERIOD, L.seed));
        }));
    // the footprint towerEnvelope reads first, to leave out the towers out of reach
    c.push_back(kernelCase(
        "towerCenter", "towerCenter(a0, a1, a2, a3)",
        [](CloudLayer L, int i, int j, vec3 u0) { return towerCenter(L, i, j, u0); },
        [](Draw& d) {
            return std::tuple(layer(d), d.i(-100000, 100000, {0, -1}), d.i(-1000, 1000, {0}),
                              d.v3(0.0f, 1.0f, {0.0f}));
        }));
    c.push_back(kernelCase(
        "towerSigmaX", "towerSigmaX(a0, a1)",
        [](CloudLayer L, vec3 u0) { return towerSigmaX(L, u0); },
        [](Draw& d) { return std::tuple(layer(d), d.v3(0.0f, 1.0f, {0.0f})); }));
    c.push_back(kernelCase(
        "truncatedGaussian", "truncatedGaussian(a0)", [](float q) { return truncatedGaussian(q); },
        [](Draw& d) {
            return std::tuple(d.f(0.0f, 12.0f, {0.0f, 9.0f, 8.9999f, 9.0001f, 1e6f, 1e-7f}));
        },
        viaExp, [](float q) { return float(expError(-0.5 * q) / (1.0 - CLOUD_TRUNC)); }));
    c.push_back(kernelCase(
        "cloudEnvelope", "cloudEnvelope(a0, a1, a2)",
        [](CloudLayer L, float h, float th) { return cloudEnvelope(L, h, th); },
        [](Draw& d) {
            return std::tuple(layer(d), heightFraction(d),
                              d.f(0.0f, 1.0f, {0.0f, 1e-4f, 1.0001e-4f, 1.0f}));
        },
        viaExp,
        [](CloudLayer L, float h, float th) {
            if (th <= 1e-4f) return 0.0f;
            const float hn = h / th;
            return float(heightProfileError(hn, L.heightA, L.heightB) *
                         std::max(0.0f, 1.0f - hn * hn * hn * hn));
        }));
    c.push_back(kernelCase(
        "cloudEnvelopeBound", "cloudEnvelopeBound(a0, a1, a2, a3)",
        [](CloudLayer L, float h0, float h1, float th) {
            return cloudEnvelopeBound(L, h0, h1, th);
        },
        [](Draw& d) {
            const float h0 = heightFraction(d);
            return std::tuple(layer(d), h0, h0 + d.f(0.0f, 1.0f, {0.0f}),
                              d.f(0.0f, 1.0f, {0.0f, 1e-4f, 1.0f}));
        },
        viaExp,
        [](CloudLayer L, float h0, float h1, float th) {
            if (th <= 1e-4f || h1 <= 0.0f) return 0.0f;
            const float lo = std::max(h0, 0.0f) / th;
            return float(heightProfileMaxError(lo, 1.0f, L.heightA, L.heightB) *
                         std::max(0.0f, 1.0f - lo * lo * lo * lo));
        }));
    c.push_back(kernelCase(
        "towerRim", "towerRim(a0)", [](float g) { return towerRim(g); },
        [](Draw& d) {
            return std::tuple(d.f(-0.2f, 1.2f, {0.0f, 0.1f, 0.7f, 1.0f, 0.35f}));
        }));
    const Tolerance towers{
        .ulps = 4,
        .abs = 0x1p-20f,
        .why = "max over towers of cloudEnvelope x towerRim, on [0, 1], through exp(), sin() "
               "and cos(): 2^-20 absolute (cloudEnvelope's own row models its exp error input "
               "by input)"};
    c.push_back(kernelCase(
        "towerEnvelope", "towerEnvelope(a0, a1, a2, a3)",
        [](CloudLayer L, float h, float x, float z) { return towerEnvelope(L, h, x, z); },
        [](Draw& d) {
            return std::tuple(layer(d), heightFraction(d), d.f(-100.0f, 100.0f, {0.0f}),
                              d.f(-100.0f, 100.0f, {0.0f, -1e4f}));
        },
        towers));
    c.push_back(kernelCase(
        "towerEnvelopeBound", "towerEnvelopeBound(a0, a1, a2, a3, a4, a5, a6)",
        [](CloudLayer L, float h0, float h1, float x0, float x1, float z0, float z1) {
            return towerEnvelopeBound(L, h0, h1, x0, x1, z0, z1);
        },
        [](Draw& d) {
            const CloudLayer L = layer(d);
            const float h0 = heightFraction(d), x0 = d.f(-100.0f, 100.0f, {0.0f});
            const float z0 = d.f(-100.0f, 100.0f, {0.0f});
            const float w = 3.0f * L.towerSpacing;
            return std::tuple(L, h0, h0 + d.f(0.0f, 1.0f, {0.0f}), x0, x0 + d.f(0.0f, w, {0.0f}),
                              z0, z0 + d.f(0.0f, w, {0.0f}));
        },
        towers));
    c.push_back(kernelCase(
        "cloudShape", "cloudShape(a0, a1, a2, a3)",
        [](CloudLayer L, float env, float base, float detail) {
            return cloudShape(L, env, base, detail);
        },
        [](Draw& d) {
            return std::tuple(layer(d), d.f(0.0f, 1.0f, {0.0f, 1.0f}),
                              d.f(0.0f, 1.0f, {0.0f, 1.0f}), d.f(0.0f, 1.0f, {0.0f, 1.0f}));
        }));

    // phase.glsl: the parameter constructors
    c.push_back(kernelCase(
        "makePhaseParams", "makePhaseParams(a0, a1, a2, a3, a4, a5)",
        [](int kind, float g, float g2, float w, float a, float dia) {
            return makePhaseParams(kind, g, g2, w, a, dia);
        },
        [](Draw& d) {
            return std::tuple(d.i(0, 5), asymmetry(d), asymmetry(d), unit(d), draineAlpha(d),
                              d.f(5.0f, 50.0f));
        },
        exact));
    c.push_back(kernelCase(
        "phaseParamsIsotropic", "phaseParamsIsotropic()", [] { return phaseParamsIsotropic(); },
        [](Draw&) { return std::tuple<>(); }, exact, NoAllowance{}, 64));
    c.push_back(kernelCase(
        "phaseParamsHG", "phaseParamsHG(a0)", [](float g) { return phaseParamsHG(g); },
        [](Draw& d) { return std::tuple(asymmetry(d)); }, exact));
    c.push_back(kernelCase(
        "phaseParamsDualHG", "phaseParamsDualHG(a0, a1, a2)",
        [](float g1, float g2, float w) { return phaseParamsDualHG(g1, g2, w); },
        [](Draw& d) { return std::tuple(asymmetry(d), asymmetry(d), unit(d)); }, exact));
    c.push_back(kernelCase(
        "phaseParamsDraine", "phaseParamsDraine(a0, a1)",
        [](float g, float a) { return phaseParamsDraine(g, a); },
        [](Draw& d) { return std::tuple(asymmetry(d), draineAlpha(d)); }, exact));
    c.push_back(kernelCase(
        "phaseParamsMieApprox", "phaseParamsMieApprox(a0)",
        [](float dia) { return phaseParamsMieApprox(dia); },
        [](Draw& d) {
            return std::tuple(d.f(0.0f, 80.0f, {5.0f, 50.0f, 0.0f, 4.99f, 1e4f}));
        },
        viaExp,
        [](float dia) { // each parameter is one exp() of the clamped diameter
            const double d = std::clamp(dia, 5.0f, 50.0f);
            PhaseParams e{};
            e.g = float(expError(-0.0990567 / (d - 1.67154)));
            e.g2 = float(expError(-2.20679 / (d + 3.91029) - 0.428934));
            e.alpha = float(expError(3.62489 - 8.29288 / (d + 5.52825)));
            e.blend = float(expError(-0.599085 / (d - 0.641583) - 0.665888));
            return e;
        }));
    c.push_back(kernelCase(
        "phaseOctave", "phaseOctave(a0, a1)",
        [](PhaseParams p, float e) { return phaseOctave(p, e); },
        [](Draw& d) {
            return std::tuple(anyPhase(d), d.f(0.0f, 1.0f, {0.0f, 0.5f, 1.0f}));
        }));

    // phase.glsl: HG and Draine pieces
    const std::string whyDraineSample =
        "Newton stops at a step of 2.5e-7 norm in the HG-uniform variable xi: the sides may "
        "stop 4 thresholds apart, dcos = dxi / p(cos); plus 4 ulp of 1";
    c.push_back(kernelCase(
        "phaseHGDenominator", "phaseHGDenominator(a0, a1)",
        [](float cs, float g) { return phaseHGDenominator(cs, g); },
        [](Draw& d) { return std::tuple(cosine(d), asymmetry(d)); }));
    c.push_back(kernelCase(
        "phaseHG", "phaseHG(a0, a1)", [](float cs, float g) { return phaseHG(cs, g); },
        [](Draw& d) { return std::tuple(cosine(d), asymmetry(d)); }));
    c.push_back(kernelCase(
        "phaseHGSampleCos", "phaseHGSampleCos(a0, a1)",
        [](float g, float u) { return phaseHGSampleCos(g, u); },
        [](Draw& d) { return std::tuple(asymmetry(d), unit(d)); }, unitScale));
    c.push_back(kernelCase(
        "phaseDraine", "phaseDraine(a0, a1, a2)",
        [](float cs, float g, float a) { return phaseDraine(cs, g, a); },
        [](Draw& d) { return std::tuple(cosine(d), asymmetry(d), draineAlpha(d)); }));
    c.push_back(kernelCase(
        "phaseDraineM2", "phaseDraineM2(a0, a1)",
        [](float g, float mu) { return phaseDraineM2(g, mu); },
        [](Draw& d) { return std::tuple(asymmetry(d), cosine(d)); },
        Tolerance{.ulps = 8,
                  .abs = kAbs1,
                  .why = "a rational function of ~30 operations that Mesa reassociates: 8 ulp, "
                         "or 4 ulp of 1 where it cancels toward 0"}));
    c.push_back(kernelCase(
        "phaseDraineSampleCos", "phaseDraineSampleCos(a0, a1, a2)",
        [](float g, float a, float u) { return phaseDraineSampleCos(g, a, u); },
        [](Draw& d) { return std::tuple(asymmetry(d), draineAlpha(d), unit(d)); },
        Tolerance{.ulps = 4, .abs = kAbs1, .why = whyDraineSample},
        [](float g, float a, float u) {
            return float(draineCosError(phaseDraineSampleCos(g, a, u), g, a));
        }));

    // phase.glsl: the verbs, for every kind
    const Tolerance sampleTolerance{
        .ulps = 4, .abs = kAbs1, .why = kWhyUnitScale + "; Draine lobes: " + whyDraineSample};
    const Tolerance directionTolerance{
        .ulps = 4,
        .abs = kAbs1,
        .why = "unit vector, 4 ulp of 1 absolute, plus the sampled cosine's allowance through "
               "sin = sqrt(1 - cos^2)"};
    for (const PhaseKindDraw& k : kPhaseKinds) {
        auto params = k.draw;
        c.push_back(kernelCase(
            std::string("phaseEval_") + k.name, "phaseEval(a0, a1)",
            [](PhaseParams p, float cs) { return phaseEval(p, cs); },
            [params](Draw& d) { return std::tuple(params(d), cosine(d)); }));
        c.push_back(kernelCase(
            std::string("phasePdf_") + k.name, "phasePdf(a0, a1)",
            [](PhaseParams p, float cs) { return phasePdf(p, cs); },
            [params](Draw& d) { return std::tuple(params(d), cosine(d)); }));
        c.push_back(kernelCase(
            std::string("phaseSample_") + k.name, "phaseSample(a0, a1)",
            [](PhaseParams p, vec2 u) { return phaseSample(p, u); },
            [params](Draw& d) { return std::tuple(params(d), vec2(unit(d), unit(d))); },
            sampleTolerance, [](PhaseParams p, vec2 u) { return float(phaseSampleError(p, u)); }));
        c.push_back(kernelCase(
            std::string("phaseSampleDirection_") + k.name, "phaseSampleDirection(a0, a1, a2)",
            [](PhaseParams p, vec3 wi, vec3 u) { return phaseSampleDirection(p, wi, u); },
            [params](Draw& d) {
                const PhaseParams p = params(d);
                const vec3 wi = d.unitVector();
                return std::tuple(p, wi, vec3(unit(d), unit(d), unit(d)));
            },
            directionTolerance,
            [](PhaseParams p, vec3, vec3 u) {
                const vec2 uc(u.x, u.y);
                return float(directionError(phaseSample(p, uc), kAbs1 + phaseSampleError(p, uc)));
            }));
    }
    c.push_back(kernelCase(
        "phaseDirection", "phaseDirection(a0, a1, a2)",
        [](vec3 wi, float cs, float u) { return phaseDirection(wi, cs, u); },
        [](Draw& d) {
            const vec3 wi = d.unitVector();
            return std::tuple(wi, cosine(d), unit(d));
        },
        unitScale));
    // the kind-and-g overloads (isotropic and HG)
    c.push_back(kernelCase(
        "phaseEval_kindG", "phaseEval(a0, a1, a2)",
        [](int kind, float g, float cs) { return phaseEval(kind, g, cs); },
        [](Draw& d) { return std::tuple(d.i(0, 1), asymmetry(d), cosine(d)); }));
    c.push_back(kernelCase(
        "phasePdf_kindG", "phasePdf(a0, a1, a2)",
        [](int kind, float g, float cs) { return phasePdf(kind, g, cs); },
        [](Draw& d) { return std::tuple(d.i(0, 1), asymmetry(d), cosine(d)); }));
    c.push_back(kernelCase(
        "phaseSampleCos_kindG", "phaseSampleCos(a0, a1, a2)",
        [](int kind, float g, float u) { return phaseSampleCos(kind, g, u); },
        [](Draw& d) { return std::tuple(d.i(0, 1), asymmetry(d), unit(d)); }, unitScale));

    // lighting.glsl
    auto depth = [](Draw& d) {
        return d.chance(0.2f) ? d.logUniform(1e-6f, 88.0f) : d.f(0.0f, 10.0f, {0.0f, 1.0f});
    };
    c.push_back(kernelCase(
        "beerLambert", "beerLambert(a0)", [](vec3 tau) { return beerLambert(tau); },
        [depth](Draw& d) { return std::tuple(vec3(depth(d), depth(d), depth(d))); }, viaExp,
        [](vec3 tau) {
            return vec3(float(expError(-tau.x)), float(expError(-tau.y)), float(expError(-tau.z)));
        }));
    c.push_back(kernelCase(
        "inScatterOlajos", "inScatterOlajos(a0, a1)",
        [](float dd, float k) { return inScatterOlajos(dd, k); },
        [depth](Draw& d) {
            return std::tuple(depth(d), d.f(0.0f, 5.0f, {0.0f, 1.0f}));
        },
        viaExp, [](float dd, float k) { return float(expError(-double(k * dd))); }));
    c.push_back(kernelCase(
        "beerPowder", "beerPowder(a0)", [](float dd) { return beerPowder(dd); },
        [depth](Draw& d) { return std::tuple(depth(d)); }, viaExp,
        [](float dd) {
            return float(2.0 * (expError(-dd) * std::abs(1.0 - std::exp(-2.0 * dd)) +
                                std::exp(-dd) * expError(-2.0 * dd)));
        }));
    auto stepArgs = [](Draw& d) {
        return std::tuple(d.f(0.0f, 10.0f, {0.0f, 1.0f}),
                          d.chance(0.3f) ? d.logUniform(1e-8f, 100.0f)
                                         : d.f(0.0f, 10.0f, {0.0f, 1e-6f, 0.999e-6f}),
                          d.f(0.0f, 5.0f, {0.0f, 1e-3f}));
    };
    // stepIntegral is (S - S e^{-x}) / sigma_t for x = sigma_t dt >= 0.01, where exp's error
    // reaches the result scaled by S / sigma_t, and a series below (no cancellation)
    const Tolerance stepTolerance{
        .ulps = 4, .why = whyExp + ", scaled by S / sigma_t (x >= 0.01; below, a series)"};
    c.push_back(kernelCase(
        "stepIntegral", "stepIntegral(a0, a1, a2)",
        [](float S, float st, float dt) { return stepIntegral(S, st, dt); }, stepArgs,
        stepTolerance,
        [](float S, float st, float dt) { return float(stepIntegralError(S, st, dt)); }));
    c.push_back(kernelBlock(
        "integrateStep",
        "vec3 L = a3; vec3 T = a4; integrateStep(a0, a1, a2, L, T);"
        " r = float[6](L.x, L.y, L.z, T.x, T.y, T.z);",
        [](vec3 S, vec3 st, float dt, vec3 L, vec3 T) {
            integrateStep(S, st, dt, L, T);
            return std::array<float, 6>{L.x, L.y, L.z, T.x, T.y, T.z};
        },
        [stepArgs](Draw& d) {
            auto [S0, st0, dt] = stepArgs(d);
            auto [S1, st1, dt1] = stepArgs(d);
            auto [S2, st2, dt2] = stepArgs(d);
            (void)dt1;
            (void)dt2;
            return std::tuple(vec3(S0, S1, S2), vec3(st0, st1, st2), dt, d.v3(0.0f, 5.0f, {0.0f}),
                              d.v3(0.0f, 1.0f, {0.0f, 1.0f}));
        },
        stepTolerance,
        [](vec3 S, vec3 st, float dt, vec3, vec3 T) {
            std::array<float, 6> a{};
            for (int k = 0; k < 3; ++k) {
                a[k] = float(T[k] * stepIntegralError(S[k], st[k], dt));
                a[3 + k] = float(T[k] * expError(-double(st[k]) * dt));
            }
            return a;
        }));
    c.push_back(kernelCase(
        "skyUpperShare", "skyUpperShare(a0, a1, a2)",
        [](float tu, float td, float k) { return skyUpperShare(tu, td, k); },
        [depth](Draw& d) {
            return std::tuple(depth(d), depth(d), d.f(0.0f, 5.0f, {0.0f, 1.0f, 100.0f}));
        },
        viaExp,
        [](float tu, float td, float k) {
            const double m = std::min(k * (tu - td), 80.0f);
            const double e = std::exp(m);
            return float(expError(m) / ((1.0 + e) * (1.0 + e)));
        }));
    // dda.glsl: the majorant walk's cell arithmetic
    c.push_back(kernelCase(
        "ddaCell", "ddaCell(a0, a1, a2)",
        [](float x, float lo, float cell) { return ddaCell(x, lo, cell); },
        [](Draw& d) {
            return std::tuple(d.f(-100.0f, 100.0f, {0.0f, 1.0f, -1.0f}), d.f(-50.0f, 50.0f, {0.0f}),
                              d.f(0.01f, 10.0f, {0.25f, 1.0f}));
        }));
    c.push_back(kernelCase(
        "ddaEdgeT", "ddaEdgeT(a0, a1, a2, a3, a4)",
        [](float lo, int e, float cell, float o, float dir) {
            return ddaEdgeT(lo, e, cell, o, dir);
        },
        [](Draw& d) {
            const float dir = d.f(0.05f, 1.0f, {1.0f});
            return std::tuple(d.f(-50.0f, 50.0f, {0.0f}), d.i(0, 256, {0, 1}),
                              d.f(0.01f, 10.0f, {0.25f}), d.f(-100.0f, 100.0f, {0.0f}),
                              d.chance(0.5f) ? dir : -dir);
        }));
    c.push_back(kernelCase(
        "ddaAxis", "ddaAxis(a0)", [](vec3 t) { return ddaAxis(t); },
        [](Draw& d) {
            if (d.chance(0.2f)) {
                const float t = d.f(0.0f, 10.0f);
                return std::tuple(vec3(t));
            }
            return std::tuple(d.v3(0.0f, 10.0f, {1.0f}));
        }));

    // cloud.glsl: the cumulus density of one frame and its bounds. The noises reach the result
    // through cloudShape's soft threshold, which scales their error by up to 1 / softness
    // (softness >= 0.02) and by the density (<= 2)
    const Tolerance cumulusTol{
        .ulps = 4,
        .abs = 0x1p-18f,
        .why = "perlinWorley and worleyFbm (<= 4e-7 absolute on [0, 1], see their rows) through "
               "cloudShape's threshold of width softness >= 0.02, times density <= 2: 2^-18 "
               "absolute (measured worst 1.4e-6)"};
    const Tolerance noiseTol{
        .ulps = 4, .abs = 0x1p-20f, .why = "the noise rows' own absolute tolerance on [0, 1]"};
    c.push_back(kernelCase(
        "cumulusBaseNoise", "cumulusBaseNoise(a0, a1)",
        [](CumulusParams C, vec3 q) { return cumulusBaseNoise(C, q); },
        [](Draw& d) {
            return std::tuple(cumulus(d), d.v3(-4.0f, 4.0f, {0.0f, 0.5f}));
        },
        noiseTol));
    c.push_back(kernelCase(
        "cumulusDetailNoise", "cumulusDetailNoise(a0, a1)",
        [](CumulusParams C, vec3 q) { return cumulusDetailNoise(C, q); },
        [](Draw& d) {
            return std::tuple(cumulus(d), d.v3(-4.0f, 4.0f, {0.0f, 0.5f}));
        },
        noiseTol));
    // Olajos' channel layout (field.evaluation = "rgba"): the channels and their combinations
    auto channels = [](Draw& d) {
        return vec4(d.v3(0.0f, 1.0f, {0.0f, 1.0f}), d.f(0.0f, 1.0f, {0.0f, 1.0f}));
    };
    c.push_back(kernelCase(
        "perlinWorleyOf", "perlinWorleyOf(a0, a1)",
        [](float perlin01, float worley) { return perlinWorleyOf(perlin01, worley); },
        [](Draw& d) {
            return std::tuple(d.f(0.0f, 1.0f, {0.0f, 0.5f, 1.0f}), d.f(0.0f, 1.0f, {0.0f, 1.0f}));
        }));
    c.push_back(kernelCase(
        "cumulusBaseChannels", "cumulusBaseChannels(a0, a1)",
        [](CumulusParams C, vec3 q) { return cumulusBaseChannels(C, q); },
        [](Draw& d) {
            return std::tuple(cumulus(d), d.v3(-4.0f, 4.0f, {0.0f, 0.5f}));
        },
        noiseTol));
    c.push_back(kernelCase(
        "cumulusBaseFromChannels", "cumulusBaseFromChannels(a0)",
        [](vec4 ch) { return cumulusBaseFromChannels(ch); },
        [channels](Draw& d) { return std::tuple(channels(d)); }));
    c.push_back(kernelCase(
        "cumulusDetailChannels", "cumulusDetailChannels(a0, a1)",
        [](CumulusParams C, vec3 q) { return cumulusDetailChannels(C, q); },
        [](Draw& d) {
            return std::tuple(cumulus(d), d.v3(-4.0f, 4.0f, {0.0f, 0.5f}));
        },
        noiseTol));
    c.push_back(kernelCase(
        "cumulusDetailFromChannels", "cumulusDetailFromChannels(a0, a1)",
        [](CumulusParams C, vec4 ch) { return cumulusDetailFromChannels(C, ch); },
        [channels](Draw& d) { return std::tuple(cumulus(d), channels(d)); }));
    c.push_back(kernelCase(
        "cumulusBaseDomain", "cumulusBaseDomain(a0, a1)",
        [](CumulusParams C, vec3 p) { return cumulusBaseDomain(C, p); },
        [](Draw& d) {
            const CumulusParams C = cumulus(d);
            return std::tuple(C, layerPoint(d, C));
        }));
    c.push_back(kernelCase(
        "cumulusDetailDomain", "cumulusDetailDomain(a0, a1)",
        [](CumulusParams C, vec3 p) { return cumulusDetailDomain(C, p); },
        [](Draw& d) {
            const CumulusParams C = cumulus(d);
            return std::tuple(C, layerPoint(d, C));
        }));
    c.push_back(kernelCase(
        "cumulusEnvelope", "cumulusEnvelope(a0, a1)",
        [](CumulusParams C, vec3 p) { return cumulusEnvelope(C, p); },
        [](Draw& d) {
            const CumulusParams C = cumulus(d);
            return std::tuple(C, layerPoint(d, C));
        },
        towers));
    c.push_back(kernelCase(
        "cumulusDensity", "cumulusDensity(a0, a1)",
        [](CumulusParams C, vec3 p) { return cumulusDensity(C, p); },
        [](Draw& d) {
            const CumulusParams C = cumulus(d);
            return std::tuple(C, layerPoint(d, C));
        },
        cumulusTol));
    c.push_back(kernelCase(
        "cumulusEnvelopeBound", "cumulusEnvelopeBound(a0, a1, a2)",
        [](CumulusParams C, vec3 lo, vec3 hi) { return cumulusEnvelopeBound(C, lo, hi); },
        [](Draw& d) {
            const CumulusParams C = cumulus(d);
            const vec3 lo = layerPoint(d, C);
            return std::tuple(C, lo, lo + d.v3(0.0f, 3.0f * C.layer.towerSpacing, {0.0f}));
        },
        towers));
    c.push_back(kernelCase(
        "cumulusDensityBound", "cumulusDensityBound(a0, a1, a2)",
        [](CumulusParams C, float env, float base) { return cumulusDensityBound(C, env, base); },
        [](Draw& d) {
            return std::tuple(cumulus(d), d.f(0.0f, 1.0f, {0.0f, 1.0f}),
                              d.f(0.0f, 1.0f, {0.0f, 1.0f}));
        },
        unitScale));

    // lighting.glsl: the march step
    c.push_back(kernelCase(
        "powderFactor", "powderFactor(a0)", [](float dd) { return powderFactor(dd); },
        [depth](Draw& d) { return std::tuple(depth(d)); }, viaExp,
        [](float dd) { return float(2.0 * expError(-2.0 * dd)); }));
    c.push_back(kernelCase(
        "freeFlight", "freeFlight(a0, a1, a2)",
        [](float t, float sm, float u) { return freeFlight(t, sm, u); },
        [](Draw& d) {
            return std::tuple(d.f(0.0f, 100.0f, {0.0f}),
                              d.chance(0.3f) ? d.logUniform(1e-3f, 1e5f) : d.f(0.1f, 10.0f),
                              d.f(0.0f, 0.999f, {0.0f, 0.5f}));
        },
        Tolerance{.ulps = 4,
                  .why = "GLSL's log() is exact to 2^-21 absolute on [0.5, 2] (where 1 - u "
                         "lies for most u), divided by sigma_maj"},
        [](float, float sm, float) { return float(0x1p-21 / double(sm)); }));
    c.push_back(kernelCase(
        "inScatterFactor", "inScatterFactor(a0, a1, a2, a3, a4, a5)",
        [](int mode, float rho, float tau, vec3 st, float k, float strength) {
            return inScatterFactor(mode, rho, tau, st, k, strength);
        },
        [depth](Draw& d) {
            return std::tuple(d.i(0, 2), d.f(0.0f, 2.0f, {0.0f}), depth(d),
                              d.v3(0.0f, 20.0f, {1.0f}), d.f(0.0f, 5.0f, {2.0f}),
                              d.f(0.0f, 1.0f, {0.0f, 0.5f, 1.0f}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-21f,
                  .why = "exp() inside mix(1, x, s) on [0, 2] (mix differs from glm's by an ulp "
                         "of its operands): 2^-21 absolute"}));
    c.push_back(kernelCase(
        "octaveSun", "octaveSun(a0, a1, a2, a3, a4)",
        [](vec3 ph, vec3 st, float tau, float w, float e) { return octaveSun(ph, st, tau, w, e); },
        [depth](Draw& d) {
            return std::tuple(d.v3(0.0f, 10.0f, {0.0795774715f}), d.v3(0.0f, 20.0f, {1.0f}),
                              depth(d), d.f(0.0f, 1.0f, {1.0f, 0.5f}),
                              d.f(0.0f, 1.0f, {1.0f, 0.5f}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-20f,
                  .why = "exp()'s error on e^{-x} in [0, 1], times phase <= 10: 2^-20 absolute"}));
    c.push_back(kernelCase(
        "octaveGateFactor", "octaveGateFactor(a0, a1, a2)",
        [](vec3 ss, float gate, float tau) { return octaveGateFactor(ss, gate, tau); },
        [depth](Draw& d) {
            return std::tuple(d.v3(0.0f, 20.0f, {1.0f}), d.f(0.0f, 2.0f, {0.0f, 0.25f}), depth(d));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-20f,
                  .why = "1 - exp(-x): exp()'s error on [0, 1], 2^-20 absolute"}));
    c.push_back(kernelCase(
        "octaveGateNeedsAway", "octaveGateNeedsAway(a0, a1, a2)",
        [](vec3 ss, float gate, float tau) { return octaveGateNeedsAway(ss, gate, tau); },
        [](Draw& d) {
            return std::tuple(d.v3(0.0f, 20.0f, {1.0f, 28.0f}), d.f(0.0f, 2.0f, {0.25f}),
                              d.f(0.0f, 60.0f, {1.0f, 28.0f}));
        },
        Tolerance{.ulps = 0, .abs = 0.0f, .why = "a comparison: the same answer"}));
    c.push_back(kernelCase(
        "boxExitPoint", "boxExitPoint(a0, a1, a2, a3)",
        [](vec3 p, vec3 w, vec3 lo, vec3 hi) { return boxExitPoint(p, w, lo, hi); },
        [](Draw& d) {
            const vec3 lo = d.v3(-10.0f, 10.0f, {0.0f}), hi = lo + d.v3(0.1f, 20.0f, {1.0f});
            const vec3 p = lo + d.v3(0.0f, 1.0f, {0.0f, 0.5f, 1.0f}) * (hi - lo);
            return std::tuple(p, d.unitVector(), lo, hi);
        },
        Tolerance{.ulps = 4,
                  .abs = 4e-5f,
                  .why = "GLSL's division is exact to 2.5 ulp: the distance to the face (up to "
                         "about 35 units through a 20-unit box) times w, added to p"}));
    c.push_back(kernelCase(
        "p1Radiance", "p1Radiance(a0, a1, a2, a3, a4, a5, a6)",
        [](float phi, vec3 g, float str, float rho, float gg, float p1, vec3 wo) {
            return p1Radiance(phi, g, str, rho, gg, p1, wo);
        },
        [](Draw& d) {
            return std::tuple(d.f(0.0f, 10.0f, {0.0f, 1.0f}), d.v3(-20.0f, 20.0f, {0.0f}),
                              d.f(0.0f, 20.0f, {0.0f, 1.0f}), d.f(0.0f, 2.0f, {0.0f, 1.0f}),
                              d.f(-0.9f, 0.9f, {0.0f, 0.8f}), d.f(0.0f, 1.0f, {1.0f}),
                              d.unitVector());
        },
        Tolerance{.ulps = 8,
                  .abs = 0x1p-18f,
                  .why = "length() and a dot product on values up to 10 whose sum with phi may "
                         "cancel toward 0: 2^-18 absolute"}));
    c.push_back(kernelCase(
        "skyColumnInScatter", "skyColumnInScatter(a0, a1, a2, a3, a4, a5, a6)",
        [](float up, float down, vec3 str, vec3 kappa, vec3 su, vec3 sd, float k) {
            return skyColumnInScatter(up, down, str, kappa, su, sd, k);
        },
        [](Draw& d) {
            return std::tuple(d.f(0.0f, 5.0f, {0.0f}), d.f(0.0f, 5.0f, {0.0f}),
                              d.v3(0.0f, 10.0f, {1.0f}), d.v3(0.0f, 1.7f, {0.0f}),
                              d.v3(0.0f, 2.0f, {1.0f}), d.v3(0.0f, 2.0f, {1.0f}),
                              d.f(0.1f, 4.0f, {1.0f}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-20f,
                  .why = "two exp()s and mix() on skies <= 2: 2^-20 absolute"}));
    c.push_back(kernelCase(
        "skyRadianceToward", "skyRadianceToward(a0, a1, a2, a3)",
        [](int kind, vec3 z, vec3 h, vec3 d) { return skyRadianceToward(kind, z, h, d); },
        [](Draw& d) {
            return std::tuple(d.i(0, 2, {0, 1, 2}), d.v3(0.0f, 4.0f, {1.0f}),
                              d.v3(0.0f, 4.0f, {0.5f}), d.unitVector());
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-21f,
                  .why = "sqrt() inside mix() on radiances <= 4: 2^-21 absolute"}));
    c.push_back(kernelCase(
        "skyHeightInScatter", "skyHeightInScatter(a0, a1, a2)",
        [](vec3 a, float h, float g) { return skyHeightInScatter(a, h, g); },
        [](Draw& d) {
            return std::tuple(d.v3(0.0f, 2.0f, {1.0f}), d.f(0.0f, 1.0f, {0.0f, 1.0f}),
                              d.f(0.0f, 1.0f, {0.3f}));
        }));
    c.push_back(kernelCase(
        "substeps", "substeps(a0, a1)", [](float tau, float most) { return substeps(tau, most); },
        [](Draw& d) {
            // steps from thin to far past the cap of 64, limits from off (0) up; quotients
            // within an ulp or two of a whole number are rare among random draws
            return std::tuple(d.f(0.0f, 40.0f, {0.0f, 0.25f, 0.26f, 1000.0f}),
                              d.f(0.0f, 1.0f, {0.0f, 0.25f}));
        },
        exact));
    c.push_back(kernelCase(
        "splitDensity", "splitDensity(a0, a1)",
        [](float rho, float around) { return splitDensity(rho, around); },
        [](Draw& d) {
            // a sample outside the cloud (0) beside one inside, and the other way round
            return std::tuple(d.f(0.0f, 5.0f, {0.0f, 2.0f}), d.f(0.0f, 5.0f, {0.0f, 3.0f}));
        },
        exact));
    c.push_back(kernelCase(
        "substepOffset", "substepOffset(a0, a1)",
        [](int j, float jitter) { return substepOffset(j, jitter); },
        [](Draw& d) {
            return std::tuple(d.i(0, 63, {0, 1, 63}), unit(d));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-23f,
                  .why = "fract() of a sum in [0, 40): an ulp of the sum, 2^-23 absolute"}));
    c.push_back(kernelCase(
        "substepT", "substepT(a0, a1, a2, a3)",
        [](float t0, float h, int j, float jitter) { return substepT(t0, h, j, jitter); },
        [](Draw& d) {
            return std::tuple(d.f(0.0f, 50.0f, {0.0f}), d.f(0.0f, 1.0f, {0.25f}),
                              d.i(0, 63, {0, 63}), unit(d));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-18f,
                  .why = "substepOffset's ulp of the sum times h, added to t0 (up to 50)"}));
    c.push_back(kernelCase(
        "lightFraction", "lightFraction(a0, a1)",
        [](float f, float tau) { return lightFraction(f, tau); },
        [](Draw& d) {
            // thin steps (the series), thick ones, and a step of 2.5e4 split 64 ways
            return std::tuple(unit(d), d.chance(0.3f) ? d.logUniform(1e-6f, 1e5f)
                                                      : d.f(0.0f, 2.0f, {0.0f, 0.01f, 390.0f}));
        },
        Tolerance{.ulps = 4,
                  .why = "log() of 1 - f (1 - e^-tau), exact to 2^-21 absolute near 1 and a few "
                         "ulps of the result elsewhere, and exp()'s 2^-22 on e^-tau through f / "
                         "(1 - f (1 - e^-tau)), over tau; the series below 0.01: ulps"},
        [](float f, float tau) {
            if (!(tau >= 0.01f)) return 0.0f;
            const double a = std::max(1.0 - double(f) * (1.0 - std::exp(-double(tau))), 1e-30);
            return float((0x1p-21 * (1.0 + std::abs(std::log(a))) + 0x1p-22 * f / a) / tau);
        }));
    c.push_back(kernelCase(
        "fibonacciPoint", "fibonacciPoint(a0, a1, a2)",
        [](int i, int n, vec2 o) { return fibonacciPoint(i, n, o); },
        [](Draw& d) {
            const int n = d.i(1, 256, {1, 8, 256});
            return std::tuple(d.i(0, n - 1, {0}), n, vec2(unit(d), unit(d)));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-23f,
                  .why = "fract() of sums in [0, 2) whose division GLSL need not round "
                         "correctly: an ulp of the operands, 2^-23 absolute"}));
    c.push_back(kernelCase(
        "fibonacciDirection", "fibonacciDirection(a0, a1)",
        [](int i, int n) { return fibonacciDirection(i, n); },
        [](Draw& d) {
            const int n = d.i(1, 256, {1, 2, 32, 256});
            return std::tuple(d.i(0, n - 1, {0}), n);
        },
        unitScale));
    c.push_back(kernelBlock(
        "marchStep",
        "vec3 L = a5; vec3 T = a6; marchStep(a0, a1, a2, a3, a4, L, T);"
        " r = float[6](L.x, L.y, L.z, T.x, T.y, T.z);",
        [](vec3 S, vec3 ss, vec3 st, float rho, float dt, vec3 L, vec3 T) {
            marchStep(S, ss, st, rho, dt, L, T);
            return std::array<float, 6>{L.x, L.y, L.z, T.x, T.y, T.z};
        },
        [](Draw& d) {
            const vec3 ss = d.v3(0.5f, 20.0f, {1.0f});
            return std::tuple(d.v3(0.0f, 5.0f, {0.0f}), ss, ss + d.v3(0.0f, 1.0f, {0.0f}),
                              d.f(0.01f, 2.0f, {1.0f}), d.f(0.001f, 0.5f, {0.05f}),
                              d.v3(0.0f, 5.0f, {0.0f}), d.v3(0.0f, 1.0f, {1.0f}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-19f,
                  .why = "stepIntegral's exp() where sigma_t rho dt >= 5e-4 (no cancellation "
                         "regime, see its row), scaled by S sigma_s / sigma_t <= 5: 2^-19 "
                         "absolute"}));

    // pixel.glsl: reconstruction filters and stratified sample offsets
    const Tolerance filterTol{.ulps = 4,
                              .abs = 0x1p-22f,
                              .why = "exp() and cos() on values of order 1 that cancel toward 0 "
                                     "at the filter's edge: 2^-22 absolute"};
    c.push_back(kernelCase(
        "pixelFilter1D", "pixelFilter1D(a0, a1, a2)",
        [](int kind, float x, float r) { return pixelFilter1D(kind, x, r); },
        [](Draw& d) {
            const float r = d.f(0.25f, 4.0f, {0.5f, 1.0f, 1.5f});
            return std::tuple(d.i(0, 2), d.f(-r - 0.5f, r + 0.5f, {0.0f, r, -r}), r);
        },
        filterTol));
    c.push_back(kernelCase(
        "pixelFilterWeight", "pixelFilterWeight(a0, a1, a2, a3)",
        [](int kind, float dx, float dy, float w) { return pixelFilterWeight(kind, dx, dy, w); },
        [](Draw& d) {
            const float w = d.f(0.5f, 8.0f, {1.0f, 2.0f, 3.0f});
            return std::tuple(d.i(0, 2), d.f(-0.6f * w, 0.6f * w, {0.0f}),
                              d.f(-0.6f * w, 0.6f * w, {0.0f}), w);
        },
        filterTol));
    c.push_back(kernelCase(
        "pixelSampleOffset", "pixelSampleOffset(a0, a1, a2, a3, a4)",
        [](int k, int n, float ux, float uy, float w) {
            return pixelSampleOffset(k, n, ux, uy, w);
        },
        [](Draw& d) {
            const int n = d.i(1, 64, {1, 2, 4, 16});
            return std::tuple(d.i(0, n - 1), n, unit(d), unit(d), d.f(0.5f, 8.0f, {1.0f}));
        }));

    // gardner.glsl: Gardner's textured ellipsoids. sin() of arguments up to F_6 x ~ 6000 rad
    const Tolerance gardnerSin{
        .ulps = 4,
        .abs = 0x1p-16f,
        .why = "sums of sin() of arguments up to ~6000 rad (F_i x), whose GLSL and glibc range "
               "reductions differ: 2^-16 absolute on sums of order 1-10 (measured worst 4.8e-6)"};
    c.push_back(kernelCase(
        "gardnerSum", "gardnerSum(a0, a1, a2)",
        [](GardnerTexture t, float x, float y) { return gardnerSum(t, x, y); },
        [](Draw& d) {
            return std::tuple(gardnerTex(d), d.f(-60.0f, 60.0f, {0.0f}),
                              d.f(-60.0f, 60.0f, {0.0f}));
        },
        gardnerSin));
    c.push_back(kernelCase(
        "gardnerSumMax", "gardnerSumMax(a0)", [](GardnerTexture t) { return gardnerSumMax(t); },
        [](Draw& d) { return std::tuple(gardnerTex(d)); }));
    c.push_back(kernelCase(
        "gardnerTexture", "gardnerTexture(a0, a1)",
        [](GardnerTexture t, vec3 p) { return gardnerTexture(t, p); },
        [](Draw& d) { return std::tuple(gardnerTex(d), d.v3(-20.0f, 20.0f, {0.0f})); },
        gardnerSin));
    c.push_back(kernelCase(
        "gardnerFalloff", "gardnerFalloff(a0)", [](vec3 q) { return gardnerFalloff(q); },
        [](Draw& d) {
            return std::tuple(d.v3(-1.3f, 1.3f, {0.0f, 1.0f}));
        },
        unitScale));
    c.push_back(kernelCase(
        "gardnerTransparency", "gardnerTransparency(a0, a1, a2, a3, a4)",
        [](float I, float g, float t1, float t2, float dd) {
            return gardnerTransparency(I, g, t1, t2, dd);
        },
        [](Draw& d) {
            const float t1 = d.f(-0.2f, 0.5f, {0.0f});
            return std::tuple(d.f(-1.0f, 1.0f, {0.0f, 1.0f}), d.f(-0.3f, 1.0f, {0.0f, 1.0f}), t1,
                              t1 + d.f(0.0f, 0.5f, {0.0f}), d.f(0.01f, 1.0f, {0.15f}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-20f,
                  .why = "1 - x / D with D >= 0.01 cancelling toward 0 (Mesa may reassociate "
                         "the numerator): 2^-20 absolute"}));
    c.push_back(kernelCase(
        "gardnerLocal", "gardnerLocal(a0, a1)",
        [](GardnerEllipsoid e, vec3 p) { return gardnerLocal(e, p); },
        [](Draw& d) {
            const GardnerEllipsoid e = gardnerEll(d);
            return std::tuple(e, gardnerPoint(d, e));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-20f,
                  .why = "dot products of order 1 that cancel toward 0: 2^-20 absolute"}));
    c.push_back(kernelCase(
        "gardnerEllipsoidDensity", "gardnerEllipsoidDensity(a0, a1, a2)",
        [](GardnerEllipsoid e, float I, vec3 p) { return gardnerEllipsoidDensity(e, I, p); },
        [](Draw& d) {
            const GardnerEllipsoid e = gardnerEll(d);
            return std::tuple(e, d.f(-1.0f, 1.0f, {0.0f, 1.0f}), gardnerPoint(d, e));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-12f,
                  .why = "gardnerLocal's 2^-20 through the falloff's slope (T2 - T1) / D <= 50 "
                         "and the density <= 2: 2^-12 absolute (measured worst 1.6e-6)"}));
    c.push_back(kernelCase(
        "gardnerSinSlack", "gardnerSinSlack(a0)", [](float m) { return gardnerSinSlack(m); },
        [](Draw& d) { return std::tuple(d.f(0.0f, 1e4f, {0.0f})); }));
    auto sinInterval = [](Draw& d) {
        const float a = d.f(-6000.0f, 6000.0f, {0.0f, 1.5707964f, -1.5707964f});
        return std::tuple(a, a + d.f(0.0f, 7.0f, {0.0f, 6.2831853f}));
    };
    c.push_back(kernelCase(
        "gardnerSinMax", "gardnerSinMax(a0, a1)",
        [](float a, float b) { return gardnerSinMax(a, b); }, sinInterval, gardnerSin));
    c.push_back(kernelCase(
        "gardnerSinMin", "gardnerSinMin(a0, a1)",
        [](float a, float b) { return gardnerSinMin(a, b); }, sinInterval, gardnerSin));
    c.push_back(kernelCase(
        "gardnerSumRange", "gardnerSumRange(a0, a1, a2)",
        [](GardnerTexture t, float x0, float x1) { return gardnerSumRange(t, x0, x1); },
        [](Draw& d) {
            const float x0 = d.f(-60.0f, 60.0f, {0.0f});
            return std::tuple(gardnerTex(d), x0, x0 + d.f(0.0f, 5.0f, {0.0f}));
        },
        gardnerSin));
    c.push_back(kernelCase(
        "gardnerIntervalProduct", "gardnerIntervalProduct(a0, a1)",
        [](vec2 u, vec2 v) { return gardnerIntervalProduct(u, v); },
        [](Draw& d) {
            const float a = d.f(-2.0f, 2.0f, {0.0f}), b = d.f(-2.0f, 2.0f, {0.0f});
            return std::tuple(vec2(a, a + d.f(0.0f, 2.0f)), vec2(b, b + d.f(0.0f, 2.0f)));
        }));
    c.push_back(kernelCase(
        "gardnerTextureBound", "gardnerTextureBound(a0, a1, a2)",
        [](GardnerTexture t, vec3 lo, vec3 hi) { return gardnerTextureBound(t, lo, hi); },
        [](Draw& d) {
            const vec3 lo = d.v3(-20.0f, 20.0f, {0.0f});
            return std::tuple(gardnerTex(d), lo, lo + d.v3(0.0f, 3.0f, {0.0f}));
        },
        gardnerSin));
    c.push_back(kernelCase(
        "gardnerR2Min", "gardnerR2Min(a0, a1, a2)",
        [](GardnerEllipsoid e, vec3 lo, vec3 hi) { return gardnerR2Min(e, lo, hi); },
        [](Draw& d) {
            const GardnerEllipsoid e = gardnerEll(d);
            const vec3 lo = gardnerPoint(d, e);
            return std::tuple(e, lo, lo + d.v3(0.0f, 3.0f, {0.0f}));
        },
        Tolerance{.ulps = 8,
                  .abs = 0x1p-18f,
                  .why = "squares of dot products that cancel toward 0: 2^-18 absolute"}));
    c.push_back(kernelCase(
        "gardnerEllipsoidBound", "gardnerEllipsoidBound(a0, a1, a2, a3)",
        [](GardnerEllipsoid e, float I, vec3 lo, vec3 hi) {
            return gardnerEllipsoidBound(e, I, lo, hi);
        },
        [](Draw& d) {
            const GardnerEllipsoid e = gardnerEll(d);
            const vec3 lo = gardnerPoint(d, e);
            return std::tuple(e, d.f(-1.0f, 1.0f, {1.0f}), lo, lo + d.v3(0.0f, 3.0f, {0.0f}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-10f,
                  .why = "gardnerR2Min's 2^-18 through the slope (T2 - T1) / D <= 50 and the "
                         "density <= 2: 2^-10 absolute (measured worst 1.8e-6)"}));
    // sdf_shading.glsl
    auto sdfDist = [](Draw& d) { return d.f(0.0f, 5.0f, {0.0f, 1e-6f, 1.0f}); };
    c.push_back(kernelCase(
        "sdfPenumbraClassic", "sdfPenumbraClassic(a0, a1, a2)",
        [](float h, float t, float k) { return sdfPenumbraClassic(h, t, k); },
        [sdfDist](Draw& d) {
            return std::tuple(sdfDist(d), d.f(0.0f, 50.0f, {0.0f, 1e-4f}),
                              d.f(0.0f, 64.0f, {1.0f, 16.0f}));
        }));
    c.push_back(kernelCase(
        "sdfPenumbraImproved", "sdfPenumbraImproved(a0, a1, a2, a3, a4)",
        [](float h, float t, float ph, float st, float k) {
            return sdfPenumbraImproved(h, t, ph, st, k);
        },
        [sdfDist](Draw& d) {
            return std::tuple(sdfDist(d), d.f(0.0f, 50.0f, {0.0f, 1e-4f}),
                              d.f(0.0f, 5.0f, {1e20f, 0.0f, 1.0f}), d.f(0.0f, 5.0f, {0.0f, 1.0f}),
                              d.f(0.0f, 64.0f, {1.0f, 16.0f}));
        }));
    c.push_back(kernelCase(
        "sdfAoDelta", "sdfAoDelta(a0, a1)", [](int i, float s) { return sdfAoDelta(i, s); },
        [](Draw& d) { return std::tuple(d.i(0, 16), d.f(1e-3f, 10.0f, {0.2f})); }));
    c.push_back(kernelCase(
        "sdfAoWeight", "sdfAoWeight(a0, a1, a2)",
        [](int i, float s, float k) { return sdfAoWeight(i, s, k); },
        [](Draw& d) {
            return std::tuple(d.i(0, 16), d.f(1e-3f, 10.0f, {0.2f}), d.f(0.0f, 4.0f, {1.0f}));
        }));
    c.push_back(kernelCase(
        "sdfAoTerm", "sdfAoTerm(a0, a1, a2)",
        [](float delta, float dist, float w) { return sdfAoTerm(delta, dist, w); },
        [sdfDist](Draw& d) {
            return std::tuple(sdfDist(d), d.f(-1.0f, 5.0f, {0.0f}), d.f(0.0f, 10.0f, {1.0f}));
        }));
    c.push_back(kernelCase(
        "sdfAoFinish", "sdfAoFinish(a0)", [](float o) { return sdfAoFinish(o); },
        [](Draw& d) {
            return std::tuple(d.f(-1.0f, 3.0f, {0.0f, 1.0f}));
        }));
    c.push_back(kernelCase(
        "sdfTetraVertex", "sdfTetraVertex(a0)", [](int i) { return sdfTetraVertex(i); },
        [](Draw& d) { return std::tuple(d.i(0, 3)); }));
    // sdf.glsl: differences of lengths (values up to ~16 in magnitude here) that cancel toward 0
    // on the surfaces; the noise rows take noise.glsl's mix() allowance
    const Tolerance distance{.ulps = 4,
                             .abs = 0x1p-17f,
                             .why = "a length minus a size, both <= 16, cancelling toward 0 on "
                                    "the surface: 4 ulp of 16 absolute"};
    auto sdfPoint = [](Draw& d) { return d.v3(-4.0f, 4.0f, {0.0f, 1.0f, -1.0f, 0.5f}); };
    auto sdfSize = [](Draw& d) { return d.f(0.05f, 3.0f, {1.0f, 0.5f}); };
    auto sdfSizes = [sdfSize](Draw& d) { return vec3(sdfSize(d), sdfSize(d), sdfSize(d)); };
    c.push_back(kernelCase(
        "sdSphere", "sdSphere(a0, a1)", [](vec3 p, float r) { return sdSphere(p, r); },
        [=](Draw& d) { return std::tuple(sdfPoint(d), sdfSize(d)); }, distance));
    c.push_back(kernelCase(
        "sdBox", "sdBox(a0, a1)", [](vec3 p, vec3 b) { return sdBox(p, b); },
        [=](Draw& d) { return std::tuple(sdfPoint(d), sdfSizes(d)); }, distance));
    c.push_back(kernelCase(
        "sdRoundBox", "sdRoundBox(a0, a1, a2)",
        [](vec3 p, vec3 b, float r) { return sdRoundBox(p, b, r); },
        [=](Draw& d) {
            const vec3 b = sdfSizes(d);
            return std::tuple(sdfPoint(d), b, d.f(0.0f, std::min(b.x, std::min(b.y, b.z)), {0.0f}));
        },
        distance));
    c.push_back(kernelCase(
        "sdEllipsoid", "sdEllipsoid(a0, a1)", [](vec3 p, vec3 r) { return sdEllipsoid(p, r); },
        [=](Draw& d) { return std::tuple(sdfPoint(d), sdfSizes(d)); }, distance));
    c.push_back(kernelCase(
        "sdSegment2", "sdSegment2(a0, a1, a2)",
        [](vec2 p, vec2 a, vec2 b) { return sdSegment2(p, a, b); },
        [](Draw& d) {
            const vec2 a(d.f(-3.0f, 3.0f, {0.0f}), d.f(-3.0f, 3.0f, {0.0f}));
            return std::tuple(vec2(d.f(-4.0f, 4.0f), d.f(-4.0f, 4.0f)), a,
                              a + vec2(d.f(0.1f, 3.0f), d.f(-3.0f, 3.0f, {0.0f})));
        },
        distance));
    c.push_back(kernelCase(
        "sdCapsule", "sdCapsule(a0, a1, a2, a3)",
        [](vec3 p, vec3 a, vec3 b, float r) { return sdCapsule(p, a, b, r); },
        [=](Draw& d) {
            const vec3 a = d.v3(-2.0f, 2.0f, {0.0f});
            return std::tuple(sdfPoint(d), a, d.chance(0.1f) ? a : d.v3(-2.0f, 2.0f), sdfSize(d));
        },
        distance));
    c.push_back(kernelCase(
        "sdTorus", "sdTorus(a0, a1, a2)", [](vec3 p, float R, float r) { return sdTorus(p, R, r); },
        [=](Draw& d) {
            const float R = sdfSize(d);
            return std::tuple(sdfPoint(d), R, d.f(0.01f, R, {R}));
        },
        distance));
    c.push_back(kernelCase(
        "sdCone", "sdCone(a0, a1, a2)", [](vec3 p, float r, float h) { return sdCone(p, r, h); },
        [=](Draw& d) { return std::tuple(sdfPoint(d), sdfSize(d), sdfSize(d)); }, distance));
    c.push_back(kernelCase(
        "sdPlane", "sdPlane(a0, a1, a2)", [](vec3 p, vec3 n, float o) { return sdPlane(p, n, o); },
        [=](Draw& d) { return std::tuple(sdfPoint(d), d.unitVector(), d.f(-2.0f, 2.0f, {0.0f})); },
        distance));
    auto values = [](Draw& d) {
        const float a = d.f(-4.0f, 4.0f, {0.0f, 1.0f});
        return std::tuple(a, d.chance(0.1f) ? a : d.f(-4.0f, 4.0f, {0.0f, -1.0f}),
                          d.f(0.0f, 2.0f, {0.0f, 0.5f}));
    };
    auto hard = [values](Draw& d) {
        const auto v = values(d);
        return std::tuple(std::get<0>(v), std::get<1>(v));
    };
    c.push_back(kernelCase(
        "sdfUnion", "sdfUnion(a0, a1)", [](float a, float b) { return sdfUnion(a, b); }, hard,
        exact));
    c.push_back(kernelCase(
        "sdfIntersection", "sdfIntersection(a0, a1)",
        [](float a, float b) { return sdfIntersection(a, b); }, hard, exact));
    c.push_back(kernelCase(
        "sdfSubtraction", "sdfSubtraction(a0, a1)",
        [](float a, float b) { return sdfSubtraction(a, b); }, hard, exact));
    c.push_back(kernelCase(
        "sdfSmoothMin", "sdfSmoothMin(a0, a1, a2)",
        [](float a, float b, float k) { return sdfSmoothMin(a, b, k); }, values, distance));
    c.push_back(kernelCase(
        "sdfSmoothMax", "sdfSmoothMax(a0, a1, a2)",
        [](float a, float b, float k) { return sdfSmoothMax(a, b, k); }, values, distance));
    c.push_back(kernelCase(
        "sdfSmoothUnion", "sdfSmoothUnion(a0, a1, a2)",
        [](float a, float b, float k) { return sdfSmoothUnion(a, b, k); }, values, distance));
    c.push_back(kernelCase(
        "sdfSmoothIntersection", "sdfSmoothIntersection(a0, a1, a2)",
        [](float a, float b, float k) { return sdfSmoothIntersection(a, b, k); }, values,
        distance));
    c.push_back(kernelCase(
        "sdfSmoothSubtraction", "sdfSmoothSubtraction(a0, a1, a2)",
        [](float a, float b, float k) { return sdfSmoothSubtraction(a, b, k); }, values, distance));
    // sdf_tree.glsl: one node of a flattened tree (a random transform, parameters valid for its
    // kind, sometimes a displacement), as nimbus::sdfTreeNode packs it
    auto treeNode = [sdfSize](Draw& d, bool primitive) {
        SdfNode n;
        n.kind = SdfKind(primitive ? d.i(0, 7) : d.i(0, 10));
        n.childCount = sdfIsPrimitive(n.kind) ? 0 : d.i(1, 2);
        for (int c = 0; c < 3; ++c) n.localFromWorld[c] = d.v3(-1.5f, 1.5f, {0.0f, 1.0f});
        n.localOffset = d.v3(-2.0f, 2.0f, {0.0f});
        n.factor = d.f(0.3f, 1.5f, {1.0f});
        const vec3 a(sdfSize(d), sdfSize(d), sdfSize(d));
        n.p0 = vec4(a, 0.5f * std::min(a.x, std::min(a.y, a.z)));
        if (n.kind == SdfKind::Torus) n.p0 = vec4(std::max(a.x, a.y), std::min(a.x, a.y), 0, 0);
        if (n.kind == SdfKind::Plane) n.p0 = vec4(d.unitVector(), d.f(-1.0f, 1.0f, {0.0f}));
        if (n.kind == SdfKind::Capsule) n.p0 = vec4(d.v3(-1.0f, 1.0f), a.x);
        n.p1 = vec4(d.v3(-1.0f, 1.0f), 0.0f);
        n.k = d.f(0.0f, 1.0f, {0.0f});
        if (d.chance(0.5f)) {
            n.amplitude = d.f(0.05f, 0.5f);
            n.noise = d.i(0, 1);
            n.frequency = d.f(0.5f, 3.0f, {1.0f});
            n.octaves = d.i(1, 4);
            n.gain = d.f(0.3f, 0.7f, {0.5f});
            n.seed = d.u({0u, 1u});
        }
        return sdfTreeNode(n);
    };
    c.push_back(kernelCase(
        "sdfTreePrimitive", "sdfTreePrimitive(a0, a1)",
        [](SdfTreeNode n, vec3 q) { return sdfTreePrimitive(n, q); },
        [=](Draw& d) { return std::tuple(treeNode(d, true), sdfPoint(d)); }, distance));
    c.push_back(kernelCase(
        "sdfTreeCombine", "sdfTreeCombine(a0, a1, a2, a3)",
        [](int op, float a, float b, float k) { return sdfTreeCombine(op, a, b, k); },
        [=](Draw& d) {
            const auto [a, b, k] = values(d);
            return std::tuple(d.i(7, 10), a, b, k);
        },
        distance));
    c.push_back(kernelBlock(
        "sdfTreeStep",
        "SdfTreeStack s; s.sp = 2; s.v[0] = a2; s.v[1] = a3; sdfTreeStep(a0, a1, true, s);"
        " r = float[3](s.v[0], s.v[1], float(s.sp));",
        [](SdfTreeNode n, vec3 p, float v0, float v1) {
            SdfTreeStack s;
            s.sp = 2;
            s.v[0] = v0;
            s.v[1] = v1;
            sdfTreeStep(n, p, true, s);
            return std::array<float, 3>{s.v[0], s.v[1], float(s.sp)};
        },
        [=](Draw& d) {
            return std::tuple(treeNode(d, false), sdfPoint(d), d.f(-4.0f, 4.0f, {0.0f}),
                              d.f(-4.0f, 4.0f, {0.0f}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-16f,
                  .why = "the transform (three products summed, values up to ~20) feeds the "
                         "primitive and the noise: 4 ulp of 32 absolute"}));
    c.push_back(kernelCase(
        "sdfNoise", "sdfNoise(a0, a1, a2, a3, a4, a5)",
        [](vec3 p, int kind, float freq, int oct, float gain, uint seed) {
            return sdfNoise(p, kind, freq, oct, gain, seed);
        },
        [](Draw& d) {
            return std::tuple(noisePoint(d) * 0.25f, d.i(0, 1), d.f(0.1f, 4.0f, {1.0f}),
                              d.i(1, 5, {1, 5}), d.f(0.3f, 0.7f, {0.5f}), d.u({0u, 1u}));
        },
        Tolerance{.ulps = 4,
                  .abs = 0x1p-20f,
                  .why = "perlinFbm's 2^-21 (mix); 1 - 2 w doubles worleyFbm's rounding near 0: "
                         "2^-20 absolute"}));
    c.push_back(kernelCase(
        "sdfSkipDistance", "sdfSkipDistance(a0, a1, a2)",
        [](float dd, float a, float l) { return sdfSkipDistance(dd, a, l); },
        [](Draw& d) {
            return std::tuple(d.f(-4.0f, 4.0f, {0.0f}), d.f(0.0f, 1.0f, {0.0f}),
                              d.f(-1.0f, 1.0f, {0.0f}));
        },
        distance));
    c.push_back(kernelCase(
        "sdfDensityFromDistance", "sdfDensityFromDistance(a0, a1)",
        [](float dd, float w) { return sdfDensityFromDistance(dd, w); },
        [](Draw& d) {
            const float w = d.f(0.0f, 1.0f, {0.0f, 0.25f});
            return std::tuple(d.f(-1.5f, 0.5f, {0.0f, -w, -0.5f * w}), w);
        },
        unitScale));

    return c;
}

const std::vector<KernelCase>& parityCases() {
    static const std::vector<KernelCase> cases = makeCases();
    return cases;
}

std::vector<std::string> parityCaseNames() {
    std::vector<std::string> names;
    for (const KernelCase& k : parityCases()) names.push_back(k.name);
    return names;
}

/// The process's GL context, made on first use; null with *error when EGL fails.
gl::ComputeContext* glContext(std::string* error) {
    return gl::ComputeContext::shared(error);
}

std::string readFile(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

} // namespace

// ------------------------------------------------------------------ the embedding

TEST(GlslEmbedding, ListIsTheIncludeOrderOfKernelsH) {
    // kernels.h is the one list: the embedded files are its #include lines, in order
    const std::string header = readFile(NIMBUS_SOURCE_DIR "/core/kernels/kernels.h");
    const std::regex include(R"(^#include "core/kernels/(\w+)\.glsl")", std::regex::multiline);
    std::vector<std::string> listed;
    for (auto it = std::sregex_iterator(header.begin(), header.end(), include);
         it != std::sregex_iterator(); ++it)
        listed.push_back((*it)[1]);
    ASSERT_FALSE(listed.empty());
    std::vector<std::string> embedded;
    for (const KernelSource& k : kernelSources()) embedded.emplace_back(k.name);
    EXPECT_EQ(embedded, listed);
}

TEST(GlslEmbedding, TextIsTheFilesOnDisk) {
    EXPECT_EQ(glslPrelude(), readFile(NIMBUS_SOURCE_DIR "/core/kernels/prelude.glsl"));
    for (const KernelSource& k : kernelSources()) {
        EXPECT_EQ(k.path, "core/kernels/" + std::string(k.name) + ".glsl");
        EXPECT_EQ(k.text, readFile(NIMBUS_SOURCE_DIR "/" + std::string(k.path))) << k.path;
        EXPECT_EQ(findKernelSource(k.name), &k);
    }
    EXPECT_EQ(findKernelSource("no_such_kernel"), nullptr);
}

TEST(GlslEmbedding, LibraryIsPreludeThenNumberedKernelsWithoutVersion) {
    const std::string lib = glslLibrary();
    EXPECT_NE(lib.rfind("#version", 0), 0u); // no #version line: the pass writes its own
    EXPECT_EQ(lib.find("\n#version"), std::string::npos);
    EXPECT_EQ(lib.rfind(glslPrelude(), 0), 0u);
    std::size_t at = glslPrelude().size(), afterFirst = 0;
    const auto kernels = kernelSources();
    for (std::size_t i = 0; i < kernels.size(); ++i) {
        const std::string line = "#line 1 " + std::to_string(i + 1) + "\n";
        ASSERT_EQ(lib.compare(at, line.size(), line), 0) << kernels[i].name;
        at += line.size();
        ASSERT_EQ(lib.compare(at, kernels[i].text.size(), kernels[i].text), 0) << kernels[i].name;
        at += kernels[i].text.size();
        if (lib[at - 1] != '\n') ++at;
        if (i == 0) afterFirst = at;
    }
    EXPECT_EQ(at, lib.size());
    // a prefix stops after the requested kernel
    EXPECT_EQ(glslLibrary(1), lib.substr(0, afterFirst));
}

TEST(GlslEmbedding, EveryPhaseConstantIsAPhaseKind) {
    // enum_mirrors.h checks each PhaseKind against its PHASE_* at compile time; this checks the
    // other direction: no PHASE_* in phase.glsl lacks an enumerator of the same value.
    const KernelSource* phase = findKernelSource("phase");
    ASSERT_NE(phase, nullptr);
    const std::string text(phase->text);
    const std::regex constant(R"(const int PHASE_(\w+) = (-?\d+);)");
    std::set<int> values;
    for (auto it = std::sregex_iterator(text.begin(), text.end(), constant);
         it != std::sregex_iterator(); ++it) {
        const int v = std::stoi((*it)[2]);
        EXPECT_EQ(glslPhaseKind(PhaseKind(v)), v)
            << "PHASE_" << (*it)[1] << " = " << v << " has no PhaseKind enumerator";
        EXPECT_TRUE(values.insert(v).second) << "PHASE_" << (*it)[1] << " repeats " << v;
    }
    EXPECT_EQ(values.size(), 6u);
}

// ------------------------------------------------------------------ GPU parity

TEST(GlslParityTable, EveryKernelFunctionHasARow) {
    // every NB_FN function of the embedded kernels is called by some row of parityCases():
    // a new kernel function fails here until it has its row (GLSL call, C++ call, inputs)
    const std::regex function(R"(NB_FN\s+\w+\s+(\w+)\s*\()");
    const std::regex call(R"((\w+)\s*\()");
    std::set<std::string> called;
    for (const KernelCase& k : parityCases())
        for (auto it = std::sregex_iterator(k.body.begin(), k.body.end(), call);
             it != std::sregex_iterator(); ++it)
            called.insert((*it)[1]);
    int functions = 0;
    for (const KernelSource& k : kernelSources()) {
        const std::string text(k.text);
        for (auto it = std::sregex_iterator(text.begin(), text.end(), function);
             it != std::sregex_iterator(); ++it, ++functions)
            EXPECT_TRUE(called.count((*it)[1]))
                << (*it)[1] << " (" << k.path << ") has no row in parityCases()";
    }
    EXPECT_GT(functions, 40);
}

class GlslParity : public ::testing::TestWithParam<std::string> {};

TEST_P(GlslParity, MatchesCpp) {
    std::string error;
    gl::ComputeContext* context = glContext(&error);
    ASSERT_NE(context, nullptr) << "no headless OpenGL 4.5 context (EGL surfaceless, Mesa "
                                   "llvmpipe; packages libegl-dev libopengl-dev "
                                   "libgl1-mesa-dri): "
                                << error;
    const KernelCase* kc = nullptr;
    for (const KernelCase& k : parityCases())
        if (k.name == GetParam()) kc = &k;
    ASSERT_NE(kc, nullptr);
    const parity::ParityResult r = parity::runParity(*kc);
    ASSERT_TRUE(r.ran) << kc->name << " on " << context->renderer() << ":\n" << r.error;
    RecordProperty("worst_ulp_" + kc->name, std::to_string(r.worstUlp));
    RecordProperty("inputs_" + kc->name, std::to_string(r.count));
    auto g3 = [](double v) { // 3 significant digits, whatever the magnitude
        std::ostringstream s;
        s.precision(3);
        s << v;
        return s.str();
    };
    RecordProperty("worst_abs_" + kc->name, g3(r.worstAbs));
    RecordProperty("tolerance_used_" + kc->name, g3(r.worstShare));
    EXPECT_EQ(r.failures, 0) << kc->name << ": " << r.failures << " of " << r.count
                             << " inputs outside " << kc->tolerance.ulps << " ulp"
                             << (kc->tolerance.why.empty() ? "" : " / " + kc->tolerance.why)
                             << " (worst " << r.worstUlp << " ulp, " << r.worstAbs
                             << " absolute); the worst:\n"
                             << r.worstFailure;
}

INSTANTIATE_TEST_SUITE_P(Kernels, GlslParity, ::testing::ValuesIn(parityCaseNames()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                             return info.param;
                         });
