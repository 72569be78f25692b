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

/// The scene and its frame-1 bindings (grid, Embree geometry).
struct BoundScene {
    SceneDesc scene;
    FrameBindings bindings;
};

/// The scene with its grid and Embree geometry bound; null when the shared data is absent.
const BoundScene* cloudscape() {
    static std::unique_ptr<BoundScene> scene = []() -> std::unique_ptr<BoundScene> {
        const std::string path = NIMBUS_SOURCE_DIR "/examples/scenes/cloudscape.toml";
        io::SceneFile f = io::loadSceneFile(path);
        io::resolveColours(f, io::ColorSystem::load());
        auto s = std::make_unique<BoundScene>();
        s->scene = f.scene;
        s->scene.camera.width = 160;
        s->scene.camera.height = 90;
        std::vector<std::string> warnings;
        const std::string dir = std::filesystem::path(path).parent_path().string();
        try {
            s->bindings.grids = {vdb::bindVdbField(s->scene.field, dir, 1, warnings)};
        } catch (const std::exception&) {
            return nullptr;
        }
        s->bindings.geometry = geom::makeEmbreeGeometry(s->scene, dir, warnings);
        return s;
    }();
    return scene.get();
}

/// Arg: 1 = hierarchical (instance boxes, then the plume's own grid), 0 = coarse world grid.
void BM_Cloudscape(benchmark::State& state) {
    const BoundScene* base = cloudscape();
    if (!base) {
        state.SkipWithError("shared/data/vdb/openvdb_smoke1.vdb is absent");
        return;
    }
    SceneDesc s = base->scene;
    s.render.hierarchicalSkip = state.range(0) != 0;
    s.render.threads = 1; // CPU time of one thread: robust when other work shares the cores
    Renderer r(s);
    const FramePlan plan = r.plan(1, base->bindings);
    Framebuffer fb;
    RenderStats st;
    for (auto _ : state) r.render(plan, base->bindings, fb, st);
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
