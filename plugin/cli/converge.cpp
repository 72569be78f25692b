/// @file converge.cpp
/// @brief `nimbus converge` (error against run time for every quality setting) and
/// `nimbus calibrate` (fit the approximations of `march` to a path-traced reference).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "core/render.h"
#include "plugin/cli/commands.h"
#include "plugin/cli/common.h"
#include "plugin/io/atomic_file.h"
#include "plugin/io/frames.h"
#include "plugin/io/image_output.h"
#include "plugin/io/scene_setup.h"

namespace nimbus::cli {

namespace {

struct Rung {
    std::string integrator; ///< "march" or "pathtrace"
    std::string label;      ///< what differs from the scene
    SceneDesc scene;
    double stepMultiplier = 1.0;
};

std::string percent(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f%%", 100.0 * v);
    return buf;
}

} // namespace

// shared with bench-vdb-render (declared in common.h)

SceneDesc withSteps(const SceneDesc& base, double f) {
    SceneDesc s = base;
    io::scaleSteps(s, f);
    return s;
}

bool measure(const SceneDesc& s, const FrameBindings& b, int frame, Measured& m) {
    Renderer r(s);
    const FramePlan plan = r.plan(frame, b);
    m.step = plan.step;
    m.shadowStep = plan.shadowStep;
    m.msModel = plan.photons ? "photons" : plan.diffusion ? "grid" : "none";
    m.cloudTau = plan.msAuto ? plan.cloudTau : -1.0;
    m.photonCellScale = plan.photons ? double(plan.photonCell / plan.lightVolumeCell) : 0.0;
    m.photonVoxelDepth = plan.photons ? plan.photonVoxelDepth : -1.0;
    m.marchOrders = plan.secondShare > 0.0f ? plan.secondDepth : 1;
    RenderCallbacks cb;
    cb.cancel = &gCancel;
    if (plan.bakeNoise) r.fieldFor(plan, b);
    const auto t0 = std::chrono::steady_clock::now();
    const bool ok = r.render(plan, b, m.fb, m.stats, cb);
    m.seconds = secondsSince(t0);
    return ok;
}

/// A path-traced reference rendered as two independent halves (seeds differ): their mean is the
/// reference and their difference measures its noise. A march reference or a one-sample one is
/// rendered once, noise 0. Returns false when interrupted.
bool measureReference(const SceneDesc& s, const FrameBindings& bindings, int frame, Measured& ref,
                      double& noise) {
    noise = 0.0;
    if (s.render.integrator != Integrator::PathTrace || s.render.spp <= 1)
        return measure(s, bindings, frame, ref);
    SceneDesc half = s;
    half.render.spp = std::max(1, s.render.spp / 2);
    Measured b;
    if (!measure(half, bindings, frame, ref)) return false;
    half.render.seed = s.render.seed ^ 0x9e3779b9u;
    if (!measure(half, bindings, frame, b)) return false;
    const Framebuffer a = ref.fb;
    ref.fb = halvesMean(a, b.fb);
    noise = halvesNoise(a, b.fb, ref.fb);
    ref.seconds += b.seconds;
    return true;
}

bool prepare(LoadedScene& ls, std::optional<int> requested, double scale, SceneDesc& base,
             int& frame, FrameBindings& b) {
    base = ls.scene();
    base.render.background = Background::Transparent;
    frame = requested ? *requested : ls.firstFrame();
    if (!bindFrame(ls, frame, b)) return false;
    base.camera.width = std::max(1, int(std::lround(base.camera.width * scale)));
    base.camera.height = std::max(1, int(std::lround(base.camera.height * scale)));
    Renderer probe(base);
    base.field.cumulus.eval = plannedNoiseEval(base, probe.plan(frame, b));
    return true;
}

bool writeText(const std::string& path, const std::string& text) {
    try {
        io::writeAtomically(path, [&](const std::string& tmp) {
            std::ofstream out(tmp);
            out << text;
            if (!out.flush()) throw std::runtime_error("cannot write " + tmp);
        });
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: error: %s\n", e.what());
        return false;
    }
    return true;
}

namespace {

/// The reference of converge and calibrate: rendered (and with --save-reference kept as an EXR
/// in the working space, no colour conversion, its label and noise in the header), or read back
/// from such a file. Returns an exit code; `label` becomes the file's label when loaded.
int obtainReference(const LoadedScene& ls, const SceneDesc& refScene, const FrameBindings& bindings,
                    int frame, const std::string& save, const std::string& load, std::string& label,
                    Measured& ref, double& noise) {
    const int w = refScene.camera.width, h = refScene.camera.height;
    if (!load.empty()) {
        io::ExrImage img;
        try {
            img = io::readExr(load);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "nimbus: error: --reference: %s\n", e.what());
            return kExitBadInput;
        }
        auto attr = [&](const std::string& key) {
            auto it = img.attributes.find(key);
            return it == img.attributes.end() ? std::string() : it->second;
        };
        const std::string fileLabel = attr("nimbus/settings/reference");
        const std::string fileNoise = attr("nimbus/settings/reference_noise_rmse");
        int c[4];
        const char* names[4] = {"R", "G", "B", "A"};
        for (int k = 0; k < 4; ++k) c[k] = img.channelIndex(names[k]);
        std::string why;
        if (fileLabel.empty() || fileNoise.empty())
            why = "not written by --save-reference (no nimbus/settings/reference header)";
        else if (c[0] < 0 || c[1] < 0 || c[2] < 0 || c[3] < 0)
            why = "it has no R, G, B and A channels";
        else if (img.width != w || img.height != h)
            why = "it is " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                  ", the renders are " + std::to_string(w) + "x" + std::to_string(h) +
                  " (check --scale)";
        else if (attr("nimbus/frame") != std::to_string(frame))
            why = "it is of frame " + attr("nimbus/frame") + ", not frame " + std::to_string(frame);
        if (!why.empty()) {
            std::fprintf(stderr, "nimbus: error: --reference %s: %s\n", load.c_str(), why.c_str());
            return kExitBadInput;
        }
        ref.fb.resize(w, h, AovSet{});
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                for (int k = 0; k < 4; ++k)
                    ref.fb.rgba[(size_t(y) * w + x) * 4 + k] = img.at(x, y, c[k]);
        noise = std::strtod(fileNoise.c_str(), nullptr);
        ref.seconds = std::strtod(attr("nimbus/renderTime").c_str(), nullptr);
        label = fileLabel + " (read from " + load + ")";
        std::fprintf(stderr, "reference: %s\n", label.c_str());
        return kExitOk;
    }
    std::fprintf(stderr, "reference: %s at %dx%d ...\n", label.c_str(), w, h);
    if (!measureReference(refScene, bindings, frame, ref, noise)) return kExitInterrupted;
    if (!save.empty()) {
        io::ExrMetadata md;
        md.frame = frame;
        md.seed = refScene.render.seed;
        md.renderSeconds = ref.seconds;
        md.settings["scene"] = ls.file().path;
        md.settings["reference"] = label;
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.9g", noise);
        md.settings["reference_noise_rmse"] = buf;
        const std::string ws = ls.workingSpace();
        try {
            io::writeExr(save, ref.fb, ls.colors(), ws, ws, md);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "nimbus: error: --save-reference: %s\n", e.what());
            return kExitIo;
        }
        std::fprintf(stderr, "wrote the reference to %s\n", save.c_str());
    }
    return kExitOk;
}

} // namespace

int runConverge(const ConvergeOptions& o) {
    if (o.suite) return runSuite(o);
    LoadedScene ls;
    if (int rc = loadScene(o.scene, o.overrides, o.threads, ls)) return rc;
    for (double m : o.ladder)
        if (!(m > 0.0)) {
            std::fprintf(stderr, "nimbus: error: --ladder: step multiplier %g must be > 0\n", m);
            return kExitBadInput;
        }
    for (int spp : o.pathtraceLadder)
        if (spp < 1) {
            std::fprintf(stderr, "nimbus: error: --pathtrace-ladder: %d spp must be >= 1\n", spp);
            return kExitBadInput;
        }
    for (int n : o.photonLadder)
        if (n < 1) {
            std::fprintf(stderr, "nimbus: error: --photon-ladder: %d photons must be >= 1\n", n);
            return kExitBadInput;
        }
    if (!(o.scale > 0.0) || o.referenceSpp < 0) {
        std::fprintf(stderr, "nimbus: error: --scale must be > 0 and --reference-spp >= 0\n");
        return kExitBadInput;
    }
    int frame = 0;
    SceneDesc base;
    FrameBindings bindings;
    if (!prepare(ls, o.frame, o.scale, base, frame, bindings)) return kExitBadInput;
    installSignalHandlers();

    // the reference
    SceneDesc refScene;
    std::string refLabel;
    // march samples pixel centres; unless asked otherwise, so do the path-traced renders
    // (render.jitter only moves the camera ray within the pixel in pathtrace)
    const bool centres = !o.boxFilter;
    if (o.referenceSpp > 0) {
        refScene = base;
        refScene.render.integrator = Integrator::PathTrace;
        refScene.render.spp = o.referenceSpp;
        if (centres) refScene.render.jitter = false;
        refLabel = "pathtrace " + std::to_string(o.referenceSpp) + " spp" +
                   (centres ? ", pixel centres" : ", box filter");
    } else {
        refScene = withSteps(base, o.referenceStep);
        refScene.render.integrator = Integrator::March;
        char buf[64];
        std::snprintf(buf, sizeof buf, "march, step x %g", o.referenceStep);
        refLabel = buf;
    }
    Measured ref;
    double refNoise = 0.0;
    if (int rc = obtainReference(ls, refScene, bindings, frame, o.saveReference, o.loadReference,
                                 refLabel, ref, refNoise))
        return rc;
    const ImageError refSelf = imageError(ref.fb, ref.fb);
    const double refMean = refSelf.mean; // relative figures divide by it
    if (refMean > 0)
        std::fprintf(
            stderr,
            "reference noise (two halves): RMSE %.3g, %.2f%% relative over %zu cloud pixels\n",
            refNoise, 100.0 * refNoise / refMean, refSelf.pixels);

    // the rungs
    std::vector<Rung> rungs;
    for (double m : o.ladder) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "step x %g", m);
        Rung r{"march", buf, withSteps(base, m), m};
        r.scene.render.integrator = Integrator::March;
        rungs.push_back(r);
    }
    {
        // the other quality knobs of march, at the scene's own step
        Rung single{"march", "octaves 1", base, 1.0};
        single.scene.render.integrator = Integrator::March;
        single.scene.render.octaves = 1;
        if (base.render.octaves > 1) rungs.push_back(single);
        Rung other{"march", "", base, 1.0};
        other.scene.render.integrator = Integrator::March;
        other.scene.render.shadow =
            base.render.shadow == ShadowMethod::March ? ShadowMethod::Volume : ShadowMethod::March;
        other.label =
            other.scene.render.shadow == ShadowMethod::Volume ? "shadow volume" : "shadow march";
        if (base.sun.enabled) rungs.push_back(other);
    }
    for (int n : o.photonLadder) {
        Rung r{"march", "photons " + std::to_string(n), base, 1.0};
        r.scene.render.integrator = Integrator::March;
        r.scene.render.multipleScattering = MultipleScattering::Photons;
        r.scene.render.photons = n;
        r.scene.render.octaves = 1;
        r.scene.render.msStrength = 1.0f;
        rungs.push_back(r);
    }
    for (int spp : o.pathtraceLadder) {
        Rung r{"pathtrace", std::to_string(spp) + " spp", base, 1.0};
        r.scene.render.integrator = Integrator::PathTrace;
        r.scene.render.spp = spp;
        r.scene.render.seed = base.render.seed + 7919u; // independent of the reference
        if (centres) r.scene.render.jitter = false;
        rungs.push_back(r);
    }

    struct Row {
        const Rung* rung;
        Measured m;
        double err, rel;
    };
    std::vector<Row> rows;
    for (const Rung& r : rungs) {
        Row row{&r, {}, 0.0, 0.0};
        if (!measure(r.scene, bindings, frame, row.m)) return kExitInterrupted;
        row.err = imageError(row.m.fb, ref.fb).rmse;
        row.rel = refMean > 0 ? row.err / refMean : 0.0;
        std::fprintf(stderr, "  %-9s %-16s %8.3f s  rel. RMSE %6.2f%%\n", r.integrator.c_str(),
                     r.label.c_str(), row.m.seconds, 100.0 * row.rel);
        rows.push_back(std::move(row));
    }

    // table, CSV, plot
    std::ostringstream table, csv;
    table << "frame " << frame << ", " << base.camera.width << "x" << base.camera.height
          << ", clouds only (background transparent; relative RMSE over RGB of the cloud pixels, "
             "divided by the reference's mean there); reference: "
          << refLabel << ", " << ref.seconds << " s";
    if (refNoise > 0.0)
        table << ", its noise " << percent(refNoise / refMean)
              << " (from two halves; the last column takes it out in quadrature)";
    table << "\n";
    char line[320];
    std::snprintf(line, sizeof line,
                  "| %-9s | %-16s | %-8s | %-8s | %-11s | %-10s | %-9s | %-9s | %-9s |\n",
                  "integrator", "setting", "step", "spp", "lookups/ray", "time (s)", "RMSE",
                  "rel. RMSE", "corrected");
    table << line
          << "|------------|------------------|----------|----------|-------------|------------|---"
             "--------|-----------|-----------|\n";
    csv << "integrator,setting,step,shadow_step,octaves,shadow,spp,lookups_per_ray,seconds,rmse,"
           "relative_rmse,corrected_relative_rmse\n";
    for (const Row& r : rows) {
        const RenderDesc& rd = r.rung->scene.render;
        const bool pt = rd.integrator == Integrator::PathTrace;
        const double perRay =
            double(r.m.stats.lookups()) / std::max<double>(1.0, double(r.m.stats.rays));
        const double rel = refMean > 0 ? withoutNoise(r.err, refNoise) / refMean : 0.0;
        std::snprintf(
            line, sizeof line,
            "| %-9s | %-16s | %-8.4g | %-8s | %-11.1f | %-10.3f | %-9.3g | %-9s | %-9s |\n",
            r.rung->integrator.c_str(), r.rung->label.c_str(), pt ? 0.0 : r.m.step,
            pt ? std::to_string(rd.spp).c_str() : "-", perRay, r.m.seconds, r.err,
            percent(r.rel).c_str(), percent(rel).c_str());
        table << line;
        csv << r.rung->integrator << "," << r.rung->label << "," << (pt ? 0.0 : r.m.step) << ","
            << (pt ? 0.0 : r.m.shadowStep) << "," << (pt ? 0 : rd.octaves) << ","
            << (pt                                  ? "-"
                : rd.shadow == ShadowMethod::Volume ? "volume"
                                                    : "march")
            << "," << (pt ? rd.spp : 0) << "," << perRay << "," << r.m.seconds << "," << r.err
            << "," << r.rel << "," << rel << "\n";
    }
    // pathtrace's noise falls as 1 / sqrt(spp): from its largest rung, the samples (and time)
    // it needs to reach each march row's error, both with the reference noise taken out
    const Row* pt = nullptr;
    for (const Row& r : rows)
        if (r.rung->scene.render.integrator == Integrator::PathTrace &&
            (!pt || r.rung->scene.render.spp > pt->rung->scene.render.spp))
            pt = &r;
    if (pt && refMean > 0) {
        const double ptErr = withoutNoise(pt->err, refNoise);
        const double spp = pt->rung->scene.render.spp;
        const double secondsPerSpp = pt->m.seconds / spp;
        table << "\npathtrace to reach the error of each march row (noise ~ 1/sqrt(spp), from "
              << int(spp) << " spp: " << percent(ptErr / refMean) << "):\n";
        for (const Row& r : rows) {
            if (r.rung->scene.render.integrator != Integrator::March) continue;
            const double e = withoutNoise(r.err, refNoise);
            if (!(e > 0.0)) continue;
            const double need = spp * (ptErr / e) * (ptErr / e);
            std::snprintf(line, sizeof line,
                          "  march %-16s %7s in %7.3f s; pathtrace ~%8.1f spp, ~%9.3f s: %6.1fx\n",
                          r.rung->label.c_str(), percent(e / refMean).c_str(), r.m.seconds, need,
                          need * secondsPerSpp, need * secondsPerSpp / r.m.seconds);
            table << line;
        }
    }
    std::cout << table.str();
    std::string csvPath = o.csv;
    if (csvPath.empty()) csvPath = std::filesystem::path(o.scene).stem().string() + ".converge.csv";
    if (!writeText(csvPath, csv.str())) return kExitIo;
    std::fprintf(stderr, "wrote %s\n", csvPath.c_str());

    if (!o.plot.empty()) {
        // gnuplot draws relative RMSE against time on log-log axes, one series per integrator
        std::ostringstream gp;
        gp << "set terminal pngcairo size 800,500\nset output '" << o.plot << ".tmp.png'\n"
           << "set logscale xy\nset xlabel 'wall time (s)'\nset ylabel 'relative RMSE'\n"
           << "set grid\nset key top right\nset datafile separator ','\n"
           << "set title 'Error against run time (reference: " << refLabel << ")'\n"
           << "plot '" << csvPath << "' using ($9):(stringcolumn(1) eq 'march' ? $11 : 1/0) "
           << "with points pointsize 1.5 title 'march', '" << csvPath
           << "' using ($9):(stringcolumn(1) eq 'pathtrace' ? $11 : 1/0) with linespoints "
              "title 'pathtrace'\n";
        const std::string gpPath = o.plot + ".gp";
        if (!writeText(gpPath, gp.str())) return kExitIo;
        const std::string cmd = "gnuplot '" + gpPath + "' 2>&1";
        if (std::system(cmd.c_str()) != 0 ||
            std::rename((o.plot + ".tmp.png").c_str(), o.plot.c_str()) != 0) {
            std::fprintf(stderr,
                         "nimbus: error: gnuplot failed to write %s (is gnuplot installed?)\n",
                         o.plot.c_str());
            std::remove((o.plot + ".tmp.png").c_str());
            return kExitIo;
        }
        std::remove(gpPath.c_str());
        std::fprintf(stderr, "wrote %s\n", o.plot.c_str());
    }
    return kExitOk;
}

int runCalibrate(const CalibrateOptions& o) {
    LoadedScene ls;
    if (int rc = loadScene(o.scene, o.overrides, o.threads, ls)) return rc;
    if (!(o.scale > 0.0) || o.referenceSpp < 1) {
        std::fprintf(stderr, "nimbus: error: --scale must be > 0 and --reference-spp >= 1\n");
        return kExitBadInput;
    }
    int frame = 0;
    SceneDesc base;
    FrameBindings bindings;
    if (!prepare(ls, o.frame, o.scale, base, frame, bindings)) return kExitBadInput;
    base.render.integrator = Integrator::March;
    installSignalHandlers();
    SceneDesc refScene = base;
    refScene.render.integrator = Integrator::PathTrace;
    refScene.render.spp = o.referenceSpp;
    if (!o.boxFilter) refScene.render.jitter = false; // pixel centres, as march samples them
    std::string refLabel = "pathtrace " + std::to_string(o.referenceSpp) + " spp" +
                           (o.boxFilter ? ", box filter" : ", pixel centres");
    Measured ref;
    double refNoise = 0.0;
    if (int rc = obtainReference(ls, refScene, bindings, frame, o.saveReference, o.loadReference,
                                 refLabel, ref, refNoise))
        return rc;
    const double refMean = imageError(ref.fb, ref.fb).mean;

    int evaluations = 0;
    auto error = [&](const SceneDesc& s, double& out) {
        Measured m;
        if (!measure(s, bindings, frame, m)) return false;
        ++evaluations;
        out = imageError(m.fb, ref.fb).relative();
        return true;
    };
    SceneDesc best = base;
    const bool msModel = base.render.multipleScattering != MultipleScattering::None;
    if (best.render.octaves < 2 && !msModel) best.render.octaves = 4;
    double bestErr;
    double startErr;
    if (!error(base, startErr) || !error(best, bestErr)) return kExitInterrupted;
    if (startErr < bestErr) {
        best = base;
        bestErr = startErr;
    }
    // coordinate descent over the approximations of march that the scene uses, two passes
    // the keys tagged for calibration in the parameter table, with their grids of values
    const std::vector<io::CalibrationKnob> knobs = io::calibrationKnobs();
    for (int pass = 0; pass < 2; ++pass) {
        for (int octaves : {1, 2, 4, 8}) {
            SceneDesc s = best;
            s.render.octaves = octaves;
            if (octaves == best.render.octaves || (octaves == 1 && !msModel)) continue;
            double e;
            if (!error(s, e)) return kExitInterrupted;
            if (e < bestErr) {
                bestErr = e;
                best = s;
            }
        }
        for (const io::CalibrationKnob& k : knobs) {
            if (!k.applies(best)) continue;
            for (double v : k.values) {
                SceneDesc s = best;
                if (k.get(s) == v) continue;
                k.set(s, v);
                // energy conservation: contribution <= extinction
                if (s.render.octaveContribution > s.render.octaveExtinction) continue;
                double e;
                if (!error(s, e)) return kExitInterrupted;
                if (e < bestErr) {
                    bestErr = e;
                    best = s;
                }
            }
        }
        std::fprintf(stderr, "pass %d: rel. RMSE %.2f%%\n", pass + 1, 100.0 * bestErr);
    }
    const double noise = refNoise / std::max(refMean, 1e-30);
    std::printf("calibrated against %s (%dx%d, %d march renders; reference noise "
                "%.2f%%):\n  relative RMSE %.2f%% -> %.2f%% (%.2f%% -> %.2f%% without the "
                "reference noise)\n\n[render]\noctaves = %d\n",
                refLabel.c_str(), base.camera.width, base.camera.height, evaluations, 100.0 * noise,
                100.0 * startErr, 100.0 * bestErr, 100.0 * withoutNoise(startErr, noise),
                100.0 * withoutNoise(bestErr, noise), best.render.octaves);
    for (const char* section : {"render", "sky"}) {
        if (std::string(section) == "sky") std::printf("\n[sky]\n");
        const std::string prefix = std::string(section) + ".";
        for (const io::CalibrationKnob& k : knobs)
            if (k.key.rfind(prefix, 0) == 0 && k.applies(best))
                std::printf("%s = %g\n", k.key.substr(prefix.size()).c_str(), k.get(best));
    }
    return kExitOk;
}

} // namespace nimbus::cli
