// Benchmarks of Dobashi's cellular automaton (core/sim/automaton.h) at 256 x 32 x 256 (x, y up,
// z), the size, from a state 200 steps into the stable defaults (clouds present):
//   (a) BM_AutomatonGrowth    the growth rule alone (word-wide bit operations)
//   (b) BM_AutomatonRegions   + region-ellipsoid weights, stochastic rules and ellipsoid
//                              controls: one full simulation step (sim::step)
//   (c) BM_AutomatonSmoothed  + smoothing of cld into the float density
//   (d) BM_AutomatonComplete  + the 8^3 block maxima (apron 1): a complete update
//   BM_AutomatonStateAtStep/2/n  stateAtStep(n) from the seed (the cost of determinism)
// The first argument is the TBB thread count (1 or 2); items_per_second is steps (updates) per
// second. Run from the build dir:
//   ./tests/nimbus_bench --benchmark_filter=Automaton
#include <benchmark/benchmark.h>

#include <tbb/global_control.h>

#include "core/sim/automaton.h"

using namespace nimbus::sim;

namespace {

const AutomatonState& warmState() {
    static const AutomatonState s = stateAtStep(AutomatonParams{}, 200);
    return s;
}

tbb::global_control threads(const benchmark::State& state) {
    return tbb::global_control(tbb::global_control::max_allowed_parallelism,
                               size_t(state.range(0)));
}

void BM_AutomatonGrowth(benchmark::State& state) {
    AutomatonState s = warmState();
    const auto t = threads(state);
    std::vector<std::uint64_t> scratch;
    for (auto _ : state) {
        growthStep(s.bits, scratch);
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
    state.SetLabel("(a) growth only");
}
BENCHMARK(BM_AutomatonGrowth)->Arg(1)->Arg(2)->UseRealTime();

/// Stages: 1 = full step, 2 = + smoothing, 3 = + block maxima.
void runStages(benchmark::State& state, int stages, const char* label) {
    const AutomatonParams p;
    AutomatonState s = warmState();
    const auto t = threads(state);
    Workspace ws;
    DensityGrid d;
    std::vector<std::uint8_t> scratch;
    BlockMaxima m;
    for (auto _ : state) {
        step(s, p, ws);
        if (stages >= 2) smoothDensity(s.bits, d, scratch);
        if (stages >= 3) blockMaxima(d, 8, 1, m);
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
    state.counters["cover"] = s.cover;
    state.counters["ellipsoids"] = double(s.ellipsoids.size());
    state.SetLabel(label);
}

void BM_AutomatonRegions(benchmark::State& state) {
    runStages(state, 1, "(b) step with region weights + stochastic rules");
}
BENCHMARK(BM_AutomatonRegions)->Arg(1)->Arg(2)->UseRealTime();

void BM_AutomatonSmoothed(benchmark::State& state) {
    runStages(state, 2, "(c) (b) + smoothing");
}
BENCHMARK(BM_AutomatonSmoothed)->Arg(1)->Arg(2)->UseRealTime();

void BM_AutomatonComplete(benchmark::State& state) {
    runStages(state, 3, "(d) (c) + 8^3 block maxima: complete update");
}
BENCHMARK(BM_AutomatonComplete)->Arg(1)->Arg(2)->UseRealTime();

/// Determinism's price: the state at step n re-simulated from the seed (n full steps).
void BM_AutomatonStateAtStep(benchmark::State& state) {
    const AutomatonParams p;
    const auto t = threads(state);
    const auto n = std::uint64_t(state.range(1));
    for (auto _ : state) {
        AutomatonState s = stateAtStep(p, n);
        benchmark::DoNotOptimize(s.cover);
    }
    state.SetLabel("stateAtStep(n = second arg) from the seed");
}
BENCHMARK(BM_AutomatonStateAtStep)
    ->Args({2, 100})
    ->Args({2, 1000})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

} // namespace
