// Benchmarks of the automaton field kind (core/fields/automaton_field.h) on the example's
// simulation (examples/scenes/automaton_cumulus.toml: 160 x 20 x 160 cells, 0.1 s steps, 15 s
// warm-up, a two-row layered wind) and on the defaults (256 x 32 x 256):
//   BM_AutomatonFieldAlone/scene/frame  the field of frame `frame` (24 fps) rendered alone:
//                                       re-simulation from step 0 (warm-up included), the two
//                                       bracketing steps smoothed and advected, block maxima
//   BM_AutomatonFieldNext/scene         the next frame's field inside a sequence (the renderer
//                                       keeps the simulation): about 0.42 steps + the advection
// scene 0 = the example, 1 = the defaults (10 s warm-up). Run from the build dir:
//   ./tests/nimbus_bench --benchmark_filter=AutomatonField
#include <benchmark/benchmark.h>

#include "core/fields/automaton_field.h"
#include "plugin/io/scene_file.h"

using namespace nimbus;

namespace {

AutomatonDesc sceneAutomaton(int which) {
    if (which == 1) {
        AutomatonDesc d;
        d.wind = {AutomatonWindRow{1.5f, vec3(4.0f, 0.0f, 1.0f)},
                  AutomatonWindRow{4.5f, vec3(12.0f, 0.0f, 2.0f)}};
        return d;
    }
    return io::loadSceneFile(NIMBUS_SOURCE_DIR "/examples/scenes/automaton_cumulus.toml")
        .scene.field.automaton;
}

void BM_AutomatonFieldAlone(benchmark::State& state) {
    const AutomatonDesc d = sceneAutomaton(int(state.range(0)));
    const float time = float(state.range(1)) / 24.0f;
    for (auto _ : state) {
        AutomatonSequence seq(d);
        benchmark::DoNotOptimize(seq.frameAt(time));
        state.counters["steps"] = double(seq.stepsComputed());
    }
}
BENCHMARK(BM_AutomatonFieldAlone)
    ->Args({0, 1})
    ->Args({0, 96})
    ->Args({0, 2400})
    ->Args({1, 96})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_AutomatonFieldNext(benchmark::State& state) {
    const AutomatonDesc d = sceneAutomaton(int(state.range(0)));
    AutomatonSequence seq(d);
    int frame = 1;
    seq.frameAt(0.0f);
    for (auto _ : state) benchmark::DoNotOptimize(seq.frameAt(float(frame++) / 24.0f));
    state.counters["frames"] = double(frame - 1);
}
BENCHMARK(BM_AutomatonFieldNext)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace
