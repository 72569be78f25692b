#include "plugin/vdb/vdb_field.h"

#include <filesystem>
#include <memory>

#include "plugin/vdb/vdb_error.h"
#include "plugin/vdb/vdb_reader.h"

namespace nimbus::vdb {

void attachVdbField(FieldDesc& field, const std::string& sceneDir, int frame,
                    std::vector<std::string>& warnings) {
    if (field.kind != FieldKind::Vdb) return;
    VdbFieldDesc& v = field.vdb;
    if (v.path.empty())
        throw VdbError("field.path: a VDB file is required for field.kind = \"vdb\"");
    std::filesystem::path pattern(v.path);
    if (pattern.is_relative() && !sceneDir.empty())
        pattern = std::filesystem::path(sceneDir) / pattern;
    const VdbFrameFile file = resolveVdbFrame(pattern.string(), frame, v.hold);
    if (!file.warning.empty()) warnings.push_back(file.warning);

    VdbLoadOptions opt;
    opt.path = file.path;
    opt.gridName = v.grid;
    opt.levelsetToFog = v.levelsetToFog;
    auto loaded = std::make_shared<LoadedVdbGrid>(loadVdbGrid(opt));
    for (const auto& w : loaded->warnings) warnings.push_back(w);
    if (loaded->empty()) {
        v.nanoGrid = nullptr;
        v.bounds = Box{vec3(0.0f), vec3(0.0f)}; // renders as empty space
    } else {
        v.nanoGrid = loaded->grid();
        // trilinear lookups reach half a voxel beyond the voxel cells: pad by one voxel
        const float pad = glm::length(loaded->voxelSize);
        v.bounds = Box{loaded->worldBounds.lo - vec3(pad), loaded->worldBounds.hi + vec3(pad)};
    }
    v.owner = loaded;
}

} // namespace nimbus::vdb
