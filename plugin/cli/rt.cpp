/// @file rt.cpp
/// @brief `nimbus rt`: the frames of a scene rendered on the GPU by the GLSL march pass
/// (plugin/realtime/rt_march.h) over a headless OpenGL 4.5 context, written through the same
/// output code as `nimbus render` (host::Session::writeFrame: the EXR with its metadata, the
/// preview). A scene that uses what the GPU path does not support is refused with exit 2 and a
/// message naming the key; there is no fallback to the CPU. `--accumulate N` averages N renders
/// of each frame with their own jitter (rt::MarchPass::setAccumulation); `--gpu-display` applies
/// the preview's OCIO display/view transform on the GPU (plugin/realtime/ocio_gpu.h).
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "plugin/cli/commands.h"
#include "plugin/cli/common.h"
#include "plugin/io/frames.h"
#include "plugin/realtime/gl_compute.h"
#include "plugin/realtime/ocio_gpu.h"
#include "plugin/realtime/rt_march.h"

namespace nimbus::cli {

int runRt(const RtOptions& o) {
    host::Session session;
    if (int rc = loadScene(o.scene, o.overrides, -1, session)) return rc;
    // the GPU march has no shadow-marched sky: "auto" keeps the grid's sky here (core/scene.h)
    session.file().scene.render.autoPhotonSky = false;
    if (!o.output.empty()) {
        if (o.output.size() < 4 || o.output.substr(o.output.size() - 4) != ".exr") {
            std::fprintf(stderr, "nimbus: error: rt: output path \"%s\" must end in .exr\n",
                         clipped(o.output).c_str());
            return kExitBadInput;
        }
        session.file().output.path = o.output;
    }
    std::vector<int> frames;
    try {
        frames = io::parseFrameSpec(o.frames.empty() ? session.file().frames : o.frames);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: error: rt: --frames: %s\n", e.what());
        return kExitBadInput;
    }
    if (frames.size() > 1)
        for (const std::string& p : {session.file().output.path, session.file().output.preview})
            if (!p.empty() && !io::patternHasFrameToken(p)) {
                std::fprintf(stderr,
                             "nimbus: error: rt: %zu frames would all be written to \"%s\": add a "
                             "frame token (%s)\n",
                             frames.size(), clipped(p).c_str(),
                             std::string(io::framePatternSyntax()).c_str());
                return kExitBadInput;
            }

    // every frame is checked before the first is rendered: a refusal costs no GPU time (a VDB
    // field's frame again once its grid is bound: its bounds decide whether it is rebased)
    const SceneDesc& scene = session.scene();
    auto refused = [&](const FramePlan& plan) {
        const std::vector<rt::Unsupported> no = rt::unsupported(scene, plan);
        for (const rt::Unsupported& u : no)
            std::fprintf(stderr, "nimbus: error: %s: %s (not supported by the GPU path: %s)\n",
                         session.file().path.c_str(), u.key.c_str(), u.message.c_str());
        return !no.empty();
    };
    for (int frame : frames) {
        const FramePlan plan = session.plan(frame);
        if (refused(plan)) return kExitBadInput;
        if (o.explain) {
            std::printf("%s%s  GPU accumulation: %d pass(es) per frame\n  output: %s\n",
                        plan.explain().c_str(), rt::explainMarch(scene, plan).c_str(), o.accumulate,
                        session.outputPath(frame).c_str());
        }
    }
    if (o.explain) return kExitOk;

    std::string error;
    const auto contextStart = std::chrono::steady_clock::now();
    std::unique_ptr<gl::ComputeContext> context = gl::ComputeContext::create(&error);
    if (!context) {
        std::fprintf(stderr,
                     "nimbus: error: rt: no headless OpenGL 4.5 context (EGL surfaceless; on "
                     "Debian: libegl1 libopengl0 libgl1-mesa-dri): %s\n",
                     error.c_str());
        return kExitInternal;
    }
    const std::string device = context->renderer();
    if (!o.quiet)
        std::printf("GPU: %s (context in %.3f s)\n", device.c_str(), secondsSince(contextStart));

    // the preview's display transform on the GPU: OCIO's shader for the working space to
    // output.display / output.view, with its LUTs, made once for every frame
    std::unique_ptr<rt::GpuDisplayTransform> display;
    double displaySeconds = 0.0;
    const io::OutputDesc& out = session.file().output;
    if (o.gpuDisplay && out.preview.empty())
        std::fprintf(stderr, "nimbus: warning: rt: --gpu-display: the scene writes no preview "
                             "(output.preview is empty)\n");
    if (o.gpuDisplay && !out.preview.empty()) {
        io::GpuDisplayShader shader;
        try {
            shader = session.colors().displayViewGpuShader(session.workingSpace(), out.display,
                                                           out.view);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "nimbus: error: rt: --gpu-display: %s\n", e.what());
            return kExitBadInput;
        }
        display = std::make_unique<rt::GpuDisplayTransform>(shader);
        if (!display->valid()) {
            std::fprintf(stderr, "nimbus: error: rt: --gpu-display: %s\n",
                         display->error().c_str());
            return kExitInternal;
        }
        if (!o.quiet)
            std::printf("preview: the display transform \"%s\" / \"%s\" from %s on the GPU "
                        "(OpenColorIO's GLSL, %zu LUT texture(s))\n",
                        out.display.c_str(), out.view.c_str(), session.workingSpace().c_str(),
                        display->textureCount());
    }
    const host::Session::DisplayTransformFn gpuDisplay =
        display ? host::Session::DisplayTransformFn(
                      [&](std::vector<float>& rgb, int w, int h, std::string* e) {
                          return display->apply(rgb, w, h, e, &displaySeconds);
                      })
                : host::Session::DisplayTransformFn();

    rt::MarchPass pass;
    pass.setAccumulation(o.accumulate);
    for (int frame : frames) {
        // the frame's grids (a VDB field's), bound as `nimbus render` binds them
        if (int rc = report(session.bind(frame))) return rc;
        const FramePlan plan = session.plan(frame);
        if (refused(plan)) return kExitBadInput;
        Framebuffer fb;
        rt::MarchStats stats;
        // the multiple-scattering grids and the light volume (when the plan names them) are
        // computed on the CPU, as `nimbus render` computes them, and read by the shader
        MarchGrids grids;
        if (rt::readsMarchGrids(plan)) {
            const auto gridStart = std::chrono::steady_clock::now();
            RenderStats gridStats;
            grids = session.renderer().marchGrids(plan, session.bindings(), gridStats);
            if (!o.quiet) {
                // what the plan built: the multiple-scattering grids, the sun's light volume,
                // the single-scattered sky's volume
                std::string built;
                auto add = [&](bool on, const char* what) {
                    if (on) built += (built.empty() ? "" : " and ") + std::string(what);
                };
                add(plan.diffusion || plan.photons, "multiple-scattering grid");
                add(plan.lightVolume, "light-attenuation volume");
                add(plan.skyVolume, "sky volume");
                std::printf("frame %d: %s computed on the CPU in %.3f s\n", frame, built.c_str(),
                            secondsSince(gridStart));
            }
        }
        // the cumulus noise tiles when the plan bakes them: the CPU's (baked once, as for
        // `nimbus render`), read by the shader
        const rt::BakedNoise noise = rt::bakedNoise(session.renderer(), plan, session.bindings());
        // the majorant grid the CPU renders the frame with (render.skip_empty): the shader skips
        // the samples in its empty cells (RT_SKIP)
        MajorantGrid majorant;
        if (plan.skipEmpty) {
            const auto majorantStart = std::chrono::steady_clock::now();
            majorant = rt::majorantGrid(session.renderer(), plan, session.bindings());
            if (!o.quiet)
                std::printf("frame %d: majorant grid (%dx%dx%d cells, %.0f%% empty) built on the "
                            "CPU in %.3f s%s\n",
                            frame, majorant.res.x, majorant.res.y, majorant.res.z,
                            100.0 * majorant.emptyFraction(), secondsSince(majorantStart),
                            rt::skipsWith(plan, &majorant) ? "" : "; not used: no empty cell");
        }
        if (!pass.render(scene, plan, &grids, &session.bindings(), &noise, &majorant, fb, stats,
                         &error)) {
            std::fprintf(stderr, "nimbus: error: rt: frame %d: %s\n", frame, error.c_str());
            return kExitInternal;
        }
        io::ExrMetadata md;
        md.settings = io::sceneSettings(session.file());
        md.settings["scene"] = session.file().path;
        md.settings["plan"] = plan.explain() + rt::explainMarch(scene, plan, &majorant);
        md.settings["renderer"] = "nimbus rt: the GLSL march pass on " + device;
        md.settings["rt.accumulate"] = std::to_string(o.accumulate);
        md.seed = scene.render.seed;
        md.renderSeconds = stats.frameSeconds;
        // not the CPU's hash: `nimbus render --resume` renders a GPU frame again
        md.sceneHash = "glsl-" + session.sceneHash();
        const host::Status st = session.writeFrame(frame, fb, md, stats.nonFinite, gpuDisplay);
        printWarnings(session);
        if (int rc = report(st)) return rc;
        if (!o.quiet)
            std::printf("frame %d: %dx%d, %.4f s on the GPU (the march %.2f ms on its clock; "
                        "upload %.4f s, dispatches and wait %.4f s, read-back %.4f s)%s%s -> %s\n",
                        frame, fb.width, fb.height, stats.frameSeconds, 1e3 * stats.gpuSeconds,
                        stats.uploadSeconds, stats.marchSeconds, stats.readSeconds,
                        o.accumulate > 1
                            ? (" (" + std::to_string(o.accumulate) + " accumulated passes)").c_str()
                            : "",
                        stats.compileSeconds > 0.0
                            ? (" (shader compiled in " + std::to_string(stats.compileSeconds) +
                               " s before)")
                                  .c_str()
                            : "",
                        session.outputPath(frame).c_str());
        if (!o.quiet && stats.sliceSteps < rt::MarchPass::kWholeRay)
            std::printf("frame %d: marched in slices of %d camera steps (%d dispatches, %d renders "
                        "discarded): the GL's loop budget is too small for whole rays "
                        "(docs/realtime.md, \"SDF clouds\")\n",
                        frame, stats.sliceSteps, stats.dispatches, stats.budgetRetries);
        if (!o.quiet && display)
            std::printf("frame %d: preview's display transform %.4f s on the GPU -> %s\n", frame,
                        displaySeconds, io::expandFramePattern(out.preview, frame).c_str());
    }
    return kExitOk;
}

} // namespace nimbus::cli
