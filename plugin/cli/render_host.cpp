/// @file render_host.cpp
/// @brief `nimbus render`: a host of libnimbus.so. Scene loading and overrides, the plan
/// (--explain), each frame's render and write, --resume's check, progress, cancellation and
/// errors all go through the C ABI of plugin/capi/nimbus.h; this file includes no header of
/// core/ or plugin/io/ other than the frame-spec strings of plugin/io/frames.h (which the
/// `nimbus` executable itself also compiles). Built as libnimbus_render.so, which links
/// libnimbus.so and nothing of the internals; the executable loads it for `render` only
/// (plugin/cli/dispatch.h), so `--help` and `--version` stay fast.
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <semaphore.h>
#include <sys/resource.h>
#include <unistd.h>

#include "plugin/capi/nimbus.h"
#include "plugin/cli/commands.h"
#include "plugin/cli/dispatch.h"
#include "plugin/cli/progress.h"
#include "plugin/io/frames.h"

namespace nimbus::cli {
namespace {

std::atomic<bool> gCancel{false};
/// The context the signal handler cancels (nimbus_cancel is async-signal-safe).
std::atomic<nimbus_context*> gContext{nullptr};
/// JSON progress: every line the command writes to stderr is one JSON object.
std::atomic<bool> gJson{false};
sem_t gSignalled;

extern "C" void onSignal(int sig) {
    // first signal: stop rendering and remove partial outputs; a second one: leave at once
    const int savedErrno = errno;
    nimbus_discard_writes();
    if (gCancel.exchange(true)) {
        std::signal(sig, SIG_DFL);
        std::raise(sig);
    }
    if (nimbus_context* c = gContext.load()) nimbus_cancel(c);
    sem_post(&gSignalled);
    errno = savedErrno;
}

/// The last resort behind the cooperative stop (as plugin/cli/commands.cpp's watchdog): once a
/// signal came, the process has kCancelGraceSeconds to end by itself.
void watchdog() {
    while (sem_wait(&gSignalled) != 0) {
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(kCancelGraceSeconds));
    nimbus_discard_writes();
    if (gJson)
        std::fprintf(stderr,
                     "{\"event\":\"error\",\"exit_code\":%d,\"status\":\"interrupted\","
                     "\"message\":\"interrupted; the work in flight did not stop within %.1f s "
                     "of the signal, exiting without it\"}\n",
                     kExitInterrupted, kCancelGraceSeconds);
    else
        std::fprintf(stderr,
                     "nimbus: interrupted; the work in flight did not stop within %.1f s of the "
                     "signal, exiting without it\n",
                     kCancelGraceSeconds);
    std::fflush(stderr);
    _exit(kExitInterrupted);
}

void installSignalHandlers() {
    static bool installed = false;
    if (!installed) {
        installed = true;
        sem_init(&gSignalled, 0, 0);
        std::thread(watchdog).detach();
    }
    std::signal(SIGINT, onSignal);
    std::signal(SIGTERM, onSignal);
    std::signal(SIGHUP, onSignal);
}

std::string clipped(const std::string& m) {
    constexpr std::size_t kMax = 8192, kHead = 6000, kTail = 1000;
    if (m.size() <= kMax) return m;
    return m.substr(0, kHead) + " [... " + std::to_string(m.size() - kHead - kTail) +
           " bytes left out ...] " + m.substr(m.size() - kTail);
}

/// Peak resident set size of this process so far, MiB (getrusage; the VDB reader's child
/// process is not counted).
double peakRssMb() {
    rusage u{};
    if (getrusage(RUSAGE_SELF, &u) != 0) return 0.0;
    return double(u.ru_maxrss) / 1024.0; // Linux: kilobytes
}

/// Prints the lines of nimbus_warnings(): "nimbus: <line>" each, or a JSON warning event.
void printWarnings(nimbus_context* ctx) {
    const char* all = nimbus_warnings(ctx);
    if (!all) return;
    const std::string text = all;
    std::size_t start = 0;
    while (start < text.size()) {
        std::size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        const std::string line = text.substr(start, end - start);
        start = end + 1;
        if (line.empty()) continue;
        if (gJson) {
            // "warning: ..." lines (and "file:line:col: warning: ...") as they are
            JsonLine j("warning");
            j.str("message", clipped(line));
            j.print();
        } else {
            std::fprintf(stderr, "nimbus: %s\n", clipped(line).c_str());
        }
    }
}

/// A failed call's error, taken from the context at once (the next call clears it).
struct Failure {
    nimbus_status status = NIMBUS_OK;
    std::string message, file;
    int line = 0;
};

Failure failure(nimbus_context* ctx, nimbus_status st) {
    Failure f;
    f.status = st;
    if (st == NIMBUS_OK) return f;
    f.message = ctx ? nimbus_last_error(ctx) : "out of memory";
    if (ctx) {
        f.file = nimbus_last_error_file(ctx);
        f.line = nimbus_last_error_line(ctx);
    }
    return f;
}

/// Prints an error as the command always has ("nimbus: error: <message>", "nimbus: <message>"
/// for an interruption, "nimbus: internal error: ...; please report it" for a bug) or as a JSON
/// error event; returns the exit code (the status).
int report(const Failure& f) {
    if (f.status == NIMBUS_OK) return kExitOk;
    const std::string& m = f.message;
    if (gJson) {
        JsonLine j("error");
        j.num("exit_code", int(f.status));
        j.str("status", nimbus_status_name(f.status));
        j.str("message", clipped(m));
        if (!f.file.empty()) {
            j.str("file", f.file);
            j.num("line", f.line);
        }
        j.print();
    } else if (f.status == NIMBUS_INTERRUPTED) {
        std::fprintf(stderr, "nimbus: %s\n", clipped(m).c_str());
    } else if (f.status == NIMBUS_INTERNAL) {
        const std::string what = m.rfind("internal error", 0) == 0 ? m : "internal error: " + m;
        std::fprintf(stderr, "nimbus: %s; please report it\n", clipped(what).c_str());
    } else {
        std::fprintf(stderr, "nimbus: error: %s\n", clipped(m).c_str());
    }
    return int(f.status);
}

int report(nimbus_context* ctx, nimbus_status st) {
    return report(failure(ctx, st));
}

/// An error of the command itself (not of a library call).
int fail(int exitCode, const std::string& message) {
    if (gJson) {
        JsonLine j("error");
        j.num("exit_code", exitCode);
        j.str("status", nimbus_status_name(nimbus_status(exitCode)));
        j.str("message", clipped(message));
        j.print();
    } else {
        std::fprintf(stderr, "nimbus: error: %s\n", clipped(message).c_str());
    }
    return exitCode;
}

/// A note for the log (skipped frames, removed temp files): a line, or a JSON event.
void note(const std::string& text) {
    if (gJson) {
        JsonLine j("note");
        j.str("message", text);
        j.print();
    } else {
        std::fprintf(stderr, "%s\n", text.c_str());
    }
}

/// The frames of `cliSpec` (or of the scene's spec when empty); with several frames, every
/// non-empty output pattern must hold a frame token. Prints the error; false on bad input.
bool framesToRender(const std::string& cliSpec, const std::string& sceneSpec,
                    const std::vector<std::string>& patterns, std::vector<int>& frames) {
    try {
        frames = io::parseFrameSpec(cliSpec.empty() ? sceneSpec : cliSpec);
    } catch (const std::exception& e) {
        fail(kExitBadInput, std::string("--frames: ") + e.what());
        return false;
    }
    if (frames.size() < 2) return true;
    for (const std::string& p : patterns)
        if (!p.empty() && !io::patternHasFrameToken(p)) {
            fail(kExitBadInput,
                 std::to_string(frames.size()) + " frames would all be written to \"" + p +
                     "\": add a frame token (" + std::string(io::framePatternSyntax()) + ")");
            return false;
        }
    return true;
}

/// What the progress callback of the ABI needs.
struct Tracker {
    Progress* progress;
    int index, frame;
};

extern "C" int onProgress(void* user, int done, int total) {
    const Tracker* t = static_cast<const Tracker*>(user);
    t->progress->update(t->index, t->frame, double(done) / total);
    return gCancel ? 1 : 0;
}

double stat(nimbus_context* ctx, nimbus_stat item) {
    double v = 0.0;
    nimbus_render_stat(ctx, item, &v);
    return v;
}

/// The per-frame log line (not in JSON mode), from the last render's statistics.
void printFrameLine(nimbus_context* ctx, int frame, double seconds, const std::string& out) {
    const double lookups = stat(ctx, NIMBUS_STAT_LOOKUPS);
    const double integrate = stat(ctx, NIMBUS_STAT_INTEGRATE_SECONDS);
    char grids[640] = "";
    auto append = [&](const char* fmt, double a = 0.0, double b = 0.0) {
        const std::size_t n = std::strlen(grids);
        std::snprintf(grids + n, sizeof grids - n, fmt, a, b);
    };
    if (double n = stat(ctx, NIMBUS_STAT_SIMULATION_STEPS); n > 0.0)
        append(", simulation %.0f steps %.2f s", n, stat(ctx, NIMBUS_STAT_SIMULATION_SECONDS));
    // render.multiple_scattering = "auto": what it chose, and the depth it chose by
    if (double d = stat(ctx, NIMBUS_STAT_CLOUD_DEPTH); d >= 0.0) {
        append(stat(ctx, NIMBUS_STAT_PHOTON_SECONDS) > 0.0 ? ", auto: photons"
                                                           : ", auto: the grid");
        // depths as the plan's notes show them (core depthText): whole numbers from 1000
        auto depth = [](double x) { return std::string(x < 1000.0 ? "%.3g" : "%.0f"); };
        if (double a = stat(ctx, NIMBUS_STAT_ABSORPTION_DEPTH); a >= 0.0)
            append((" (the depth absorption lets light reach " + depth(a) +
                    ", the cloud's along the sun " + depth(d) + ")")
                       .c_str(),
                   a, d);
        else
            append((" (the cloud's depth along the sun " + depth(d) + ")").c_str(), d);
    }
    if (double s = stat(ctx, NIMBUS_STAT_LIGHT_VOLUME_SECONDS); s > 0.0)
        append(", light grids %.2f s (%.0f MB)", s, stat(ctx, NIMBUS_STAT_LIGHT_GRID_MB));
    if (double s = stat(ctx, NIMBUS_STAT_DIFFUSION_SECONDS); s > 0.0)
        append(", diffusion %.2f s (%.1f MB)", s, stat(ctx, NIMBUS_STAT_DIFFUSION_MB));
    if (double s = stat(ctx, NIMBUS_STAT_PHOTON_SECONDS); s > 0.0) {
        append(", photons %.2f s (%.0f traced", s, stat(ctx, NIMBUS_STAT_PHOTONS));
        if (double n = stat(ctx, NIMBUS_STAT_PHOTON_SCATTERINGS); n >= 1e7)
            append(", %.0f M scatterings", 1e-6 * n, 0.0);
        else
            append(", %.0f scatterings", n, 0.0);
        append(", %.1f MB", stat(ctx, NIMBUS_STAT_PHOTON_MB), 0.0);
        if (double n = stat(ctx, NIMBUS_STAT_PHOTONS_FROM_SKY); n > 0.0)
            append(", %.0f from the sky", n, 0.0);
        if (double n = stat(ctx, NIMBUS_STAT_PHOTONS_HANDED_OFF); n > 0.0)
            append(", %.0f handed to the grid", n, 0.0);
        append(")", 0.0);
    }
    if (double s = stat(ctx, NIMBUS_STAT_SKY_VOLUME_SECONDS); s > 0.0)
        append(", sky volume %.2f s (%.0f MB)", s, stat(ctx, NIMBUS_STAT_SKY_VOLUME_MB));
    // the integrator's own time, by its name
    int integrator = 0;
    nimbus_plan_int(ctx, frame, NIMBUS_PLAN_INTEGRATOR, &integrator);
    std::fprintf(stderr,
                 "frame %d: %.2f s (noise %s, bake %.2f s, majorant %.2f s%s, %s %.2f s), "
                 "%.1f M density lookups (%.1f M/s, %.0f%% in shadow rays), "
                 "%.0f%% of majorant cells empty%s, peak RSS %.0f MB -> %s\n",
                 frame, seconds, stat(ctx, NIMBUS_STAT_BAKED_NOISE) != 0.0 ? "baked" : "direct",
                 stat(ctx, NIMBUS_STAT_BAKE_SECONDS), stat(ctx, NIMBUS_STAT_MAJORANT_SECONDS),
                 grids, integrator == 1 ? "pathtrace" : "march", integrate, lookups * 1e-6,
                 lookups * 1e-6 / std::max(integrate, 1e-9),
                 100.0 * stat(ctx, NIMBUS_STAT_SHADOW_LOOKUPS) / std::max(lookups, 1.0),
                 100.0 * stat(ctx, NIMBUS_STAT_MAJORANT_EMPTY_FRACTION),
                 stat(ctx, NIMBUS_STAT_MAJORANT_USED) != 0.0 ? "" : " (grid not used: too full)",
                 peakRssMb(), out.c_str());
}

/// Owns the context for the command's lifetime; the signal handler sees it while it lives.
struct Context {
    nimbus_context* ctx = nimbus_create();
    Context() { gContext.store(ctx); }
    ~Context() {
        gContext.store(nullptr);
        nimbus_destroy(ctx);
    }
};

std::string str(const char* s) {
    return s ? s : "";
}

int render(const RenderOptions& o) {
    gJson = o.progress == "json"; // with -q too: errors and warnings are then JSON
    Context holder;
    nimbus_context* ctx = holder.ctx;
    if (!ctx) return fail(kExitNoMemory, "out of memory");

    // load: the scene file with the --set overrides (one load), --threads
    if (o.threads >= 0)
        if (nimbus_status st = nimbus_set_threads(ctx, o.threads)) return report(ctx, st);
    std::vector<const char*> assignments;
    for (const std::string& a : o.overrides) assignments.push_back(a.c_str());
    const Failure loaded =
        failure(ctx, nimbus_load_file_with(ctx, o.scene.c_str(), assignments.data(),
                                           int(assignments.size())));
    printWarnings(ctx);
    if (loaded.status != NIMBUS_OK) return report(loaded);
    if (!o.output.empty())
        if (nimbus_status st = nimbus_set_output(ctx, o.output.c_str())) return report(ctx, st);
    const std::string pattern = str(nimbus_scene_string(ctx, NIMBUS_SCENE_OUTPUT_PATTERN));
    const std::string preview = str(nimbus_scene_string(ctx, NIMBUS_SCENE_PREVIEW_PATTERN));
    if (pattern.size() < 4 || pattern.substr(pattern.size() - 4) != ".exr")
        return fail(kExitBadInput, "output path \"" + pattern + "\" must end in .exr");
    std::vector<int> frames;
    if (!framesToRender(o.frames, str(nimbus_scene_string(ctx, NIMBUS_SCENE_FRAMES)),
                        {pattern, preview}, frames))
        return kExitBadInput;

    if (o.explain) {
        // planned without reading grids (a VDB field's grid is not read for --explain)
        std::printf("scene %s\ncolour: %s, working space %s, output %s\n",
                    str(nimbus_scene_string(ctx, NIMBUS_SCENE_PATH)).c_str(),
                    str(nimbus_scene_string(ctx, NIMBUS_SCENE_COLOR_CONFIG)).c_str(),
                    str(nimbus_scene_string(ctx, NIMBUS_SCENE_WORKING_SPACE)).c_str(),
                    str(nimbus_scene_string(ctx, NIMBUS_SCENE_OUTPUT_SPACE)).c_str());
        for (int frame : frames) {
            const std::string plan = str(nimbus_plan_explain(ctx, frame));
            if (plan.empty() && nimbus_last_error_code(ctx) != NIMBUS_OK)
                return report(ctx, nimbus_last_error_code(ctx));
            std::printf("%s  output: %s\n", plan.c_str(),
                        str(nimbus_output_path(ctx, frame)).c_str());
        }
        return kExitOk;
    }

    installSignalHandlers();
    {
        // temp files a SIGKILLed run of these frames left (with or without --resume)
        int stale = 0;
        if (nimbus_status st =
                nimbus_remove_stale_temp_files(ctx, frames.data(), int(frames.size()), &stale))
            return report(ctx, st);
        if (stale && !o.quiet)
            note("removed " + std::to_string(stale) + " temp file(s) of interrupted runs");
    }
    const ProgressMode mode = o.quiet                 ? ProgressMode::None
                              : o.progress == "bar"   ? ProgressMode::Bar
                              : o.progress == "plain" ? ProgressMode::Plain
                              : o.progress == "json"  ? ProgressMode::Json
                              : o.progress == "none"  ? ProgressMode::None
                                                      : ProgressMode::Auto;
    Progress progress(mode, int(frames.size()));
    double totalSeconds = 0.0;
    int rendered = 0;
    for (size_t k = 0; k < frames.size(); ++k) {
        const int frame = frames[k];
        const std::string out = str(nimbus_output_path(ctx, frame));
        if (o.resume) {
            int state = NIMBUS_OUTPUT_ABSENT;
            const char* why = nullptr;
            if (nimbus_status st = nimbus_output_check(ctx, frame, nullptr, &state, &why))
                return report(ctx, st);
            if (state == NIMBUS_OUTPUT_CURRENT) {
                progress.finishLine();
                if (gJson && !o.quiet) {
                    JsonLine j("frame_skipped");
                    j.num("frame", frame);
                    j.str("output", out);
                    j.str("reason", "a complete frame of this scene exists (--resume)");
                    j.print();
                } else if (!o.quiet) {
                    std::fprintf(stderr, "frame %d: %s exists, skipped (--resume)\n", frame,
                                 out.c_str());
                }
                continue;
            }
            if (state == NIMBUS_OUTPUT_STALE && !o.quiet) {
                progress.finishLine();
                if (gJson) {
                    JsonLine j("frame_rerender");
                    j.num("frame", frame);
                    j.str("output", out);
                    j.str("reason", str(why));
                    j.print();
                } else {
                    std::fprintf(stderr,
                                 "frame %d: %s exists but %s: rendering it again (--resume)\n",
                                 frame, out.c_str(), str(why).c_str());
                }
            }
        }
        // the grids of the frame (a VDB field: only the named grid of that frame's file)
        const Failure bound = failure(ctx, nimbus_prepare(ctx, frame));
        printWarnings(ctx);
        if (bound.status != NIMBUS_OK) return report(bound);
        int nWarnings = 0;
        nimbus_plan_int(ctx, frame, NIMBUS_PLAN_WARNINGS, &nWarnings);
        for (int i = 0; i < nWarnings; ++i) {
            const std::string w = str(nimbus_plan_warning(ctx, frame, i));
            progress.finishLine();
            if (gJson) {
                JsonLine j("warning");
                j.num("frame", frame);
                j.str("message", w);
                j.print();
            } else {
                std::fprintf(stderr, "nimbus: warning: frame %d: %s\n", frame, w.c_str());
            }
        }
        if (gJson && !o.quiet) {
            JsonLine j("frame_start");
            j.num("frame", frame);
            j.num("index", int(k));
            j.num("frames", int(frames.size()));
            j.str("output", out);
            j.print();
        }
        progress.update(int(k), frame, 0.0);
        Tracker tracker{&progress, int(k), frame};
        if (nimbus_status st = nimbus_set_progress(ctx, onProgress, &tracker))
            return report(ctx, st);
        if (gCancel) {
            progress.finishLine();
            Failure f;
            f.status = NIMBUS_INTERRUPTED;
            f.message =
                "interrupted during frame " + std::to_string(frame) + "; no output written for it";
            return report(f);
        }
        const Failure written = failure(ctx, nimbus_render_write(ctx, frame, nullptr));
        const nimbus_status result = written.status;
        nimbus_set_progress(ctx, nullptr, nullptr);
        const double seconds = stat(ctx, NIMBUS_STAT_SECONDS);
        if (result != NIMBUS_OK) progress.finishLine();
        printWarnings(ctx);
        if (result != NIMBUS_OK) {
            nimbus_discard_writes();
            if (result == NIMBUS_INTERRUPTED) return report(written);
            if (gCancel && result == NIMBUS_IO) {
                // the signal's handler removed the temp file under the writer: an interruption,
                // not an I/O error
                Failure f;
                f.status = NIMBUS_INTERRUPTED;
                f.message = "interrupted while writing frame " + std::to_string(frame) +
                            "; no output written for it";
                report(f);
                return kExitInterrupted;
            }
            return report(written);
        }
        if (gCancel) {
            progress.finishLine();
            return kExitInterrupted;
        }
        progress.update(int(k), frame, 1.0);
        totalSeconds += seconds;
        ++rendered;
        if (gJson) {
            if (!o.quiet) {
                JsonLine j("frame_done");
                j.num("frame", frame);
                j.str("output", out);
                j.num("seconds", seconds);
                j.num("peak_rss_mb", peakRssMb());
                j.num("lookups", stat(ctx, NIMBUS_STAT_LOOKUPS));
                j.print();
            }
        } else if (!o.quiet) {
            progress.finishLine();
            printFrameLine(ctx, frame, seconds, out);
        }
    }
    progress.finishLine();
    if (gJson && !o.quiet) {
        JsonLine j("done");
        j.num("frames_rendered", rendered);
        j.num("frames_skipped", int(frames.size()) - rendered);
        j.num("seconds", totalSeconds);
        j.num("peak_rss_mb", peakRssMb());
        j.print();
    } else if (!o.quiet && rendered > 1) {
        std::fprintf(stderr, "%d frames in %s (%.2f s per frame)\n", rendered,
                     formatDuration(totalSeconds).c_str(), totalSeconds / rendered);
    }
    return kExitOk;
}

/// The last resort for an exception that reaches std::terminate (as dispatch.cpp's).
[[noreturn]] void onTerminate() {
    nimbus_discard_writes();
    std::string what = "no exception";
    if (std::exception_ptr e = std::current_exception()) {
        try {
            std::rethrow_exception(e);
        } catch (const std::exception& ex) {
            what = ex.what();
        } catch (...) {
            what = "an exception that is not a std::exception";
        }
    }
    std::fprintf(stderr, "nimbus: internal error: unhandled (%s); please report it\n",
                 what.c_str());
    std::fflush(stderr);
    _exit(kExitInternal);
}

} // namespace
} // namespace nimbus::cli

using namespace nimbus::cli;

extern "C" __attribute__((visibility("default"))) int nimbus_cli_render(const void* options) {
    std::set_terminate(onTerminate);
    try {
        // NIMBUS_TEST_FAULT=thread (tests/test_stability.cpp): an exception on a thread of its
        // own reaches std::terminate
        if (const char* f = std::getenv("NIMBUS_TEST_FAULT"); f && std::string(f) == "thread")
            std::thread([] {
                throw std::runtime_error("test fault on a thread of its own");
            }).join();
        return render(*static_cast<const RenderOptions*>(options));
    } catch (const std::bad_alloc&) {
        nimbus_discard_writes();
        return fail(kExitNoMemory, "out of memory");
    } catch (const std::exception& e) {
        nimbus_discard_writes();
        Failure f;
        f.status = NIMBUS_INTERNAL;
        f.message = e.what();
        return report(f);
    } catch (...) {
        nimbus_discard_writes();
        Failure f;
        f.status = NIMBUS_INTERNAL;
        f.message = "an exception that is not a std::exception";
        return report(f);
    }
}
