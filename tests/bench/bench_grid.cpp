// VDB density lookups (core/fields/grid.h): GridField::density through its dense copy of the
// voxels against NanoVDB's tree, and the cost of making the copy, on the real grids of
// ../shared/data/vdb (skipped with a message when that folder is absent).
//
//   BM_GridDensity/<file>/<dense>   trilinear lookups at points marching along random rays
//                                   through the grid's bounds (step half a voxel), 1 thread
//   BM_GridDenseCopy/<file>         makeField of the loaded grid (the dense copy, parallel)
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>
#include <vector>

#include "core/fields/field.h"
#include "core/fields/grid.h"
#include "core/sampler.h"
#include "plugin/vdb/vdb_field.h"

using namespace nimbus;

namespace {

const char* const kFiles[] = {"openvdb_smoke1.vdb", "vpt_dragon.vdb", "daichi_smoke.vdb"};

std::string dataPath(int i) {
    return std::string(NIMBUS_SOURCE_DIR) + "/../shared/data/vdb/" + kFiles[i];
}

/// The file's density grid bound as a scene binds it; when the file is absent, a null grid and
/// the benchmark skipped with a message.
GridBinding bind(benchmark::State& state, int i, FieldDesc& fd) {
    fd.kind = FieldKind::Vdb;
    fd.vdb.path = dataPath(i);
    fd.vdb.grid = "density";
    std::vector<std::string> warnings;
    if (!std::filesystem::exists(fd.vdb.path)) {
        state.SkipWithError(("no " + fd.vdb.path + " (../shared/data/vdb absent)").c_str());
        return GridBinding{};
    }
    return vdb::bindVdbField(fd, "", 1, warnings);
}

void BM_GridDensity(benchmark::State& state) {
    const int file = int(state.range(0));
    FieldDesc fd;
    const GridBinding b = bind(state, file, fd);
    if (!b.grid) return;
    Field f = makeField(fd, 0.0f, b);
    if (state.range(1) == 0) std::get<GridField>(f.data).dense.reset();
    if (state.range(1) == 1 && !f.as<GridField>().dense) {
        state.SkipWithError("the grid is too large for a dense copy");
        return;
    }
    const vec3 voxel = gridVoxelSize(b);
    const float step = 0.5f * std::min(voxel.x, std::min(voxel.y, voxel.z));
    Sampler rng{12345u, 0};
    auto u = [&] { return rng.next(); };
    const Box box = b.bounds;
    std::int64_t lookups = 0;
    float sum = 0.0f;
    for (auto _ : state) {
        // one ray: from a random point on the box's -z face toward a random point on its +z face
        const vec3 a(box.lo.x + u() * (box.hi.x - box.lo.x), box.lo.y + u() * (box.hi.y - box.lo.y),
                     box.lo.z);
        const vec3 e(box.lo.x + u() * (box.hi.x - box.lo.x), box.lo.y + u() * (box.hi.y - box.lo.y),
                     box.hi.z);
        const float len = glm::length(e - a);
        const vec3 d = (e - a) / len;
        for (float t = 0.0f; t < len; t += step, ++lookups) sum += f.density(a + t * d);
        benchmark::DoNotOptimize(sum);
    }
    state.SetItemsProcessed(lookups);
    state.SetLabel(std::string(kFiles[file]) + (state.range(1) ? " dense" : " tree"));
}
BENCHMARK(BM_GridDensity)->ArgsProduct({{0, 1, 2}, {0, 1}});

void BM_GridDenseCopy(benchmark::State& state) {
    const int file = int(state.range(0));
    FieldDesc fd;
    const GridBinding b = bind(state, file, fd);
    if (!b.grid) return;
    std::size_t bytes = 0;
    for (auto _ : state) {
        const Field f = makeField(fd, 0.0f, b);
        const auto& dense = f.as<GridField>().dense;
        bytes = dense ? dense->values.size() * sizeof(float) : 0;
        benchmark::DoNotOptimize(bytes);
    }
    state.SetLabel(std::string(kFiles[file]) + ", " + std::to_string(bytes >> 20) + " MiB");
}
BENCHMARK(BM_GridDenseCopy)->DenseRange(0, 2)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace
