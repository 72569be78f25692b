// The overhead of the C ABI (libnimbus.so, plugin/capi/nimbus.h) against the C++ call it wraps
// (host::Session::render): the same frame of the same scene rendered both ways, noise baked
// beforehand, at two sizes: a 24x14 frame (a few ms: fixed per-call costs show) and the default
// scene at 160x90 (a real frame); the tiny frame also on one thread (CPU time = the work).
// Interleave the two in one run (docs/capi.md):
//   ./tests/nimbus_bench --benchmark_filter=CApi --benchmark_repetitions=10 \
//       --benchmark_enable_random_interleaving=true --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "plugin/capi/nimbus.h"
#include "plugin/host/session.h"
#include "tests/scenes.h"

using namespace nimbus;

namespace {

/// The scenes measured: a tiny cumulus (as tests/test_capi.cpp) and the default scene.
struct Case {
    const char* name;
    bool fromFile;
    std::string source;
    std::vector<std::string> overrides;
    int frame;
};

Case tiny() {
    return {"tiny", false, tinySceneText(), {}, 3};
}

/// The tiny scene on one thread: the render runs on the calling thread, so its CPU time is the
/// work itself, less disturbed by the other processes of a shared machine.
Case tinyOneThread() {
    Case c = tiny();
    c.name = "tiny1thread";
    c.overrides = {"render.threads=1"};
    return c;
}

Case defaultScene() {
    return {"cumulus160x90",
            true,
            NIMBUS_SOURCE_DIR "/examples/scenes/cumulus.toml",
            {"camera.width=160", "camera.height=90", "render.threads=2"},
            1};
}

void viaSession(benchmark::State& state, const Case& c) {
    host::Session s;
    host::Status st = c.fromFile ? s.load(c.source, c.overrides)
                                 : s.loadString(c.source, "scene.toml", c.overrides);
    if (!st.ok()) {
        state.SkipWithError(st.message.c_str());
        return;
    }
    Framebuffer warm;
    RenderStats stats;
    s.render(c.frame, warm, stats); // bakes the noise, binds the frame
    for (auto _ : state) {
        Framebuffer fb;
        st = s.render(c.frame, fb, stats);
        benchmark::DoNotOptimize(fb.rgba.data());
    }
    if (!st.ok()) state.SkipWithError(st.message.c_str());
}

void viaCApi(benchmark::State& state, const Case& c) {
    std::unique_ptr<nimbus_context, void (*)(nimbus_context*)> ctx(nimbus_create(), nimbus_destroy);
    nimbus_status st = c.fromFile ? nimbus_load_file(ctx.get(), c.source.c_str())
                                  : nimbus_load_string(ctx.get(), c.source.c_str(), "scene.toml");
    for (const std::string& o : c.overrides)
        if (st == NIMBUS_OK) st = nimbus_set(ctx.get(), o.c_str());
    if (st != NIMBUS_OK) {
        state.SkipWithError(nimbus_last_error(ctx.get()));
        return;
    }
    int w = 0, h = 0;
    nimbus_plan_int(ctx.get(), c.frame, NIMBUS_PLAN_WIDTH, &w);
    nimbus_plan_int(ctx.get(), c.frame, NIMBUS_PLAN_HEIGHT, &h);
    std::vector<float> rgba(size_t(w) * h * 4);
    nimbus_render(ctx.get(), c.frame, rgba.data(), rgba.size()); // bakes, binds
    for (auto _ : state) {
        st = nimbus_render(ctx.get(), c.frame, rgba.data(), rgba.size());
        benchmark::DoNotOptimize(rgba.data());
    }
    if (st != NIMBUS_OK) state.SkipWithError(nimbus_last_error(ctx.get()));
}

} // namespace

BENCHMARK_CAPTURE(viaSession, tiny, tiny())
    ->Name("CApi/session/tiny")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(viaCApi, tiny, tiny())->Name("CApi/c_abi/tiny")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(viaSession, tiny1, tinyOneThread())
    ->Name("CApi/session/tiny1thread")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(viaCApi, tiny1, tinyOneThread())
    ->Name("CApi/c_abi/tiny1thread")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(viaSession, cumulus, defaultScene())
    ->Name("CApi/session/cumulus160x90")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(viaCApi, cumulus, defaultScene())
    ->Name("CApi/c_abi/cumulus160x90")
    ->Unit(benchmark::kMillisecond);
