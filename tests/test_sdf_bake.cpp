// `nimbus bake` of an SDF cloud: the VDB it writes holds the field's density at the voxel
// centres (the example scene, coarse voxels).
#include <gtest/gtest.h>

#include <nanovdb/NanoVDB.h>

#include "core/fields/field.h"
#include "plugin/io/scene_file.h"
#include "plugin/vdb/vdb_reader.h"
#include "test_util.h"

TEST(SdfBakeCli, BakedSdfCloudReadsBackAsTheFieldItSampled) {
    TempDir dir;
    const std::string scene = NIMBUS_SOURCE_DIR "/examples/scenes/sdf_cloud.toml";
    const CliRun r =
        runNimbus("bake " + scene + " -o " + (dir / "s.####.vdb").string() + " --voxel 0.25");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    nimbus::vdb::VdbLoadOptions opt;
    opt.path = (dir / "s.0001.vdb").string();
    nimbus::vdb::LoadedVdbGrid g = nimbus::vdb::loadVdbGrid(opt);
    EXPECT_EQ(g.gridClass, "fog volume");
    EXPECT_GT(g.activeVoxelCount, 1000u);
    const nimbus::io::SceneFile f = nimbus::io::loadSceneFile(scene);
    const nimbus::Field field = nimbus::makeField(f.scene.field, 0.0f);
    auto acc = g.grid()->getAccessor();
    const nanovdb::CoordBBox bbox = g.grid()->indexBBox();
    int nonzero = 0, checked = 0;
    for (int k = bbox.min()[2]; k <= bbox.max()[2]; k += 3)
        for (int j = bbox.min()[1]; j <= bbox.max()[1]; j += 2)
            for (int i = bbox.min()[0]; i <= bbox.max()[0]; i += 2) {
                const nanovdb::Vec3f w = g.grid()->indexToWorldF(nanovdb::Vec3f(i, j, k));
                const float expect = field.density(nimbus::vec3(w[0], w[1], w[2]));
                ASSERT_NEAR(acc.getValue(nanovdb::Coord(i, j, k)), expect, 1e-5f)
                    << i << "," << j << "," << k;
                nonzero += expect > 0.0f;
                ++checked;
            }
    EXPECT_GT(nonzero, 100);
    RecordProperty("voxels_checked", std::to_string(checked));
}
