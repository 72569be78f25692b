#include "plugin/cli/commands.h"

#include <atomic>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include <semaphore.h>
#include <thread>
#include <unistd.h>

#include "core/tracking/majorant.h"
#include "core/render.h"
#include "core/tracking/volumes.h"
#include "core/sdf/sdf.h"
#include "plugin/cli/common.h"
#include "plugin/io/atomic_file.h"
#include "plugin/io/color.h"
#include "plugin/io/frames.h"
#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"
#include "plugin/io/scene_setup.h"
#include "plugin/vdb/vdb_writer.h"

namespace nimbus::cli {

std::atomic<bool> gCancel{false};

namespace {

/// Posted by the first signal (sem_post is async-signal-safe); the watchdog waits on it.
sem_t gSignalled;

extern "C" void onSignal(int sig) {
    // first signal: stop rendering (the renderer polls gCancel inside its loops, core/cancel.h)
    // and remove partial outputs; a second one: leave at once
    const int savedErrno = errno;
    io::removeInFlightTempFiles();
    if (gCancel.exchange(true)) {
        std::signal(sig, SIG_DFL);
        std::raise(sig);
    }
    sem_post(&gSignalled);
    errno = savedErrno;
}

/// The last resort behind the cooperative stop: once a signal came, the process has
/// kCancelGraceSeconds to end by itself (it takes milliseconds: docs/stability.md); if it has
/// not, whatever it is stuck in (a library call that never polls gCancel), the temp files are
/// removed and it exits 130 with a message saying so.
void watchdog() {
    while (sem_wait(&gSignalled) != 0) {
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(kCancelGraceSeconds));
    io::removeInFlightTempFiles();
    std::fprintf(stderr,
                 "nimbus: interrupted; the work in flight did not stop within %.1f s of the "
                 "signal, exiting without it\n",
                 kCancelGraceSeconds);
    std::fflush(stderr);
    _exit(kExitInterrupted);
}

} // namespace

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

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::string clipped(const std::string& m) {
    constexpr std::size_t kMax = 8192, kHead = 6000, kTail = 1000;
    if (m.size() <= kMax) return m;
    return m.substr(0, kHead) + " [... " + std::to_string(m.size() - kHead - kTail) +
           " bytes left out ...] " + m.substr(m.size() - kTail);
}

void printWarnings(host::Session& s) {
    for (const auto& w : s.takeWarnings()) std::fprintf(stderr, "nimbus: %s\n", clipped(w).c_str());
}

int report(const host::Status& st) {
    if (st.ok()) return kExitOk;
    if (st.code == host::StatusCode::interrupted)
        std::fprintf(stderr, "nimbus: %s\n", clipped(st.message).c_str());
    else
        std::fprintf(stderr, "nimbus: error: %s\n", clipped(st.message).c_str());
    return host::exitCode(st.code);
}

int loadScene(const std::string& path, const std::vector<std::string>& overrides, int threads,
              LoadedScene& out) {
    const host::Status st = out.load(path, overrides, threads);
    printWarnings(out);
    return report(st);
}

bool bindFrame(LoadedScene& ls, int frame, FrameBindings& b) {
    const host::Status st = ls.bind(frame);
    printWarnings(ls);
    if (report(st)) return false;
    b = ls.bindings();
    return true;
}

namespace {

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

/// The frames of `cliSpec` (or of the scene's spec when empty); with several frames, every
/// non-empty output pattern must hold a frame token. Prints the error; false on bad input.
bool framesToRender(const std::string& cliSpec, const std::string& sceneSpec,
                    std::initializer_list<const std::string*> patterns, std::vector<int>& frames) {
    try {
        frames = io::parseFrameSpec(cliSpec.empty() ? sceneSpec : cliSpec);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: error: --frames: %s\n", e.what());
        return false;
    }
    if (frames.size() < 2) return true;
    for (const std::string* p : patterns)
        if (!p->empty() && !io::patternHasFrameToken(*p)) {
            std::fprintf(stderr,
                         "nimbus: error: %zu frames would all be written to \"%s\": add a frame "
                         "token (%s)\n",
                         frames.size(), p->c_str(), std::string(io::framePatternSyntax()).c_str());
            return false;
        }
    return true;
}

} // namespace

namespace {

/// A bake allocates one pointer per 8^3 block of its box: refuse boxes past this many voxels.
constexpr double kMaxBakeVoxels = 4294967296.0; // 2^32

/// The resolution of @p box at voxel size @p voxel, or an error naming @p what.
bool bakeResolution(const Box& box, float voxel, int frame, const char* what, ivec3& res) {
    const vec3 n = glm::ceil(box.extent() / voxel);
    if (!(double(n.x) * n.y * n.z <= kMaxBakeVoxels)) {
        std::fprintf(stderr,
                     "nimbus: error: frame %d: %s: %.3g x %.3g x %.3g voxels of %g is more than "
                     "the 2^32 a bake allows; give a larger --voxel or a smaller --box\n",
                     frame, what, double(n.x), double(n.y), double(n.z), double(voxel));
        return false;
    }
    res = glm::max(ivec3(n), ivec3(1));
    return true;
}

/// The level sets of the scene's [[solid]]s for frame @p frame: one grid per solid, "<name>"
/// for a single solid, "<name>_<n>" (n from 1, in file order) for several.
bool solidLevelSets(const SceneDesc& scene, const BakeOptions& o, float voxel, int firstFrame,
                    std::vector<vdb::LevelSetBake>& out, std::vector<std::string>& notes) {
    const float band = o.halfWidth * voxel;
    for (size_t i = 0; i < scene.solids.size(); ++i) {
        const std::string name = scene.solids.size() == 1
                                     ? o.levelSetGrid
                                     : o.levelSetGrid + "_" + std::to_string(i + 1);
        auto tree = std::make_shared<const SdfTree>(flattenSdf(scene.solids[i].root));
        // every point within the band (plus a voxel, for the sign around it) lies in this box
        const Box support = tree->supportBox(band + voxel);
        Box box = support;
        if (o.box) {
            box.lo = glm::max(box.lo, o.box->lo);
            box.hi = glm::min(box.hi, o.box->hi);
        }
        if (!sdfBoxBounded(box)) {
            std::fprintf(stderr,
                         "nimbus: error: %s: [[solid]] %zu is unbounded (a plane, or a union "
                         "holding one); give --box xmin,ymin,zmin,xmax,ymax,zmax to bake its "
                         "level set\n",
                         o.scene.c_str(), i + 1);
            return false;
        }
        if (box.empty()) {
            std::fprintf(stderr,
                         "nimbus: error: %s: [[solid]] %zu lies outside --box; nothing to "
                         "bake\n",
                         o.scene.c_str(), i + 1);
            return false;
        }
        ivec3 res;
        const std::string what = "level set \"" + name + "\"";
        if (!bakeResolution(box, voxel, firstFrame, what.c_str(), res)) return false;
        vdb::LevelSetBake l;
        l.name = name;
        l.resolution = res;
        l.voxelSize = voxel;
        // centred on the box; whole voxels
        l.worldOrigin = 0.5f * (box.lo + box.hi) - 0.5f * voxel * vec3(res - 1);
        l.halfWidth = o.halfWidth;
        l.distance = [tree](vec3 p) { return gCancel ? 0.0f : tree->distance(p); };
        l.bound = [tree](vec3 p) { return tree->bound(p); };
        l.slack = tree->displacementBound;
        // a surface the box cuts is open: meshing it to re-distance would lose its sign
        const bool cut = box.lo != support.lo || box.hi != support.hi;
        l.rebuild = !cut;
        if (cut) {
            notes.push_back(name + ": the box cuts the surface; distances are the SDF tree's own "
                                   "(a bound where it is smooth-blended or displaced)");
        }
        out.push_back(std::move(l));
    }
    return true;
}

} // namespace

int runBake(const BakeOptions& o) {
    LoadedScene ls;
    if (int rc = loadScene(o.scene, o.overrides, o.threads, ls)) return rc;
    const io::SceneFile& f = ls.file();
    if (o.levelSet && f.scene.solids.empty()) {
        std::fprintf(stderr,
                     "nimbus: error: %s: --level-set bakes the scene's [[solid]]s, and it has "
                     "none\n",
                     o.scene.c_str());
        return kExitBadInput;
    }
    std::vector<int> frames;
    if (!framesToRender(o.frames, f.frames, {&o.output}, frames)) return kExitBadInput;
    installSignalHandlers();
    // the solids do not move: their level sets are the same for every frame
    std::vector<vdb::LevelSetBake> sets;
    std::vector<std::string> notes;
    if (o.levelSet) {
        const float voxel =
            o.voxel > 0.0f ? o.voxel : ls.plan(frames.front(), AovSet{}).majorantCell;
        try {
            if (!solidLevelSets(f.scene, o, voxel, frames.front(), sets, notes))
                return kExitBadInput;
        } catch (const std::invalid_argument& e) {
            std::fprintf(stderr, "nimbus: error: %s\n", e.what());
            return kExitBadInput;
        }
    }
    for (int frame : frames) {
        FrameBindings bindings;
        if (!bindFrame(ls, frame, bindings)) return kExitBadInput;
        const FramePlan plan = ls.plan(frame, AovSet{});
        const Field field = ls.renderer().fieldFor(plan, bindings);
        const MajorantGrid grid = buildMajorantGrid(field, plan.majorantCell);
        const float voxel = o.voxel > 0.0f ? o.voxel : plan.majorantCell;
        const Box b = field.bounds();
        if (b.empty() && !o.levelSet) {
            std::fprintf(stderr, "nimbus: error: frame %d: the field is empty, nothing to bake\n",
                         frame);
            return kExitBadInput;
        }
        if (o.velocity && !field.motion.moving) {
            std::fprintf(stderr,
                         "nimbus: error: %s: frame %d: --velocity writes the field's motion, and "
                         "this field does not move (no wind: a cumulus or automaton without "
                         "`wind`, or a VDB or other still field); bake without --velocity\n",
                         o.scene.c_str(), frame);
            return kExitBadInput;
        }
        std::vector<vdb::FogBake> fogs;
        if (!b.empty()) {
            ivec3 res;
            if (!bakeResolution(b, voxel, frame, "the density", res)) return kExitBadInput;
            const vec3 size = b.extent() / vec3(res);
            vdb::FogBake fog;
            fog.name = o.grid;
            fog.resolution = res;
            fog.worldOrigin = b.lo + 0.5f * size;
            fog.voxelSize = size;
            // voxel centres; cells the majorant grid proves empty are not evaluated
            fog.density = [&](vec3 p) {
                if (gCancel) return 0.0f;
                const ivec3 c = glm::clamp(ivec3((p - grid.bounds.lo) / grid.cellSize), ivec3(0),
                                           grid.res - ivec3(1));
                return grid.at(c) > 0.0f ? field.density(p) : 0.0f;
            };
            if (o.velocity) {
                // the field's motion (core/fields/field.h): world units / s at each voxel centre
                fog.velocity = [&](vec3 p) {
                    return gCancel ? vec3(0.0f) : sim::velocityAt(field.motion.velocity, p);
                };
                fog.velocityName = o.velocityGrid;
            }
            fogs.push_back(std::move(fog));
        }
        const std::string out = io::expandFramePattern(o.output, frame);
        const auto t0 = std::chrono::steady_clock::now();
        try {
            const std::vector<vdb::VdbBakeStats> st = vdb::bakeVdb(out, fogs, sets);
            if (gCancel) {
                std::remove(out.c_str());
                return kExitInterrupted;
            }
            size_t k = 0;
            for (const vdb::FogBake& fog : fogs) {
                const vdb::VdbBakeStats& s = st[k++];
                std::fprintf(
                    stderr, "frame %d: \"%s\": %dx%dx%d voxels of %g, %llu active, max %g\n", frame,
                    fog.name.c_str(), fog.resolution.x, fog.resolution.y, fog.resolution.z,
                    double(voxel), (unsigned long long)s.activeVoxelCount, double(s.maxValue));
                if (fog.velocity) {
                    const vdb::VdbBakeStats& v = st[k++];
                    std::fprintf(stderr, "frame %d: \"%s\": %llu voxels, speed %g to %g units/s\n",
                                 frame, fog.velocityName.c_str(),
                                 (unsigned long long)v.activeVoxelCount, double(v.minValue),
                                 double(v.maxValue));
                }
            }
            for (const vdb::LevelSetBake& l : sets) {
                const vdb::VdbBakeStats& s = st[k++];
                std::fprintf(
                    stderr,
                    "frame %d: level set \"%s\": %dx%dx%d voxels of %g, %llu in a band "
                    "of %g voxels each side, %s\n",
                    frame, l.name.c_str(), l.resolution.x, l.resolution.y, l.resolution.z,
                    double(voxel), (unsigned long long)s.activeVoxelCount, double(l.halfWidth),
                    s.rebuilt ? "re-distanced from its surface" : "the SDF tree's distances");
            }
            for (const std::string& n : notes) std::fprintf(stderr, "  note: %s\n", n.c_str());
            std::fprintf(stderr, "frame %d: %.2f s -> %s\n", frame, secondsSince(t0), out.c_str());
        } catch (const std::exception& e) {
            std::fprintf(stderr, "nimbus: error: frame %d: %s\n", frame, e.what());
            return kExitIo;
        }
    }
    return kExitOk;
}

} // namespace nimbus::cli
