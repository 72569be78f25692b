/// @file export_glsl.cpp
/// @brief `nimbus export-glsl`: writes one frame's march shader for engines to a folder:
/// march.comp (only the features the frame uses), params.json (the parameter block's members,
/// the bindings, the dispatch), params.bin (the block's std430 bytes) and the data buffers the
/// frame's shader reads (the Mie table, the multiple-scattering grids, a VDB field's NanoVDB
/// grid as vdb_grid.bin). A scene that uses what
/// `nimbus rt` refuses is refused the same way (exit 2, every key named); nothing is written.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "plugin/cli/commands.h"
#include "plugin/cli/common.h"
#include "plugin/io/atomic_file.h"
#include "plugin/io/frames.h"
#include "plugin/realtime/export_glsl.h"
#include "plugin/realtime/rt_march.h"

namespace nimbus::cli {

namespace {

bool writeBytes(const std::string& path, const void* data, std::size_t n) {
    try {
        io::writeAtomically(path, [&](const std::string& tmp) {
            std::ofstream out(tmp, std::ios::binary);
            out.write(static_cast<const char*>(data), std::streamsize(n));
            if (!out.flush()) throw std::runtime_error("cannot write " + tmp);
        });
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: error: export-glsl: %s\n", e.what());
        return false;
    }
    return true;
}

} // namespace

int runExportGlsl(const ExportGlslOptions& o) {
    host::Session session;
    if (int rc = loadScene(o.scene, o.overrides, -1, session)) return rc;
    // the GPU march has no shadow-marched sky: "auto" keeps the grid's sky here (core/scene.h)
    session.file().scene.render.autoPhotonSky = false;
    int frame = 0;
    if (o.frame) {
        frame = *o.frame;
    } else {
        try {
            const std::vector<int> frames = io::parseFrameSpec(session.file().frames);
            if (frames.empty()) throw std::runtime_error("the scene's `frames` is empty");
            frame = frames.front();
        } catch (const std::exception& e) {
            std::fprintf(stderr, "nimbus: error: export-glsl: frames: %s\n", e.what());
            return kExitBadInput;
        }
    }
    const SceneDesc& scene = session.scene();
    // the frame's grids (a VDB field's grid goes out as a data file), bound as `nimbus rt` does
    if (int rc = report(session.bind(frame))) return rc;
    const FramePlan plan = session.plan(frame);
    // the refusals of `nimbus rt`, with its message, before anything is written
    const std::vector<rt::Unsupported> no = rt::unsupported(scene, plan);
    if (!no.empty()) {
        for (const rt::Unsupported& u : no)
            std::fprintf(stderr, "nimbus: error: %s: %s (not supported by the GPU path: %s)\n",
                         session.file().path.c_str(), u.key.c_str(), u.message.c_str());
        return kExitBadInput;
    }
    // the multiple-scattering grids (when the plan names them), computed on the CPU as
    // `nimbus rt` does, go out as data files
    MarchGrids grids;
    if (rt::readsMarchGrids(plan)) {
        RenderStats gridStats;
        grids = session.renderer().marchGrids(plan, session.bindings(), gridStats);
    }
    // the cumulus noise tiles (when the plan bakes them), baked by the CPU as for `nimbus render`
    const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
    // the majorant grid the CPU renders with (render.skip_empty), as `nimbus rt` builds it: the
    // shader skips its empty cells (RT_SKIP) and the grid goes out as majorant.bin
    const MajorantGrid majorant = rt::majorantGrid(session.renderer(), plan, session.bindings());
    rt::GlslExport e;
    std::string error;
    if (!rt::exportGlsl(scene, plan, session.file().path, &grids, &session.bindings(), &noise,
                        &majorant, e, &error)) {
        std::fprintf(stderr, "nimbus: error: export-glsl: %s\n", error.c_str());
        return kExitInternal;
    }

    const std::filesystem::path dir(o.output);
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec || !std::filesystem::is_directory(dir)) {
        std::fprintf(stderr, "nimbus: error: export-glsl: cannot create the folder \"%s\": %s\n",
                     clipped(o.output).c_str(),
                     ec ? ec.message().c_str() : "a file of that name is in the way");
        return kExitIo;
    }
    if (!writeBytes((dir / rt::kExportShaderFile).string(), e.shader.data(), e.shader.size()) ||
        !writeBytes((dir / rt::kExportJsonFile).string(), e.json.data(), e.json.size()) ||
        !writeBytes((dir / rt::kExportParamsFile).string(), e.params.data(), e.params.size()))
        return kExitIo;
    std::string data;
    for (const auto& [file, bytes] : e.data) {
        if (!writeBytes((dir / file).string(), bytes.data(), bytes.size())) return kExitIo;
        data += ", " + file + " (" + std::to_string(bytes.size()) + " bytes)";
    }
    std::string features;
    for (const auto& [name, on] : rt::featureMacros(e.features))
        if (on) features += (features.empty() ? "" : ", ") + name;
    std::printf("frame %d: %s (%s), %s, %s (%zu bytes)%s -> %s\n", frame, rt::kExportShaderFile,
                features.empty() ? "no optional features" : features.c_str(), rt::kExportJsonFile,
                rt::kExportParamsFile, e.params.size(), data.c_str(), o.output.c_str());
    return kExitOk;
}

} // namespace nimbus::cli
