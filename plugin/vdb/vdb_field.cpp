#include "plugin/vdb/vdb_field.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "plugin/vdb/vdb_error.h"
#include "plugin/vdb/vdb_reader.h"

namespace nimbus::vdb {

void applyVdbEnvironment(VdbLoadOptions& o) {
    auto bad = [](const char* name, const char* value, const char* allowed) {
        throw VdbError(std::string(name) + "=\"" + value + "\": " + allowed);
    };
    if (const char* v = std::getenv("NIMBUS_VDB_ISOLATE"); v && *v) {
        const std::string s = v;
        if (s == "0")
            o.isolate = false;
        else if (s == "1")
            o.isolate = true;
        else
            bad("NIMBUS_VDB_ISOLATE", v,
                "expected 1 (read VDB grids in a child process, the default) or 0 (in "
                "process: trusted files only)");
    }
    if (const char* v = std::getenv("NIMBUS_VDB_TIMEOUT"); v && *v) {
        char* end = nullptr;
        errno = 0;
        const double s = std::strtod(v, &end);
        if (errno || *end || !std::isfinite(s) || !(s > 0.0))
            bad("NIMBUS_VDB_TIMEOUT", v, "expected a positive number of seconds, e.g. 600");
        o.timeoutSeconds = s;
    }
    if (const char* v = std::getenv("NIMBUS_VDB_MEMORY_LIMIT"); v && *v) {
        char* end = nullptr;
        errno = 0;
        const double n = std::strtod(v, &end);
        const std::string unit = end ? end : "";
        const double scale = unit == "M" || unit == "MiB"   ? double(1ull << 20)
                             : unit == "G" || unit == "GiB" ? double(1ull << 30)
                                                            : 0.0;
        if (errno || !(scale > 0.0) || !std::isfinite(n) || !(n * scale >= double(1ull << 20)) ||
            n * scale > 1e18)
            bad("NIMBUS_VDB_MEMORY_LIMIT", v,
                "expected an amount of memory with a unit, at least 1M, e.g. 512M or 16G");
        o.memoryLimitBytes = std::uint64_t(n * scale);
    }
}

GridBinding bindVdbField(const FieldDesc& field, const std::string& sceneDir, int frame,
                         std::vector<std::string>& warnings) {
    GridBinding b;
    if (field.kind != FieldKind::Vdb) return b;
    const VdbFieldDesc& v = field.vdb;
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
    applyVdbEnvironment(opt);
    auto loaded = std::make_shared<LoadedVdbGrid>(loadVdbGrid(opt));
    for (const auto& w : loaded->warnings) warnings.push_back(w);
    if (loaded->empty()) {
        b.grid = nullptr;
        b.bounds = Box{vec3(0.0f), vec3(0.0f)}; // renders as empty space
    } else {
        b.grid = loaded->grid();
        // trilinear lookups reach half a voxel beyond the voxel cells: pad by one voxel
        const float pad = glm::length(loaded->voxelSize);
        b.bounds = Box{loaded->worldBounds.lo - vec3(pad), loaded->worldBounds.hi + vec3(pad)};
    }
    b.owner = loaded;
    return b;
}

} // namespace nimbus::vdb
