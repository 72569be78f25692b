// Several volumes and instances (core/tracking/volumes.h), found by a linear scan or by Embree
// (plugin/geom): placements, overlaps, rotations, majorant correctness and the coarse grid.
#include <cmath>

#include <gtest/gtest.h>

#include "core/integrators/pathtrace.h"
#include "core/render.h"
#include "render_util.h"
#include "core/sampler.h"
#include "core/tracking/volumes.h"
#include "plugin/geom/embree_geometry.h"

using namespace nimbus;

namespace {

SceneDesc boxes() {
    SceneDesc s;
    s.camera.position = vec3(0.0f, 0.0f, -12.0f);
    s.camera.lookAt = vec3(0.0f);
    s.camera.width = 48;
    s.camera.height = 32;
    s.camera.fovY = 40.0f;
    s.field.kind = FieldKind::Homogeneous;
    s.field.homogeneous.box = Box{vec3(-1.0f, -0.5f, -0.25f), vec3(1.0f, 0.5f, 0.25f)};
    s.field.homogeneous.density = 1.0f;
    s.medium.sigma_s = vec3(0.8f);
    s.medium.sigma_a = vec3(0.1f);
    s.sun.direction = glm::normalize(vec3(0.3f, 1.0f, -0.4f));
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(0.2f);
    s.render.background = Background::Transparent;
    s.render.step = 0.01f;
    s.render.shadowStep = 0.01f;
    s.render.shadowGrowth = 0.0f;
    s.render.jitter = false;
    s.render.epsilon = 0.0f;
    s.render.threads = 2;
    // the diffusion grid covers one untransformed volume only: compare like with like
    s.render.multipleScattering = MultipleScattering::None;
    return s;
}

double maxDiff(const Framebuffer& a, const Framebuffer& b) {
    double m = 0.0;
    for (size_t i = 0; i < a.rgba.size(); ++i)
        m = std::max(m, double(std::abs(a.rgba[i] - b.rgba[i])));
    return m;
}

double maxValue(const Framebuffer& a) {
    double m = 0.0;
    for (float v : a.rgba) m = std::max(m, double(v));
    return m;
}

std::shared_ptr<const GeometryBackend> embree(const SceneDesc& s) {
    std::vector<std::string> warnings;
    return geom::makeEmbreeGeometry(s, "", warnings);
}

} // namespace

TEST(Instances, TranslatedInstanceEqualsMovedField) {
    SceneDesc a = boxes();
    a.instances.push_back(InstanceDesc{0, vec3(0.7f, 0.4f, 0.5f)});
    SceneDesc b = boxes();
    b.field.homogeneous.box.lo += vec3(0.7f, 0.4f, 0.5f);
    b.field.homogeneous.box.hi += vec3(0.7f, 0.4f, 0.5f);
    const Framebuffer fa = renderScene(a), fb = renderScene(b);
    ASSERT_GT(maxValue(fb), 0.05);
    EXPECT_LT(maxDiff(fa, fb), 1e-4);
}

TEST(Instances, RotatedAndScaledInstanceEqualsTheBoxItBecomes) {
    // 90 degrees about y maps x -> -z and z -> x: the 2 x 1 x 0.5 box becomes 0.5 x 1 x 2;
    // scale (1, 2, 1) first makes it 2 x 2 x 0.5 -> 0.5 x 2 x 2
    SceneDesc a = boxes();
    InstanceDesc d;
    d.rotate = vec3(0.0f, 90.0f, 0.0f);
    d.scale = vec3(1.0f, 2.0f, 1.0f);
    a.instances.push_back(d);
    SceneDesc b = boxes();
    b.field.homogeneous.box = Box{vec3(-0.25f, -1.0f, -1.0f), vec3(0.25f, 1.0f, 1.0f)};
    const Framebuffer fa = renderScene(a), fb = renderScene(b);
    ASSERT_GT(maxValue(fb), 0.05);
    // box edges sampled at 0.01 steps: a sample may fall on the other side of a face
    EXPECT_LT(maxDiff(fa, fb), 0.02);
}

TEST(Instances, OverlappingInstancesAddTheirExtinction) {
    SceneDesc a = boxes();
    a.instances = {InstanceDesc{0, vec3(0.0f), vec3(0.0f), vec3(1.0f), 0.25f},
                   InstanceDesc{0, vec3(0.0f), vec3(0.0f), vec3(1.0f), 0.75f}};
    SceneDesc b = boxes();
    b.instances = {InstanceDesc{0, vec3(0.0f), vec3(0.0f), vec3(1.0f), 1.0f}};
    const Framebuffer fa = renderScene(a), fb = renderScene(b);
    EXPECT_LT(maxDiff(fa, fb), 1e-4);
}

TEST(Instances, EmbreeFindsTheSameInstancesAsALinearScan) {
    SceneDesc s = boxes();
    s.camera.position = vec3(0.0f, 2.0f, -30.0f);
    for (int i = 0; i < 40; ++i) {
        InstanceDesc d;
        d.translate = vec3(float(i % 8) * 2.5f - 9.0f, float(i / 8) * 1.3f - 3.0f, float(i % 3));
        d.rotate = vec3(0.0f, float(i) * 17.0f, float(i) * 5.0f);
        d.density = 0.5f + 0.05f * float(i);
        s.instances.push_back(d);
    }
    const Framebuffer scan = renderScene(s);
    FrameBindings b;
    b.geometry = embree(s);
    const Framebuffer bvh = renderScene(s, b);
    ASSERT_GT(maxValue(scan), 0.05);
    EXPECT_LT(maxDiff(scan, bvh), 1e-5);
}

TEST(Instances, CoarseGridRendersTheSameImageAsHierarchicalSkipping) {
    SceneDesc s = boxes();
    s.field.kind = FieldKind::Cumulus;
    s.field.cumulus.bounds = Box{vec3(-3.0f, -1.0f, -3.0f), vec3(3.0f, 1.0f, 3.0f)};
    s.field.cumulus.towerSpacing = 3.0f;
    s.field.cumulus.towerRadiusMin = 1.0f;
    s.field.cumulus.towerRadiusMax = 1.5f;
    s.field.cumulus.eval = NoiseEval::Direct;
    s.render.step = 0.05f;
    s.render.shadowStep = 0.05f;
    s.camera.position = vec3(0.0f, 3.0f, -25.0f);
    for (int i = 0; i < 6; ++i)
        s.instances.push_back(InstanceDesc{0,
                                           vec3(float(i) * 7.0f - 17.0f, 0.0f, float(i % 2) * 4.0f),
                                           vec3(0.0f, float(i) * 40.0f, 0.0f), vec3(1.0f), 1.0f});
    FrameBindings b;
    b.geometry = embree(s);
    const Framebuffer h = renderScene(s, b);
    s.render.hierarchicalSkip = false;
    const Framebuffer c = renderScene(s, b);
    ASSERT_GT(maxValue(h), 0.01);
    EXPECT_LT(maxDiff(h, c), 1e-4);
}

namespace {

/// Two overlapping, rotated, scaled cumulus instances (path traced).
SceneDesc overlappingCumulus() {
    SceneDesc s = boxes();
    s.render.integrator = Integrator::PathTrace;
    s.field.kind = FieldKind::Cumulus;
    s.field.cumulus.bounds = Box{vec3(-3.0f, -1.0f, -3.0f), vec3(3.0f, 1.0f, 3.0f)};
    s.field.cumulus.towerSpacing = 3.0f;
    s.field.cumulus.towerRadiusMin = 1.0f;
    s.field.cumulus.towerRadiusMax = 1.5f;
    s.field.cumulus.eval = NoiseEval::Direct;
    s.instances = {InstanceDesc{0, vec3(0.0f), vec3(0.0f, 30.0f, 0.0f), vec3(1.0f), 1.0f},
                   InstanceDesc{0, vec3(1.5f, 0.3f, 0.0f), vec3(10.0f, -20.0f, 5.0f),
                                vec3(1.2f, 0.8f, 1.0f), 0.7f}};
    return s;
}

} // namespace

TEST(Instances, DensityAheadLeavesTheQueriesAsTheyWere) {
    // march looks at a step's sample (densityAhead) before it asks the densities of its
    // sub-steps, some of them before that sample (render.step_tau): the look must leave every
    // span a later query from `from` on needs, and read what density() reads there. Two overlapping
    // boxes of density 1 and 0.5, a ray through both: their spans begin and end inside the look.
    SceneDesc s = boxes();
    s.instances = {InstanceDesc{0, vec3(0.0f), vec3(0.0f), vec3(1.0f), 1.0f},
                   InstanceDesc{0, vec3(1.5f, 0.0f, 0.0f), vec3(0.0f), vec3(1.0f), 0.5f}};
    FrameBindings b;
    b.geometry = embree(s);
    Renderer r(s);
    const FramePlan plan = r.plan(1, b);
    RenderStats st;
    const VolumeSet vs = r.volumesFor(plan, b, st);
    ASSERT_EQ(vs.instances.size(), 2u);
    const Ray ray{vec3(-3.0f, 0.01f, 0.02f), vec3(1.0f, 0.0f, 0.0f)};
    RayVolumes looked, plain;
    ASSERT_TRUE(looked.begin(vs, ray, 0.0f, 1e30f));
    ASSERT_TRUE(plain.begin(vs, ray, 0.0f, 1e30f));
    const float t0 = looked.tIn(), len = looked.tOut() - looked.tIn();
    const int N = 400, ahead = 40; // the look reaches a tenth of the ray on
    double sum = 0.0;
    for (int k = 0; k < N; ++k) {
        const float t = t0 + len * (float(k) + 0.5f) / float(N);
        const float tAhead = t0 + len * (float(k + ahead) + 0.5f) / float(N);
        const float look = looked.densityAhead(tAhead, t);
        const float here = looked.density(t);
        EXPECT_EQ(here, plain.density(t)) << "t " << t;
        if (k + ahead < N) {
            RayVolumes fresh;
            ASSERT_TRUE(fresh.begin(vs, ray, 0.0f, 1e30f));
            EXPECT_EQ(look, fresh.density(tAhead)) << "t " << tAhead;
        }
        sum += here;
    }
    EXPECT_NEAR(sum * len / N, 2.0 + 0.5 * 2.0, 0.05); // both boxes, 2 long each
}

TEST(Instances, MergedMajorantsBoundTheSummedDensity) {
    // Ratio tracking is unbiased only if every merged segment's majorant bounds the density
    // summed over the instances it covers: overlapping, rotated, scaled cumulus instances.
    const SceneDesc s = overlappingCumulus();
    FrameBindings b;
    b.geometry = embree(s);
    Renderer r(s);
    const FramePlan plan = r.plan(1, b);
    RenderStats st;
    const VolumeSet vs = r.volumesFor(plan, b, st);
    ASSERT_EQ(vs.instances.size(), 2u);
    // a ray through cloud where the two instances overlap (searched, deterministic)
    auto opticalDepth = [&](const Ray& ray) {
        RayVolumes rf;
        if (!rf.begin(vs, ray, 0.0f, 1e30f)) return 0.0;
        double sum = 0.0;
        const int N = 100000;
        const float len = rf.tOut() - rf.tIn();
        for (int k = 0; k < N; ++k)
            sum += double(rf.density(rf.tIn() + len * (float(k) + 0.5f) / float(N))) * len / N;
        return sum;
    };
    Ray ray{};
    double fine = 0.0;
    for (int k = 0; k < 64 && fine < 0.5; ++k) {
        ray = Ray{vec3(-8.0f, -0.8f + 0.025f * float(k), 0.7f * std::sin(float(k))),
                  glm::normalize(vec3(1.0f, 0.02f, 0.05f))};
        fine = opticalDepth(ray);
    }
    ASSERT_GT(fine, 0.5) << "no test ray crosses cloud";
    // every density along the ray is at most its segment's majorant
    RayVolumes rv, rd;
    ASSERT_TRUE(rv.begin(vs, ray, 0.0f, 1e30f));
    ASSERT_TRUE(rd.begin(vs, ray, 0.0f, 1e30f));
    MajorantSegment seg;
    double tau = 0.0;
    int samples = 0;
    while (rv.nextSegment(seg)) {
        for (int k = 0; k < 200; ++k) {
            const float t = seg.t0 + (seg.t1 - seg.t0) * (float(k) + 0.5f) / 200.0f;
            const float rho = rd.density(t);
            EXPECT_LE(rho, seg.sigma_maj * 1.0001f) << "t " << t;
            tau += double(rho) * (seg.t1 - seg.t0) / 200.0;
            ++samples;
        }
    }
    ASSERT_GT(samples, 0);
    EXPECT_NEAR(tau, fine, 0.02 * fine); // the segments cover all of the density
    // and ratio tracking through them is unbiased: exact exp(-sigma_t tau) vs the mean estimate
    const double exact = std::exp(-0.9 * fine);
    PathContext ctx(s, plan, vs);
    RayCounters cnt;
    PathContext::Scratch scratch;
    double sum = 0.0, sum2 = 0.0;
    const int M = 20000;
    for (int k = 0; k < M; ++k) {
        Sampler rng{kern::pcg(std::uint32_t(k) + 77u), 0};
        const double T = ctx.transmittance(ray.o, ray.d, rng, cnt, scratch).x;
        sum += T;
        sum2 += T * T;
    }
    const double mean = sum / M, se = std::sqrt((sum2 / M - mean * mean) / M);
    EXPECT_NEAR(mean, exact, 4.0 * se + 1e-4) << "tau " << fine;
}

TEST(Instances, PlacementsOfEmptyVolumesAreLeftOut) {
    FieldDesc unit{FieldKind::Homogeneous};
    unit.homogeneous = HomogeneousDesc{Box{vec3(-1.0f), vec3(1.0f)}, 1.0f};
    // an empty box: an empty VDB grid
    const std::vector<Field> fields = {makeField(unit, 0.0f), emptyField()};
    std::vector<InstanceDesc> d = {InstanceDesc{0}, InstanceDesc{1}, InstanceDesc{0, vec3(5.0f)}};
    const auto in = makeInstances(fields, d);
    ASSERT_EQ(in.size(), 2u);
    EXPECT_TRUE(in[0].identity);
    EXPECT_FALSE(in[1].identity);
    EXPECT_NEAR(in[1].worldBounds.lo.x, 4.0f, 1e-5f);
    EXPECT_THROW(makeInstances(fields, {InstanceDesc{2}}), std::invalid_argument);
}
