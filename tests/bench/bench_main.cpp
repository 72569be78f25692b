// Benchmarks (Google Benchmark): density lookups per second, the default frame with empty-space
// skipping on and off, the share of time spent in shadow marches, the cost of the
// multiple-scattering grid (light volumes and diffusion solve), the majorant walk with and
// without leaping over empty blocks, and the photon pass. Run from the build dir:
//   ./tests/nimbus_bench                       (all; the frame benchmarks take ~1 min on 2 cores)
//   ./tests/nimbus_bench --benchmark_filter=Density
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "core/tracking/majorant.h"
#include "core/render.h"
#include "plugin/io/color.h"
#include "plugin/io/scene_file.h"
#include "plugin/io/scene_setup.h"

using namespace nimbus;

namespace {

const SceneDesc& defaultScene() {
    static SceneDesc scene = [] {
        io::SceneFile f = io::loadSceneFile(NIMBUS_SOURCE_DIR "/examples/scenes/cumulus.toml");
        io::resolveColours(f, io::ColorSystem::load());
        return f.scene;
    }();
    return scene;
}

/// Points where a march with skipping evaluates density: inside non-empty majorant cells.
std::vector<vec3> pointsInCloudCells(const Field& f, const MajorantGrid& g, int n) {
    std::vector<vec3> cells;
    for (int z = 0; z < g.res.z; ++z)
        for (int y = 0; y < g.res.y; ++y)
            for (int x = 0; x < g.res.x; ++x)
                if (g.at(ivec3(x, y, z)) > 0.0f) cells.push_back(vec3(x, y, z));
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<vec3> pts(n);
    for (vec3& p : pts) {
        vec3 c = cells[rng() % cells.size()];
        p = f.bounds().lo + (c + vec3(u(rng), u(rng), u(rng))) * g.cellSize;
    }
    return pts;
}

void BM_Density(benchmark::State& state) {
    SceneDesc s = defaultScene();
    const bool baked = state.range(0) != 0;
    auto base = baked ? bakeCumulusBase(s.field.cumulus) : nullptr;
    auto detail = baked ? bakeCumulusDetail(s.field.cumulus) : nullptr;
    Field f = makeField(s.field, 0.5f, base, detail);
    MajorantGrid g = buildMajorantGrid(f, 0.16f);
    std::vector<vec3> pts = pointsInCloudCells(f, g, 1 << 16);
    size_t i = 0;
    float sum = 0.0f;
    for (auto _ : state) {
        sum += f.density(pts[i++ & (pts.size() - 1)]);
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
    state.SetLabel(baked ? "baked noise, points in non-empty cells"
                         : "direct noise, points in non-empty cells");
}
BENCHMARK(BM_Density)->Arg(0)->Arg(1);

/// One frame of the default scene. Args: skip empty space (0/1), sun (0/1), the
/// multiple-scattering grid (0 = off, the v1 sky ambient instead; 1 = the scene's).
void BM_Frame(benchmark::State& state) {
    SceneDesc s = defaultScene();
    s.render.skipEmpty = state.range(0) != 0;
    s.sun.enabled = state.range(1) != 0;
    if (state.range(2) == 0) s.render.multipleScattering = MultipleScattering::None;
    Renderer r(s);
    FramePlan plan = r.plan(1);
    Framebuffer fb;
    RenderStats st;
    r.render(plan, fb, st); // bakes the noise once, outside the timing
    for (auto _ : state) r.render(plan, fb, st);
    state.counters["lookups"] = double(st.lookups());
    state.counters["shadow_lookups"] = double(st.shadowSamples);
    state.counters["lookups_per_s"] =
        benchmark::Counter(double(st.lookups()), benchmark::Counter::kIsIterationInvariantRate);
    state.counters["volumes_s"] = st.lightVolumeSeconds;
    state.counters["diffusion_s"] = st.diffusionSeconds;
    state.counters["diffusion_iterations"] = st.diffusionIterations;
    state.SetLabel(std::string(s.render.skipEmpty ? "skip on" : "skip off") +
                   (s.sun.enabled ? ", sun" : ", no sun (no shadow marches)") +
                   (plan.diffusion ? ", diffusion grid" : ", no grid"));
}
BENCHMARK(BM_Frame)
    ->Args({1, 1, 1})
    ->Args({1, 1, 0})
    ->Args({0, 1, 1})
    ->Args({1, 0, 1})
    ->Iterations(2)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

/// The majorant walk of random rays across the default scene's grid (cell 0.23 km, the plan's),
/// cell by cell (arg 0) or leaping over empty blocks (arg 1).
void BM_MajorantWalk(benchmark::State& state) {
    SceneDesc s = defaultScene();
    auto base = bakeCumulusBase(s.field.cumulus);
    auto detail = bakeCumulusDetail(s.field.cumulus);
    Field f = makeField(s.field, 0.5f, base, detail);
    MajorantGrid g = buildMajorantGrid(f, Renderer(s).plan(1).majorantCell);
    if (state.range(0) == 0) g.blockDistance.clear();
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Ray> rays(4096);
    for (Ray& r : rays) {
        const vec3 o = g.bounds.lo + vec3(u(rng), u(rng), u(rng)) * g.bounds.extent();
        const float z = 2.0f * u(rng) - 1.0f, phi = 6.2831853f * u(rng);
        const float rxy = std::sqrt(std::max(0.0f, 1.0f - z * z));
        r = Ray{o, vec3(rxy * std::cos(phi), z, rxy * std::sin(phi))};
    }
    size_t i = 0, segments = 0;
    for (auto _ : state) {
        const Ray& r = rays[i++ & (rays.size() - 1)];
        MajorantIterator it(&g, g.bounds, r, 0.0f, 1e30f, 0.0f);
        MajorantSegment seg;
        while (it.next(seg)) ++segments;
    }
    benchmark::DoNotOptimize(segments);
    state.SetItemsProcessed(state.iterations());
    state.counters["segments_per_ray"] =
        benchmark::Counter(double(segments), benchmark::Counter::kAvgIterations);
    state.SetLabel(state.range(0) ? "leaping over empty blocks" : "cell by cell");
}
BENCHMARK(BM_MajorantWalk)->Arg(0)->Arg(1);

/// The photon pass of the default scene (render.multiple_scattering = "photons") at
/// `arg` photons; a 160x90 image so that the frame is mostly the photons.
void BM_Photons(benchmark::State& state) {
    SceneDesc s = defaultScene();
    s.render.multipleScattering = MultipleScattering::Photons;
    s.render.photons = int(state.range(0));
    s.render.octaves = 1;
    s.render.msStrength = 1.0f;
    s.camera.width = 160;
    s.camera.height = 90;
    Renderer r(s);
    FramePlan plan = r.plan(1);
    Framebuffer fb;
    RenderStats st;
    r.render(plan, fb, st); // bakes the noise once, outside the timing
    double photonSeconds = 0.0;
    for (auto _ : state) {
        r.render(plan, fb, st);
        photonSeconds += st.photonSeconds;
    }
    state.counters["photon_s"] =
        benchmark::Counter(photonSeconds, benchmark::Counter::kAvgIterations);
    state.counters["photons_per_s"] =
        double(state.range(0)) * double(state.iterations()) / std::max(photonSeconds, 1e-9);
}
BENCHMARK(BM_Photons)->Arg(1000000)->Iterations(2)->Unit(benchmark::kSecond)->UseRealTime();

void BM_NoiseBake(benchmark::State& state) {
    SceneDesc s = defaultScene();
    for (auto _ : state) {
        auto b = bakeCumulusBase(s.field.cumulus);
        auto d = bakeCumulusDetail(s.field.cumulus);
        benchmark::DoNotOptimize(b);
        benchmark::DoNotOptimize(d);
    }
}
BENCHMARK(BM_NoiseBake)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

} // namespace

BENCHMARK_MAIN();
