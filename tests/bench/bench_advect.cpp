// Benchmarks of wind advection (core/sim/advect.h) at 256 x 32 x 256 (x, y up, z), the issue's
// size: the automaton's smoothed density 200 steps into its stable defaults (clouds present),
// advected one step per iteration (the result fed back, so the clouds keep moving):
//   BM_AdvectLayered/<scheme>/<threads>/<row kernel>    a two-row layered wind (shear), max CFL
//                                          ~1.3; row kernel 0 = the per-cell path (same bits)
//   BM_AdvectGrid/<scheme>/<threads>       a cell-centred velocity grid (a swirl + drift) of
//                                          the same size, max CFL ~1.9, 2 trace substeps
//                                          where the CFL exceeds 1
//   BM_AdvectCube/<n>/<scheme>/<wind>/<kernel>  an n^3 grid of smooth lobes (the 256^3
//                                          and its scaling), wind 0 = layered, 1 = a centred
//                                          velocity grid of the same size, 2 = a staggered one
//                                          (n + 1 faces); kernel 1 = the row / grid kernel,
//                                          0 = the per-cell path (the reference); all threads
//   BM_StaggeredGridField/<n>             staggeredGrid() of (n + 1)^3 faces: the one-time copy
//                                          of the components into planes
// scheme: 0 = semi-Lagrangian, 1 = MacCormack; threads: the TBB thread count. items_per_second
// is steps per second. Run from the build dir:
//   ./tests/nimbus_bench --benchmark_filter=Advect
#include <cmath>

#include <benchmark/benchmark.h>

#include <tbb/global_control.h>

#include "core/sim/advect.h"

using namespace nimbus::sim;

namespace {

const DensityGrid& cloudDensity() {
    static const DensityGrid d = [] {
        DensityGrid g;
        std::vector<std::uint8_t> scratch;
        smoothDensity(stateAtStep(AutomatonParams{}, 200).bits, g, scratch);
        return g;
    }();
    return d;
}

const GridFrame kFrame{vec3(0.0f, 1000.0f, 0.0f), 25.0f}; // 6.4 km x 800 m x 6.4 km

const VelocityGrid& swirl() {
    static const VelocityGrid g = [] {
        VelocityGrid v;
        v.res = cloudDensity().res;
        v.frame = kFrame;
        v.v.resize(size_t(v.res.x) * v.res.y * v.res.z);
        const vec3 c = kFrame.origin + vec3(v.res) * (0.5f * kFrame.voxelSize);
        for (int z = 0; z < v.res.z; ++z)
            for (int y = 0; y < v.res.y; ++y)
                for (int x = 0; x < v.res.x; ++x) {
                    const vec3 p = kFrame.origin + (vec3(x, y, z) + 0.5f) * kFrame.voxelSize - c;
                    v.v[v.index(x, y, z)] =
                        vec3(0.004f * p.z, 0.5f, -0.004f * p.x) + vec3(6.0f, 0.0f, 2.0f);
                }
        return v;
    }();
    return g;
}

void run(benchmark::State& state, const VelocityField& v, const char* label) {
    const tbb::global_control t(tbb::global_control::max_allowed_parallelism,
                                size_t(state.range(1)));
    AdvectParams p;
    p.scheme = state.range(0) ? AdvectScheme::MacCormack : AdvectScheme::SemiLagrangian;
    p.rowKernel = state.range(2) != 0;
    DensityGrid d = cloudDensity();
    AdvectWorkspace ws;
    AdvectStats st;
    for (auto _ : state) {
        st = advect(d, kFrame, v, 2.0f, p, d, ws);
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["maxCfl"] = st.maxCfl;
    state.counters["clamped"] = double(st.clampedCells);
    state.SetLabel(std::string(p.scheme == AdvectScheme::MacCormack ? "MacCormack, " : "SL, ") +
                   label);
}

void BM_AdvectLayered(benchmark::State& state) {
    static const VelocityField v =
        layeredWind({{1200.0f, vec3(8.0f, 0.0f, 2.0f)}, {1700.0f, vec3(16.0f, 0.0f, -4.0f)}});
    run(state, v, state.range(2) ? "layered wind, row kernel" : "layered wind, per cell");
}
BENCHMARK(BM_AdvectLayered)
    ->ArgsProduct({{0, 1}, {1, 2}, {1, 0}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_AdvectGrid(benchmark::State& state) {
    run(state, centredGrid(swirl()), "centred velocity grid");
}
BENCHMARK(BM_AdvectGrid)
    ->ArgsProduct({{0, 1}, {1, 2}, {1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_AdvectCube(benchmark::State& state) {
    const int n = int(state.range(0));
    DensityGrid d;
    d.res = ivec3(n);
    d.v.resize(size_t(n) * n * n);
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                const float s = std::sin(0.11f * x) * std::sin(0.13f * y) * std::sin(0.07f * z);
                d.v[(size_t(z) * n + y) * n + x] = s > 0.2f ? s - 0.2f : 0.0f;
            }
    const GridFrame frame{vec3(0.0f), 6400.0f / float(n)}; // 6.4 km across at any n
    const VelocityField layered =
        layeredWind({{800.0f, vec3(8.0f, 0.0f, 2.0f)}, {5600.0f, vec3(16.0f, 0.0f, -4.0f)}});
    const int wind = int(state.range(2));
    const bool staggered = wind == 2;
    VelocityGrid g;
    if (wind) {
        g.res = d.res + (staggered ? 1 : 0); // staggered: n + 1 faces per axis
        g.frame = frame;
        g.v.resize(size_t(g.res.x) * g.res.y * g.res.z);
        const vec3 c(3200.0f);
        auto swirlAt = [&](vec3 cell) {
            const vec3 p = cell * frame.voxelSize - c;
            return vec3(0.004f * p.z, 0.5f, -0.004f * p.x) + vec3(6.0f, 0.0f, 2.0f);
        };
        for (int z = 0; z < g.res.z; ++z)
            for (int y = 0; y < g.res.y; ++y)
                for (int x = 0; x < g.res.x; ++x) {
                    const vec3 i(x, y, z);
                    vec3& w = g.v[g.index(x, y, z)];
                    if (!staggered) {
                        w = swirlAt(i + 0.5f);
                    } else { // each component on its own lower face
                        w.x = swirlAt(i + vec3(0.0f, 0.5f, 0.5f)).x;
                        w.y = swirlAt(i + vec3(0.5f, 0.0f, 0.5f)).y;
                        w.z = swirlAt(i + vec3(0.5f, 0.5f, 0.0f)).z;
                    }
                }
    }
    const VelocityField v = wind == 0 ? layered : staggered ? staggeredGrid(g) : centredGrid(g);
    AdvectParams p;
    p.scheme = state.range(1) ? AdvectScheme::MacCormack : AdvectScheme::SemiLagrangian;
    p.rowKernel = state.range(3) != 0;
    AdvectWorkspace ws;
    AdvectStats st;
    const float dt = 0.5f * frame.voxelSize / 16.0f; // max CFL ~0.5 at any n
    for (auto _ : state) {
        st = advect(d, frame, v, dt, p, d, ws);
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["cells"] = double(d.v.size());
    state.counters["ns/cell"] =
        benchmark::Counter(double(d.v.size()) * state.iterations() * 1e-9,
                           benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
    static const char* const winds[] = {"layered wind", "centred velocity grid",
                                        "staggered velocity grid"};
    state.SetLabel(std::string(p.scheme == AdvectScheme::MacCormack ? "MacCormack, " : "SL, ") +
                   winds[wind] + (p.rowKernel ? "" : ", per cell"));
}
BENCHMARK(BM_AdvectCube)
    ->ArgsProduct({{64, 128, 256}, {0, 1}, {0, 1, 2}, {1, 0}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// staggeredGrid() of an (n + 1)^3 grid: the one-time copy of its components into the planes the
// 8-cell blocks read (once per grid, not per step)
void BM_StaggeredGridField(benchmark::State& state) {
    const int n = int(state.range(0)) + 1;
    VelocityGrid g;
    g.res = ivec3(n);
    g.frame = GridFrame{vec3(0.0f), 25.0f};
    g.v.resize(size_t(n) * n * n);
    for (size_t i = 0; i < g.v.size(); ++i) g.v[i] = vec3(float(i % 7), float(i % 5), float(i % 3));
    for (auto _ : state) {
        VelocityField f = staggeredGrid(g);
        benchmark::DoNotOptimize(f.planes->data());
    }
    state.counters["faces"] = double(g.v.size());
}
BENCHMARK(BM_StaggeredGridField)->Arg(128)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace
