// The sparse cloudscape (examples/scenes/cloudscape.toml: OpenVDB's smoke plume scattered 200
// times over a ground plane) at 160x90: hierarchical skipping (Embree finds the instance boxes
// a ray crosses) against one coarse world majorant grid over all instances, in one run, on one
// thread (the CPU column is the process's CPU time).
//   ./tests/nimbus_bench --benchmark_filter=Cloudscape
#include <benchmark/benchmark.h>

#include <filesystem>

#include "core/render.h"
#include "plugin/geom/embree_geometry.h"
#include "plugin/io/color.h"
#include "plugin/io/scene_file.h"
#include "plugin/io/scene_setup.h"
#include "plugin/vdb/vdb_field.h"

using namespace nimbus;

namespace {

/// The scene with its grid and Embree geometry attached; null when the shared data is absent.
const SceneDesc* cloudscape() {
    static std::unique_ptr<SceneDesc> scene = []() -> std::unique_ptr<SceneDesc> {
        const std::string path = NIMBUS_SOURCE_DIR "/examples/scenes/cloudscape.toml";
        io::SceneFile f = io::loadSceneFile(path);
        io::resolveColours(f, io::ColorSystem::load());
        auto s = std::make_unique<SceneDesc>(f.scene);
        s->camera.width = 160;
        s->camera.height = 90;
        std::vector<std::string> warnings;
        const std::string dir = std::filesystem::path(path).parent_path().string();
        try {
            vdb::attachVdbField(s->field, dir, 1, warnings);
        } catch (const std::exception&) {
            return nullptr;
        }
        s->geometry = geom::makeEmbreeGeometry(*s, dir, warnings);
        return s;
    }();
    return scene.get();
}

/// Arg: 1 = hierarchical (instance boxes, then the plume's own grid), 0 = coarse world grid.
void BM_Cloudscape(benchmark::State& state) {
    const SceneDesc* base = cloudscape();
    if (!base) {
        state.SkipWithError("shared/data/vdb/openvdb_smoke1.vdb is absent");
        return;
    }
    SceneDesc s = *base;
    s.render.hierarchicalSkip = state.range(0) != 0;
    s.render.threads = 1; // CPU time of one thread: robust when other work shares the cores
    Renderer r(s);
    const FramePlan plan = r.plan(1);
    Framebuffer fb;
    RenderStats st;
    for (auto _ : state) r.render(plan, fb, st);
    state.counters["lookups"] = double(st.lookups());
    state.counters["majorant_s"] = st.majorantSeconds;
    state.SetLabel(s.render.hierarchicalSkip ? "hierarchical: Embree instance boxes"
                                             : "coarse world majorant grid");
}
BENCHMARK(BM_Cloudscape)
    ->Arg(1)
    ->Arg(0)
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->MeasureProcessCPUTime();

} // namespace
