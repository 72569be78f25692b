#include "plugin/cli/commands.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include <unistd.h>

#include "core/render.h"
#include "plugin/cli/progress.h"
#include "plugin/io/atomic_file.h"
#include "plugin/io/color.h"
#include "plugin/io/frames.h"
#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"
#include "plugin/io/scene_setup.h"

namespace nimbus::cli {

namespace {

std::atomic<bool> gCancel{false};

extern "C" void onSignal(int sig) {
    // first signal: stop rendering after the tiles in flight and remove partial outputs;
    // a second one: leave at once
    io::removeInFlightTempFiles();
    if (gCancel.exchange(true)) {
        std::signal(sig, SIG_DFL);
        std::raise(sig);
    }
}

void installSignalHandlers() {
    std::signal(SIGINT, onSignal);
    std::signal(SIGTERM, onSignal);
    std::signal(SIGHUP, onSignal);
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Loads, overrides and colour-resolves a scene; errors are printed and mapped to exit codes.
struct LoadedScene {
    std::optional<io::ColorSystem> cs;
    io::SceneFile file;
};

int loadScene(const std::string& path, const std::vector<std::string>& overrides, int threads,
              LoadedScene& out) {
    try {
        out.cs.emplace(io::ColorSystem::load());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: error: colour configuration: %s\n", e.what());
        return kExitBadInput;
    }
    try {
        out.file = io::loadSceneFile(path, overrides);
        if (threads >= 0) out.file.scene.render.threads = threads;
        io::resolveColours(out.file, *out.cs);
    } catch (const io::SceneError& e) {
        std::fprintf(stderr, "nimbus: error: %s\n", e.what());
        return kExitBadInput;
    }
    for (const auto& w : out.file.warnings) std::fprintf(stderr, "nimbus: %s\n", w.c_str());
    return kExitOk;
}

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

std::map<std::string, std::string> settingsOf(const io::SceneFile& f,
                                              const std::vector<std::string>& overrides,
                                              const FramePlan& plan) {
    const RenderDesc& r = f.scene.render;
    std::map<std::string, std::string> m;
    m["scene"] = f.path;
    // the scene file itself, so a frame can be reproduced from its EXR alone
    std::ifstream in(f.path);
    m["scene_file"] = std::string(std::istreambuf_iterator<char>(in), {});
    std::string ov;
    for (const auto& o : overrides) ov += (ov.empty() ? "" : " ") + o;
    m["overrides"] = ov;
    m["integrator"] = "march";
    m["render.step"] = fmt("%g", r.step);
    m["render.step_growth"] = fmt("%g", r.stepGrowth);
    m["render.shadow_step"] = fmt("%g", r.shadowStep);
    m["render.shadow_growth"] = fmt("%g", r.shadowGrowth);
    m["render.epsilon"] = fmt("%g", r.epsilon);
    m["render.jitter"] = r.jitter ? "true" : "false";
    m["render.skip_empty"] = r.skipEmpty ? "true" : "false";
    m["plan"] = plan.explain();
    return m;
}

bool validOutputExists(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) return false;
    try {
        io::ExrImage img = io::readExr(path);
        return img.attributes.count("nimbus/frame") && img.width > 0;
    } catch (const std::exception&) {
        return false;
    }
}

} // namespace

int runRender(const RenderOptions& o) {
    LoadedScene ls;
    if (int rc = loadScene(o.scene, o.overrides, o.threads, ls)) return rc;
    io::SceneFile& f = ls.file;
    if (!o.output.empty()) f.output.path = o.output;
    if (f.output.path.size() < 4 || f.output.path.substr(f.output.path.size() - 4) != ".exr") {
        std::fprintf(stderr, "nimbus: error: output path \"%s\" must end in .exr\n",
                     f.output.path.c_str());
        return kExitBadInput;
    }
    std::vector<int> frames;
    try {
        frames = io::parseFrameSpec(o.frames.empty() ? f.frames : o.frames);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: error: --frames: %s\n", e.what());
        return kExitBadInput;
    }
    if (frames.size() > 1) {
        for (const std::string* p : {&f.output.path, &f.output.preview})
            if (!p->empty() && !io::patternHasFrameToken(*p)) {
                std::fprintf(stderr,
                             "nimbus: error: %zu frames would all be written to \"%s\": add a "
                             "frame token (%s)\n",
                             frames.size(), p->c_str(),
                             std::string(io::framePatternSyntax()).c_str());
                return kExitBadInput;
            }
    }

    Renderer renderer(f.scene);
    if (o.explain) {
        std::printf("scene %s\ncolour: %s, working space %s, output %s\n", f.path.c_str(),
                    ls.cs->description().c_str(), io::workingSpace(*ls.cs).c_str(),
                    f.output.colorSpace.c_str());
        for (int frame : frames) {
            FramePlan plan = renderer.plan(frame, f.output.aovs);
            std::printf("%s  output: %s\n", plan.explain().c_str(),
                        io::expandFramePattern(f.output.path, frame).c_str());
        }
        return kExitOk;
    }

    installSignalHandlers();
    const ProgressMode mode = o.quiet                 ? ProgressMode::None
                              : o.progress == "bar"   ? ProgressMode::Bar
                              : o.progress == "plain" ? ProgressMode::Plain
                              : o.progress == "none"  ? ProgressMode::None
                                                      : ProgressMode::Auto;
    Progress progress(mode, int(frames.size()));
    const std::string ws = io::workingSpace(*ls.cs);
    double totalSeconds = 0.0;
    int rendered = 0;
    for (size_t k = 0; k < frames.size(); ++k) {
        const int frame = frames[k];
        const std::string out = io::expandFramePattern(f.output.path, frame);
        if (o.resume && validOutputExists(out)) {
            progress.finishLine();
            if (!o.quiet)
                std::fprintf(stderr, "frame %d: %s exists, skipped (--resume)\n", frame,
                             out.c_str());
            continue;
        }
        const FramePlan plan = renderer.plan(frame, f.output.aovs);
        Framebuffer fb;
        RenderStats st;
        RenderCallbacks cb;
        cb.cancel = &gCancel;
        cb.progress = [&](int done, int total) {
            progress.update(int(k), frame, double(done) / total);
        };
        progress.update(int(k), frame, 0.0);
        const auto t0 = std::chrono::steady_clock::now();
        const bool complete = renderer.render(plan, fb, st, cb);
        const double seconds = secondsSince(t0);
        if (!complete || gCancel) {
            progress.finishLine();
            io::removeInFlightTempFiles();
            std::fprintf(stderr, "nimbus: interrupted during frame %d; no output written for it\n",
                         frame);
            return kExitInterrupted;
        }
        try {
            io::ExrMetadata md;
            md.settings = settingsOf(f, o.overrides, plan);
            md.seed = f.scene.render.seed;
            md.renderSeconds = seconds;
            md.frame = frame;
            size_t bad = io::writeExr(out, fb, *ls.cs, ws, f.output.colorSpace, md);
            if (!f.output.preview.empty())
                bad += io::writePreviewPng(io::expandFramePattern(f.output.preview, frame), fb,
                                           *ls.cs, ws, f.output.display, f.output.view);
            if (bad + st.nonFinite > 0)
                std::fprintf(stderr,
                             "nimbus: warning: frame %d: %zu non-finite values replaced by 0\n",
                             frame, size_t(bad + st.nonFinite));
        } catch (const std::exception& e) {
            progress.finishLine();
            std::fprintf(stderr, "nimbus: error: frame %d: %s\n", frame, e.what());
            return kExitIo;
        }
        if (gCancel) {
            progress.finishLine();
            return kExitInterrupted;
        }
        progress.update(int(k), frame, 1.0);
        totalSeconds += seconds;
        ++rendered;
        if (!o.quiet) {
            progress.finishLine();
            const double lookups = double(st.lookups());
            std::fprintf(stderr,
                         "frame %d: %.2f s (noise %s, bake %.2f s, majorant %.2f s, march %.2f s), "
                         "%.1f M density lookups (%.1f M/s, %.0f%% in shadow rays), "
                         "%.0f%% of majorant cells empty -> %s\n",
                         frame, seconds, plan.bakeNoise ? "baked" : "direct", st.bakeSeconds,
                         st.majorantSeconds, st.integrateSeconds, lookups * 1e-6,
                         lookups * 1e-6 / std::max(st.integrateSeconds, 1e-9),
                         100.0 * double(st.shadowSamples) / std::max(lookups, 1.0),
                         100.0 * st.majorantEmptyFraction, out.c_str());
        }
    }
    progress.finishLine();
    if (!o.quiet && rendered > 1)
        std::fprintf(stderr, "%d frames in %s (%.2f s per frame)\n", rendered,
                     formatDuration(totalSeconds).c_str(), totalSeconds / rendered);
    return kExitOk;
}

int runConverge(const ConvergeOptions& o) {
    LoadedScene ls;
    if (int rc = loadScene(o.scene, o.overrides, o.threads, ls)) return rc;
    SceneDesc base = ls.file.scene;
    // compare the clouds themselves: a noise-free sky behind them would dilute the error
    base.render.background = Background::Transparent;
    int frame = o.frame;
    if (frame == -1000000000) frame = io::parseFrameSpec(ls.file.frames).front();
    if (o.ladder.empty()) {
        std::fprintf(stderr, "nimbus: error: --ladder needs at least one step multiplier\n");
        return kExitBadInput;
    }
    for (double m : o.ladder)
        if (!(m > 0.0)) {
            std::fprintf(stderr, "nimbus: error: --ladder: multiplier %g must be > 0\n", m);
            return kExitBadInput;
        }
    // every rung uses the same noise evaluation as the scene's own plan, so the error measured is
    // that of the step alone
    {
        Renderer probe(base);
        base.field.cumulus.eval =
            probe.plan(frame).bakeNoise ? NoiseEval::Baked : NoiseEval::Direct;
    }
    installSignalHandlers();
    auto renderWith = [&](double factor, Framebuffer& fb, RenderStats& st) {
        SceneDesc s = base;
        // the whole step schedule scales: base steps and distance growth alike
        s.render.step = float(base.render.step * factor);
        s.render.stepGrowth = float(base.render.stepGrowth * factor);
        s.render.shadowStep = float(base.render.shadowStep * factor);
        Renderer r(s);
        FramePlan plan = r.plan(frame);
        r.render(plan, fb, st); // warm-up: bakes the noise tiles so the timing is the march's
        RenderCallbacks cb;
        cb.cancel = &gCancel;
        const auto t0 = std::chrono::steady_clock::now();
        const bool ok = r.render(plan, fb, st, cb);
        return ok ? secondsSince(t0) : -1.0;
    };

    std::fprintf(stderr, "reference: step %g x %g = %g ...\n", base.render.step, o.referenceFactor,
                 base.render.step * o.referenceFactor);
    Framebuffer ref;
    RenderStats refStats;
    const double refSeconds = renderWith(o.referenceFactor, ref, refStats);
    if (refSeconds < 0) return kExitInterrupted;
    double refSq = 0.0;
    for (float v : ref.rgba) refSq += double(v) * v;
    const double refRms = std::sqrt(refSq / double(ref.rgba.size()));

    struct Row {
        double factor, step, shadowStep, samplesPerRay, shadowPerRay, seconds, rmse, rel;
    };
    std::vector<Row> rows;
    auto addRow = [&](double factor, const RenderStats& st, double seconds, const Framebuffer* fb) {
        Row r{factor,
              base.render.step * factor,
              base.render.shadowStep * factor,
              double(st.primarySamples) / std::max<double>(1, double(st.rays)),
              double(st.shadowSamples) / std::max<double>(1, double(st.rays)),
              seconds,
              0.0,
              0.0};
        if (fb) {
            double sq = 0.0;
            for (size_t i = 0; i < ref.rgba.size(); ++i) {
                const double d = double(fb->rgba[i]) - ref.rgba[i];
                sq += d * d;
            }
            r.rmse = std::sqrt(sq / double(ref.rgba.size()));
            r.rel = refRms > 0 ? r.rmse / refRms : 0.0;
        }
        rows.push_back(r);
    };
    addRow(o.referenceFactor, refStats, refSeconds, nullptr);
    for (double m : o.ladder) {
        Framebuffer fb;
        RenderStats st;
        const double sec = renderWith(m, fb, st);
        if (sec < 0) return kExitInterrupted;
        addRow(m, st, sec, &fb);
        std::fprintf(stderr, "  step x %g: %.3f s, rel. RMSE %.4f\n", m, sec, rows.back().rel);
    }

    std::ostringstream table, csv;
    table << "frame " << frame << ", " << ls.file.scene.camera.width << "x"
          << ls.file.scene.camera.height << ", clouds only (RGBA, background transparent)\n";
    char line[256];
    std::snprintf(line, sizeof line,
                  "| %-9s | %-10s | %-11s | %-13s | %-13s | %-10s | %-10s | %-9s |\n", "step x",
                  "step", "shadow step", "samples/ray", "shadow/ray", "time (s)", "RMSE",
                  "rel. RMSE");
    table << line
          << "|-----------|------------|-------------|---------------|---------------|------------|"
             "------------|-----------|\n";
    csv << "step_multiplier,step,shadow_step,samples_per_ray,shadow_samples_per_ray,seconds,rmse,"
           "relative_rmse,is_reference\n";
    for (size_t i = 0; i < rows.size(); ++i) {
        const Row& r = rows[i];
        std::snprintf(line, sizeof line,
                      "| %-9g | %-10.4g | %-11.4g | %-13.1f | %-13.1f | %-10.3f | %-10s | %-9s |\n",
                      r.factor, r.step, r.shadowStep, r.samplesPerRay, r.shadowPerRay, r.seconds,
                      i == 0 ? "reference" : fmt("%.3g", r.rmse).c_str(),
                      i == 0 ? "-" : fmt("%.2f%%", 100.0 * r.rel).c_str());
        table << line;
        csv << r.factor << "," << r.step << "," << r.shadowStep << "," << r.samplesPerRay << ","
            << r.shadowPerRay << "," << r.seconds << "," << (i == 0 ? 0.0 : r.rmse) << ","
            << (i == 0 ? 0.0 : r.rel) << "," << (i == 0 ? 1 : 0) << "\n";
    }
    std::cout << table.str();
    std::string csvPath = o.csv;
    if (csvPath.empty()) csvPath = std::filesystem::path(o.scene).stem().string() + ".converge.csv";
    try {
        io::writeAtomically(csvPath, [&](const std::string& tmp) {
            std::ofstream out(tmp);
            out << csv.str();
            if (!out.flush()) throw std::runtime_error("cannot write " + tmp);
        });
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: error: %s\n", e.what());
        return kExitIo;
    }
    std::fprintf(stderr, "wrote %s\n", csvPath.c_str());
    return kExitOk;
}

} // namespace nimbus::cli
