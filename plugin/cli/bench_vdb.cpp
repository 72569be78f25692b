/// @file bench_vdb.cpp
/// @brief `nimbus bench-vdb-render`: the same VDB, camera, sun and resolution rendered by
/// OpenVDB's own VolumeRender (plugin/vdb/volume_render_baseline.h) and by Nimbus `march` in
/// single scattering, in one process; time and error of each against a very-fine-step Nimbus
/// reference, over a ladder of step sizes for both.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>

#include <tbb/task_arena.h>

#include "core/render.h"
#include "plugin/cli/commands.h"
#include "plugin/cli/common.h"
#include "plugin/cli/vdb_scene.h"
#include "plugin/io/image_output.h"
#include "plugin/io/scene_setup.h"
#include "plugin/vdb/volume_render_baseline.h"

namespace nimbus::cli {

namespace {

const char* phaseName(PhaseKind k) {
    switch (k) {
    case PhaseKind::Isotropic:
        return "isotropic";
    case PhaseKind::HenyeyGreenstein:
        return "hg";
    case PhaseKind::DualHG:
        return "dual_hg";
    case PhaseKind::Draine:
        return "draine";
    case PhaseKind::MieApprox:
        return "mie_approx";
    case PhaseKind::MieTable:
        return "mie_table";
    }
    return "?";
}

/// Turns the scene into the problem VolumeRender solves (see volume_render_baseline.h) and
/// lists what changed.
std::vector<std::string> toSingleScattering(SceneDesc& s) {
    std::vector<std::string> changed;
    if (s.medium.phase != PhaseKind::Isotropic)
        changed.push_back(std::string("medium.phase ") + phaseName(s.medium.phase) +
                          " -> isotropic (VolumeRender has no phase function)");
    s.medium.phase = PhaseKind::Isotropic;
    if (s.render.octaves != 1)
        changed.push_back("render.octaves " + std::to_string(s.render.octaves) +
                          " -> 1 (single scattering)");
    s.render.octaves = 1;
    if (s.render.multipleScattering != MultipleScattering::None)
        changed.push_back("render.multiple_scattering -> none");
    s.render.multipleScattering = MultipleScattering::None;
    if (s.render.inScatter != InScatter::None) changed.push_back("render.inscatter -> none");
    s.render.inScatter = InScatter::None;
    if (s.sky.kind != SkyKind::None) changed.push_back("sky.kind -> none (no ambient light)");
    s.sky.kind = SkyKind::None;
    s.render.integrator = Integrator::March;
    s.render.background = Background::Transparent;
    return changed;
}

struct Row {
    std::string renderer; ///< "nimbus" or "VolumeRender"
    std::string label;    ///< short name of the setting (file names, summary)
    std::string settings; ///< steps in world units and voxels
    double seconds = 0.0;
    double err = 0.0, rel = 0.0;
    Framebuffer fb;
};

std::string nimbusSettings(const RenderDesc& r, double voxel) {
    // steps of 0 are the plan's: step_voxels x the voxel (core/plan.h; one grid here)
    const double step = r.step > 0.0f ? r.step : r.stepVoxels * voxel;
    const double shadow = r.shadowStep > 0.0f ? r.shadowStep : r.shadowStepVoxels * voxel;
    char buf[200];
    if (r.shadow == ShadowMethod::Volume)
        std::snprintf(buf, sizeof buf, "step %.4g (%.3g vx), light volume", step, step / voxel);
    else
        std::snprintf(buf, sizeof buf, "step %.4g (%.3g vx), shadow %.4g (%.3g vx) +%g%%/step",
                      step, step / voxel, shadow, shadow / voxel, 100.0 * r.shadowGrowth);
    std::string s = buf;
    if (r.stepGrowth > 0.0f) s += ", step growth " + std::to_string(r.stepGrowth);
    return s;
}

std::string vdbSettings(const vdb::VolumeRenderSettings& v, double voxel) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "step %.3g vx (%.4g), shadow %.3g vx (%.4g), cutoff %.2g",
                  v.primaryStep, v.primaryStep * voxel, v.shadowStep, v.shadowStep * voxel,
                  v.cutoff);
    return buf;
}

std::string fileLabel(std::string s) {
    for (char& c : s)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.') c = '_';
    return s;
}

} // namespace

int runBenchVdb(const BenchVdbOptions& o) {
    LoadedScene ls;
    const std::string ext = std::filesystem::path(o.scene).extension().string();
    if (ext == ".vdb") {
        // a bare VDB file: framed as converge --suite frames it, lit from the image's right
        VdbFraming fr;
        std::string skip;
        const std::string path = std::filesystem::absolute(o.scene).string();
        if (!frameVdbFile(path, 640, 360, "nimbus bench-vdb-render", fr, skip)) {
            std::fprintf(stderr, "nimbus: error: %s: cannot bench it: %s\n", o.scene.c_str(),
                         skip.c_str());
            return kExitBadInput;
        }
        const std::string text = fr.scene + "[sun]\nelevation = 30.0\nazimuth = 110.0\n";
        const int rc = report(ls.loadString(text, path + ".toml", o.overrides, o.threads));
        printWarnings(ls);
        if (rc) return rc;
    } else if (int rc = loadScene(o.scene, o.overrides, o.threads, ls)) {
        return rc;
    }
    const io::SceneFile& f = ls.file();
    if (f.scene.field.kind != FieldKind::Vdb) {
        std::fprintf(stderr,
                     "nimbus: error: %s is not a VDB scene (its field.kind is \"%s\"): "
                     "bench-vdb-render compares Nimbus with OpenVDB's VolumeRender, which renders "
                     "VDB grids only; use a scene with [field] kind = \"vdb\", e.g. "
                     "examples/scenes/smoke1.toml\n",
                     f.path.c_str(),
                     f.scene.field.kind == FieldKind::Cumulus   ? "cumulus"
                     : f.scene.field.kind == FieldKind::Gardner ? "gardner"
                                                                : "homogeneous");
        return kExitBadInput;
    }
    if (!f.scene.sun.enabled || !(maxComponent(f.scene.sun.irradiance) > 0.0f)) {
        std::fprintf(stderr,
                     "nimbus: error: %s has no sun: VolumeRender's only light is a "
                     "directional light, so the comparison needs [sun] enabled with a "
                     "non-zero intensity\n",
                     f.path.c_str());
        return kExitBadInput;
    }
    auto positive = [](const std::vector<double>& v) {
        return std::all_of(v.begin(), v.end(), [](double x) { return x > 0.0; });
    };
    if (!positive(o.ladder) || !positive(o.vdbLadder) || !(o.referenceStep > 0.0) ||
        !(o.scale > 0.0) || !(o.vdbStep > 0.0) || !(o.vdbShadowStep > 0.0) || o.repeat < 1) {
        std::fprintf(stderr, "nimbus: error: --ladder, --vdb-ladder, --reference-step, --scale, "
                             "--vdb-step, --vdb-shadow-step and --repeat must all be > 0\n");
        return kExitBadInput;
    }
    std::vector<std::pair<double, double>> vdbPairs;
    for (const std::string& pair : o.vdbSteps) {
        double p = 0.0, sh = 0.0;
        char rest = 0;
        if (pair.empty()) continue;
        if (std::sscanf(pair.c_str(), "%lf:%lf%c", &p, &sh, &rest) != 2 || !(p > 0.0) ||
            !(sh > 0.0)) {
            std::fprintf(stderr,
                         "nimbus: error: --vdb-steps: \"%s\" is not primary:shadow with two "
                         "positive step lengths in voxels, e.g. 2:1\n",
                         pair.c_str());
            return kExitBadInput;
        }
        vdbPairs.emplace_back(p, sh);
    }
    if (o.ladder.empty() && o.vdbLadder.empty() && vdbPairs.empty()) {
        std::fprintf(stderr, "nimbus: error: no rungs: --ladder, --vdb-ladder and --vdb-steps "
                             "are all empty\n");
        return kExitBadInput;
    }

    int frame = 0;
    SceneDesc base;
    FrameBindings bindings;
    if (!prepare(ls, o.frame, o.scale, base, frame, bindings)) return kExitBadInput;
    const std::vector<std::string> changed = toSingleScattering(base);
    std::optional<vdb::VolumeRenderBaseline> baseline;
    try {
        baseline.emplace(base.field.vdb, bindings.grid(0));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: error: %s: frame %d: %s\n", f.path.c_str(), frame, e.what());
        return kExitBadInput;
    }
    const double voxel = baseline->voxelSize();
    const int threads =
        base.render.threads > 0 ? base.render.threads : tbb::this_task_arena::max_concurrency();
    const double cutoff =
        o.vdbCutoff >= 0.0 ? o.vdbCutoff : 3.0 * double(base.render.epsilon) * base.render.epsilon;
    installSignalHandlers();

    std::fprintf(stderr, "%s, frame %d, %dx%d, %d threads for both renderers, voxel %g\n",
                 f.path.c_str(), frame, base.camera.width, base.camera.height, threads, voxel);
    std::fprintf(stderr, "single scattering, isotropic phase, sun only, transparent background:\n");
    for (const auto& c : changed) std::fprintf(stderr, "  nimbus: %s\n", c.c_str());
    std::fprintf(stderr, "  VolumeRender gets:\n%s",
                 vdb::volumeRenderProblem(base, voxel).describe().c_str());

    // the reference: every step (and the shadow growth) scaled down, a late early exit
    auto referenceScene = [&](double r) {
        SceneDesc s = withSteps(base, r);
        s.render.shadowGrowth = float(base.render.shadowGrowth * r);
        s.render.epsilon = std::min(base.render.epsilon, 1e-4f);
        return s;
    };
    const SceneDesc refScene = referenceScene(o.referenceStep);
    std::fprintf(stderr, "reference: nimbus step x %g (%s, early exit %g) ...\n", o.referenceStep,
                 nimbusSettings(refScene.render, voxel).c_str(), double(refScene.render.epsilon));
    Measured ref;
    if (!measure(refScene, bindings, frame, ref)) return kExitInterrupted;
    const double refMean = imageError(ref.fb, ref.fb).mean;
    std::fprintf(stderr, "  %.2f s\n", ref.seconds);
    // convergence check: the reference against one twice as coarse; at first order the
    // reference's own error is about their difference
    double refCheck = -1.0;
    if (o.checkReference) {
        std::fprintf(stderr, "reference check: nimbus step x %g ...\n", 2.0 * o.referenceStep);
        Measured coarser;
        if (!measure(referenceScene(2.0 * o.referenceStep), bindings, frame, coarser))
            return kExitInterrupted;
        refCheck = imageError(coarser.fb, ref.fb).relative();
        std::fprintf(stderr, "  %.2f s, differs from the reference by rel. RMSE %.3f%%\n",
                     coarser.seconds, 100.0 * refCheck);
    }

    // the rungs: nimbus ladder, VolumeRender ladder and step pairs, then vdb_render's own
    // defaults (1 and 3 voxels, cutoff 0.005) unless listed
    std::vector<Row> rows;
    std::vector<SceneDesc> nimbusScenes; // rows[i] for i < nimbusScenes.size()
    for (double m : o.ladder) {
        Row row;
        row.renderer = "nimbus";
        char buf[64];
        std::snprintf(buf, sizeof buf, "step x %g", m);
        row.label = buf;
        nimbusScenes.push_back(withSteps(base, m));
        row.settings = nimbusSettings(nimbusScenes.back().render, voxel);
        rows.push_back(std::move(row));
    }
    std::vector<std::pair<std::string, vdb::VolumeRenderSettings>> vdbRungs;
    auto addVdb = [&](const std::string& label, double primary, double shadow, double c) {
        vdb::VolumeRenderSettings v;
        v.primaryStep = primary;
        v.shadowStep = shadow;
        v.cutoff = c;
        v.threads = base.render.threads;
        vdbRungs.emplace_back(label, v);
    };
    for (double m : o.vdbLadder) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "step x %g", m);
        addVdb(buf, o.vdbStep * m, o.vdbShadowStep * m, cutoff);
    }
    for (const auto& [p, sh] : vdbPairs) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "steps %g:%g", p, sh);
        addVdb(buf, p, sh, cutoff);
    }
    const vdb::VolumeRenderSettings defaults;
    const bool listed = std::any_of(vdbRungs.begin(), vdbRungs.end(), [&](const auto& r) {
        return r.second.primaryStep == defaults.primaryStep &&
               r.second.shadowStep == defaults.shadowStep && r.second.cutoff == defaults.cutoff;
    });
    if (!listed && o.vdbDefaults)
        addVdb("vdb_render defaults", defaults.primaryStep, defaults.shadowStep, defaults.cutoff);
    for (const auto& [label, v] : vdbRungs) {
        Row row;
        row.renderer = "VolumeRender";
        row.label = label;
        row.settings = vdbSettings(v, voxel);
        rows.push_back(std::move(row));
    }

    // every rung once per round, keeping the fastest time: rounds spread a changing machine
    // load over all rungs alike (both renderers are deterministic: the image of round 1 stays)
    for (int round = 0; round < o.repeat; ++round) {
        if (o.repeat > 1) std::fprintf(stderr, "round %d of %d\n", round + 1, o.repeat);
        for (size_t i = 0; i < rows.size(); ++i) {
            if (gCancel) return kExitInterrupted;
            Row& row = rows[i];
            double seconds = 0.0;
            Framebuffer fb;
            if (i < nimbusScenes.size()) {
                Measured mr;
                if (!measure(nimbusScenes[i], bindings, frame, mr)) return kExitInterrupted;
                seconds = mr.seconds;
                fb = std::move(mr.fb);
            } else {
                try {
                    seconds = baseline->render(base, vdbRungs[i - nimbusScenes.size()].second, fb)
                                  .total();
                } catch (const std::exception& e) {
                    std::fprintf(stderr, "nimbus: error: VolumeRender: %s\n", e.what());
                    return kExitInternal;
                }
            }
            if (round == 0) {
                row.fb = std::move(fb);
                row.seconds = seconds;
                row.err = imageError(row.fb, ref.fb).rmse;
                row.rel = refMean > 0.0 ? row.err / refMean : 0.0;
            } else {
                row.seconds = std::min(row.seconds, seconds);
            }
            std::fprintf(stderr, "  %-12s %-58s %8.3f s  rel. RMSE %6.2f%%\n", row.renderer.c_str(),
                         row.settings.c_str(), seconds, 100.0 * row.rel);
        }
    }
    if (gCancel) return kExitInterrupted;

    // the time unit: VolumeRender at its default steps (the ladder's x 1 rung), else its first
    const Row* unit = nullptr;
    for (const Row& r : rows)
        if (r.renderer == "VolumeRender" && (!unit || r.label == "step x 1")) unit = &r;
    if (!unit) unit = &rows.front();

    std::ostringstream table;
    table << f.path << ", frame " << frame << ", " << base.camera.width << "x" << base.camera.height
          << ", " << threads << " threads each, RGBA (transparent background), time: fastest of "
          << o.repeat << " round(s)\n"
          << "reference: nimbus step x " << o.referenceStep << " ("
          << nimbusSettings(refScene.render, voxel) << "), " << ref.seconds << " s";
    if (refCheck >= 0.0)
        table << "; step x " << 2.0 * o.referenceStep << " differs from it by rel. RMSE "
              << 100.0 * refCheck << "%";
    table << "\n";
    char line[400];
    std::snprintf(line, sizeof line, "| %-12s | %-58s | %-8s | %-12s | %-9s | %-9s |\n", "renderer",
                  "settings", "time (s)", "time / unit", "RMSE", "rel. RMSE");
    table << line << "|--------------|" << std::string(60, '-')
          << "|----------|--------------|-----------|-----------|\n";
    for (const Row& r : rows) {
        char rel[32];
        std::snprintf(rel, sizeof rel, "%.2f%%", 100.0 * r.rel);
        std::snprintf(line, sizeof line, "| %-12s | %-58s | %-8.3f | %-12.3f | %-9.3g | %-9s |\n",
                      r.renderer.c_str(), r.settings.c_str(), r.seconds,
                      r.seconds / std::max(unit->seconds, 1e-9), r.err, rel);
        table << line;
    }
    table << "time unit: VolumeRender " << unit->label << " (" << unit->seconds << " s)\n";
    // for each VolumeRender rung: the fastest nimbus rung with no larger error
    for (const Row& v : rows) {
        if (v.renderer != "VolumeRender") continue;
        const Row* best = nullptr;
        for (const Row& n : rows)
            if (n.renderer == "nimbus" && n.rel <= v.rel && (!best || n.seconds < best->seconds))
                best = &n;
        char buf[400];
        if (best)
            std::snprintf(
                buf, sizeof buf,
                "VolumeRender %s (%.3f s, %.2f%%): nimbus %s is %.2fx %s (%.3f s) at "
                "%.2f%%\n",
                v.label.c_str(), v.seconds, 100.0 * v.rel, best->label.c_str(),
                v.seconds >= best->seconds ? v.seconds / best->seconds : best->seconds / v.seconds,
                v.seconds >= best->seconds ? "faster" : "slower", best->seconds, 100.0 * best->rel);
        else
            std::snprintf(buf, sizeof buf,
                          "VolumeRender %s (%.3f s, %.2f%%): no nimbus rung is that accurate\n",
                          v.label.c_str(), v.seconds, 100.0 * v.rel);
        table << buf;
    }
    std::cout << table.str() << std::flush;

    if (!o.csv.empty()) {
        std::ostringstream csv;
        csv << "renderer,setting,settings,seconds,rmse,relative_rmse\n";
        for (const Row& r : rows)
            csv << r.renderer << "," << r.label << ",\"" << r.settings << "\"," << r.seconds << ","
                << r.err << "," << r.rel << "\n";
        if (!writeText(o.csv, csv.str())) return kExitIo;
        std::fprintf(stderr, "wrote %s\n", o.csv.c_str());
    }
    if (!o.outputDir.empty()) {
        const std::string ws = ls.workingSpace();
        auto write = [&](const std::string& stem, const Framebuffer& fb, double seconds) {
            const std::filesystem::path p = std::filesystem::path(o.outputDir) / stem;
            io::ExrMetadata md;
            md.renderSeconds = seconds;
            md.frame = frame;
            md.settings["scene"] = f.path;
            io::writeExr(p.string() + ".exr", fb, ls.colors(), ws, f.output.colorSpace, md);
            io::writePreviewPng(p.string() + ".png", fb, ls.colors(), ws, f.output.display,
                                f.output.view);
        };
        try {
            std::filesystem::create_directories(o.outputDir);
            write("reference", ref.fb, ref.seconds);
            for (const Row& r : rows)
                write(fileLabel((r.renderer == "nimbus" ? "nimbus_" : "volumerender_") + r.label),
                      r.fb, r.seconds);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "nimbus: error: --output-dir: %s\n", e.what());
            return kExitIo;
        }
        std::fprintf(stderr, "wrote the images (EXR and PNG) to %s\n", o.outputDir.c_str());
    }
    return kExitOk;
}

} // namespace nimbus::cli
