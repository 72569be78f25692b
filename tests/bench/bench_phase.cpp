// Benchmarks of the phase functions: ns per eval and per sample of each kind, the Lorenz-Mie
// table included ("Mie lookup cost vs HG"), and the time to compute the table. Run:
//   ./tests/nimbus_bench --benchmark_filter=Phase
// The argument selects the kind (see kKinds); items/s is calls per second.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "core/media/mie.h"
#include "core/media/phase.h"

using namespace nimbus;

namespace {

struct Kind {
    const char* name;
    kern::PhaseParams params; ///< kernel kinds
    int table;                ///< 0: kernel; 1: MieTable (one channel); 2: PhaseFunction (RGB)
};

const std::vector<Kind>& kinds() {
    static const std::vector<Kind> k = {
        {"isotropic", kern::phaseParamsIsotropic(), 0},
        {"hg g=0.8", kern::phaseParamsHG(0.8f), 0},
        {"dual_hg 0.8/-0.3/0.2", kern::phaseParamsDualHG(0.8f, -0.3f, 0.2f), 0},
        {"draine g=0.6 a=1", kern::phaseParamsDraine(0.6f, 1.0f), 0},
        {"mie_approx d=20", kern::phaseParamsMieApprox(20.0f), 0},
        {"mie_table: MieTable pdf / sample (one channel)", {}, 1},
        {"mie_table: PhaseFunction eval (RGB) / sample (+weight)", {}, 2},
    };
    return k;
}

const MieTable& table() {
    static std::shared_ptr<const MieTable> t = sharedMieTable(MieTableParams{});
    return *t;
}

constexpr size_t kInputs = 1 << 14;

const std::vector<float>& randomFloats(unsigned seed, float lo, float hi) {
    static std::vector<float> v[2];
    std::vector<float>& out = v[seed & 1];
    if (out.empty()) {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<float> u(lo, hi);
        out.resize(kInputs);
        for (float& x : out) x = u(rng);
    }
    return out;
}

void BM_PhaseEval(benchmark::State& state) {
    const Kind& k = kinds()[state.range(0)];
    const std::vector<float>& mu = randomFloats(1, -1.0f, 1.0f);
    const PhaseFunction f = k.table ? PhaseFunction(&table()) : PhaseFunction(k.params);
    size_t i = 0;
    float sum = 0.0f;
    for (auto _ : state) {
        const float c = mu[i++ & (kInputs - 1)];
        if (k.table == 1)
            sum += table().pdf(c);
        else if (k.table == 2)
            sum += f.eval(c).y;
        else
            sum += kern::phaseEval(k.params, c);
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
    state.SetLabel(k.name);
}
BENCHMARK(BM_PhaseEval)->DenseRange(0, 6);

void BM_PhaseSample(benchmark::State& state) {
    const Kind& k = kinds()[state.range(0)];
    const std::vector<float>& u = randomFloats(2, 0.0f, 1.0f);
    const PhaseFunction f = k.table ? PhaseFunction(&table()) : PhaseFunction(k.params);
    size_t i = 0;
    float sum = 0.0f;
    for (auto _ : state) {
        const vec2 uu(u[i & (kInputs - 1)], u[(i + 7) & (kInputs - 1)]);
        ++i;
        if (k.table == 1)
            sum += table().sample(uu.x);
        else if (k.table == 2)
            sum += f.sample(uu).weight.y;
        else
            sum += kern::phaseSample(k.params, uu);
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
    state.SetLabel(k.name);
}
BENCHMARK(BM_PhaseSample)->DenseRange(0, 6);

/// The default table (r_eff 10 um, v_eff 0.1, three wavelengths), uncached.
void BM_PhaseMieTableCompute(benchmark::State& state) {
    double cpu = 0.0;
    for (auto _ : state) {
        MieTable t = MieTable::compute(MieTableParams{});
        cpu = t.stats().cpuSeconds;
        benchmark::DoNotOptimize(t);
    }
    state.counters["cpu_s"] = cpu;
    state.SetLabel("r_eff 10 um, v_eff 0.1, 680/550/440 nm");
}
BENCHMARK(BM_PhaseMieTableCompute)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

} // namespace
