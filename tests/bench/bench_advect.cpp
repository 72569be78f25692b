// Benchmarks of wind advection (core/sim/advect.h) at 256 x 32 x 256 (x, y up, z), the issue's
// size: the automaton's smoothed density 200 steps into its stable defaults (clouds present),
// advected one step per iteration (the result fed back, so the clouds keep moving):
//   BM_AdvectLayered/<scheme>/<threads>    a two-row layered wind (shear), max CFL ~1.3
//   BM_AdvectGrid/<scheme>/<threads>       a cell-centred velocity grid (a swirl + drift) of
//                                          the same size, max CFL ~1.9, 2 trace substeps
//                                          where the CFL exceeds 1
// scheme: 0 = semi-Lagrangian, 1 = MacCormack; threads: the TBB thread count. items_per_second
// is steps per second. Run from the build dir:
//   ./tests/nimbus_bench --benchmark_filter=Advect
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
    run(state, v, "layered wind");
}
BENCHMARK(BM_AdvectLayered)
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_AdvectGrid(benchmark::State& state) {
    run(state, centredGrid(swirl()), "centred velocity grid");
}
BENCHMARK(BM_AdvectGrid)
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

} // namespace
