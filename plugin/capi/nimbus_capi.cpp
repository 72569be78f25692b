/// @file nimbus_capi.cpp
/// @brief The C ABI (nimbus.h) over the render session (plugin/host/session.h). Every entry
/// point is noexcept and catches everything: no C++ exception crosses the ABI. Built into
/// libnimbus.so with hidden visibility and a version script (nimbus.map) exporting nimbus_*.
#include "plugin/capi/nimbus.h"

#include <cstring>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "plugin/host/session.h"
#include "plugin/io/atomic_file.h"
#include "plugin/io/frames.h"
#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"

#ifndef NIMBUS_VERSION
#error "NIMBUS_VERSION must be defined by the build (the project version)"
#endif
#if defined(NIMBUS_PROJECT_VERSION_MAJOR)
static_assert(NIMBUS_PROJECT_VERSION_MAJOR == NIMBUS_VERSION_MAJOR &&
                  NIMBUS_PROJECT_VERSION_MINOR == NIMBUS_VERSION_MINOR &&
                  NIMBUS_PROJECT_VERSION_PATCH == NIMBUS_VERSION_PATCH,
              "nimbus.h's NIMBUS_VERSION_* must equal the project version in CMakeLists.txt");
#endif

using namespace nimbus;

/// One loaded scene and what the C caller set around it.
struct nimbus_context {
    /// The loaded scene, null before the first successful load.
    std::unique_ptr<host::Session> session;
    bool fromFile = false;
    std::string source; ///< the path (fromFile) or the scene text
    std::string name;   ///< the path, or the name standing for the text
    std::vector<std::string> overrides;

    nimbus_progress_fn progress = nullptr;
    void* user = nullptr;
    std::atomic<bool> cancel{false};
    std::atomic<bool> busy{false}; ///< a call is running on the context

    nimbus_status code = NIMBUS_OK;
    std::string message, file;
    int line = 0;
    /// The message could not be stored (no memory): the accessors report "out of memory".
    bool messageLost = false;

    std::vector<std::string> warnings; ///< taken from sessions, not yet returned
    std::string explainText, outputPathText, warningsText, sceneString, planWarningText, whyText;

    int threads = -1;                  ///< nimbus_set_threads (-1: the scene's)
    std::optional<std::string> output; ///< nimbus_set_output
    /// The last render's statistics (nimbus_render_stat).
    RenderStats stats;
    double seconds = 0.0;
    bool bakedNoise = false;
};

namespace {

nimbus_status toStatus(host::StatusCode c) {
    switch (c) {
    case host::StatusCode::ok:
        return NIMBUS_OK;
    case host::StatusCode::bad_input:
        return NIMBUS_BAD_INPUT;
    case host::StatusCode::io:
        return NIMBUS_IO;
    case host::StatusCode::no_memory:
        return NIMBUS_NO_MEMORY;
    case host::StatusCode::interrupted:
        return NIMBUS_INTERRUPTED;
    case host::StatusCode::internal:
        return NIMBUS_INTERNAL;
    }
    return NIMBUS_INTERNAL;
}

void clearError(nimbus_context* ctx) noexcept {
    ctx->code = NIMBUS_OK;
    ctx->message.clear(); // clear() never allocates
    ctx->file.clear();
    ctx->line = 0;
    ctx->messageLost = false;
}

nimbus_status setError(nimbus_context* ctx, nimbus_status code, const char* message,
                       const std::string* file = nullptr, int line = 0) noexcept {
    ctx->code = code;
    ctx->line = line;
    try {
        ctx->message = message;
        if (file)
            ctx->file = *file;
        else
            ctx->file.clear();
        ctx->messageLost = false;
    } catch (...) {
        ctx->message.clear();
        ctx->file.clear();
        ctx->messageLost = true;
    }
    return code;
}

nimbus_status setError(nimbus_context* ctx, const host::Status& st) noexcept {
    return setError(ctx, toStatus(st.code), st.message.c_str(), &st.file, st.line);
}

/// Thrown inside an entry point for a misused call; becomes NIMBUS_BAD_INPUT.
struct Misuse : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Runs `f` (returning nimbus_status) on `ctx` with the context marked busy, its error cleared,
/// and every exception turned into a status.
template <class F> nimbus_status guarded(nimbus_context* ctx, F&& f) noexcept {
    if (!ctx) return NIMBUS_BAD_INPUT;
    if (ctx->busy.exchange(true)) return NIMBUS_BAD_INPUT; // another call runs on it
    struct Release {
        nimbus_context* c;
        ~Release() { c->busy.store(false); }
    } release{ctx};
    clearError(ctx);
    try {
        return f();
    } catch (const Misuse& e) {
        return setError(ctx, NIMBUS_BAD_INPUT, e.what());
    } catch (const std::bad_alloc&) {
        return setError(ctx, NIMBUS_NO_MEMORY, "out of memory");
    } catch (const std::exception& e) {
        // setError copies the message; a failed copy is recorded as a lost message
        try {
            const std::string m = std::string("internal error: ") + e.what();
            return setError(ctx, NIMBUS_INTERNAL, m.c_str());
        } catch (...) {
            return setError(ctx, NIMBUS_INTERNAL, "internal error");
        }
    } catch (...) {
        return setError(ctx, NIMBUS_INTERNAL,
                        "internal error: an exception that is not a std::exception");
    }
}

/// The same for entry points returning a context-owned string: NULL on failure.
template <class F> const char* guardedString(nimbus_context* ctx, F&& f) noexcept {
    const char* out = nullptr;
    const nimbus_status st = guarded(ctx, [&] {
        out = f();
        return NIMBUS_OK;
    });
    return st == NIMBUS_OK ? out : nullptr;
}

host::Session& loadedSession(nimbus_context* ctx) {
    if (!ctx->session) throw Misuse("no scene loaded: call nimbus_load_file or nimbus_load_string");
    return *ctx->session;
}

void takeWarnings(nimbus_context* ctx, host::Session& s) {
    for (std::string& w : s.takeWarnings()) ctx->warnings.push_back(std::move(w));
}

/// Loads (fromFile ? the file at `source` : the text `source` named `name`) with `overrides`
/// into a new session; on success it replaces the context's scene, else the context keeps its
/// scene and the error is set.
nimbus_status loadInto(nimbus_context* ctx, bool fromFile, const std::string& source,
                       const std::string& name, const std::vector<std::string>& overrides) {
    auto next = std::make_unique<host::Session>();
    const host::Status st = fromFile ? next->load(source, overrides, ctx->threads)
                                     : next->loadString(source, name, overrides, ctx->threads);
    takeWarnings(ctx, *next);
    if (!st.ok()) return setError(ctx, st);
    if (ctx->output) next->file().output.path = *ctx->output;
    ctx->session = std::move(next);
    ctx->fromFile = fromFile;
    ctx->source = source;
    ctx->name = name;
    ctx->overrides = overrides;
    return NIMBUS_OK;
}

/// Loads the context's scene again with `overrides`, or (no scene) checks them against the
/// default scene; on success they become the context's.
nimbus_status applyOverrides(nimbus_context* ctx, const std::vector<std::string>& overrides) {
    if (ctx->session) return loadInto(ctx, ctx->fromFile, ctx->source, ctx->name, overrides);
    host::Session check;
    const host::Status st = check.loadString("", "<default scene>", overrides);
    check.takeWarnings();
    if (!st.ok()) return setError(ctx, st);
    ctx->overrides = overrides;
    return NIMBUS_OK;
}

const char* nonNull(const char* s, const char* what) {
    if (!s) throw Misuse(std::string(what) + " is NULL");
    return s;
}

/// A layer's buffer, checked.
struct Target {
    nimbus_aov aov;
    float* data;
    size_t count;
};

/// Flips the scene's output AOVs to `want` for the scope of one render.
struct AovScope {
    io::OutputDesc& out;
    AovSet saved;
    AovScope(io::OutputDesc& o, const AovSet& want) : out(o), saved(o.aovs) { out.aovs = want; }
    ~AovScope() { out.aovs = saved; }
};

/// NIMBUS_TEST_FAULT (tests/test_capi.cpp, as for the command: plugin/cli/commands.cpp):
/// `worker` throws an int from a render worker, `bad-alloc` / `std` throw std::bad_alloc /
/// std::runtime_error there.
int testFault() {
    const char* f = std::getenv("NIMBUS_TEST_FAULT");
    if (!f) return 0;
    const std::string s = f;
    return s == "worker" ? 1 : s == "bad-alloc" ? 2 : s == "std" ? 3 : 0;
}

/// Renders `frame` with the scene's output AOVs set to `aovs` (when given) into fb.
nimbus_status renderFrame(nimbus_context* ctx, int frame, const AovSet* aovs, Framebuffer& fb,
                          RenderStats& stats, FramePlan& plan, double& seconds) {
    host::Session& s = loadedSession(ctx);
    ctx->cancel.store(false);
    const nimbus_progress_fn fn = ctx->progress;
    void* const user = ctx->user;
    const int fault = testFault();
    host::ProgressFn progress;
    if (fn || fault)
        progress = [ctx, fn, user, fault](int done, int total) {
            if (fault == 1) throw 42;
            if (fault == 2) throw std::bad_alloc();
            if (fault == 3) throw std::runtime_error("test fault in a worker");
            if (fn && fn(user, done, total) != 0) ctx->cancel.store(true);
        };
    std::optional<AovScope> scope;
    if (aovs) scope.emplace(s.file().output, *aovs);
    const auto t0 = std::chrono::steady_clock::now();
    const host::Status st = s.render(frame, fb, stats, progress, &ctx->cancel, &plan);
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ctx->stats = stats;
    ctx->seconds = seconds;
    ctx->bakedNoise = plan.bakeNoise;
    takeWarnings(ctx, s);
    if (!st.ok()) return setError(ctx, st);
    return NIMBUS_OK;
}

nimbus_status renderInto(nimbus_context* ctx, int frame, const nimbus_buffer* buffers, int n) {
    host::Session& s = loadedSession(ctx);
    if (n < 0) throw Misuse("negative buffer count");
    if (n > 0 && !buffers) throw Misuse("buffers is NULL");
    const size_t pixels = size_t(s.scene().camera.width) * size_t(s.scene().camera.height);
    std::vector<Target> targets;
    AovSet want;
    bool seen[3] = {false, false, false};
    for (int i = 0; i < n; ++i) {
        const nimbus_buffer& b = buffers[i];
        const int ch = nimbus_aov_channels(b.aov);
        if (ch == 0)
            throw Misuse("buffer " + std::to_string(i) + ": unknown layer " +
                         std::to_string(b.aov));
        if (seen[b.aov])
            throw Misuse("buffer " + std::to_string(i) + ": layer " + std::to_string(b.aov) +
                         " given twice");
        seen[b.aov] = true;
        if (!b.data) throw Misuse("buffer " + std::to_string(i) + ": data is NULL");
        if (b.count < pixels * size_t(ch))
            throw Misuse("buffer " + std::to_string(i) + ": " + std::to_string(b.count) +
                         " floats, the frame needs " + std::to_string(pixels * size_t(ch)) + " (" +
                         std::to_string(s.scene().camera.width) + " x " +
                         std::to_string(s.scene().camera.height) + " x " + std::to_string(ch) +
                         ")");
        if (b.aov == NIMBUS_AOV_TRANSMITTANCE) want.transmittance = true;
        if (b.aov == NIMBUS_AOV_DEPTH) want.depth = true;
        targets.push_back({nimbus_aov(b.aov), b.data, b.count});
    }
    Framebuffer fb;
    RenderStats stats;
    FramePlan plan;
    double seconds = 0.0;
    const nimbus_status st = renderFrame(ctx, frame, &want, fb, stats, plan, seconds);
    // an interrupted frame is handed over as far as it got
    if (st != NIMBUS_OK && st != NIMBUS_INTERRUPTED) return st;
    for (const Target& t : targets) {
        const std::vector<float>& src = t.aov == NIMBUS_AOV_RGBA            ? fb.rgba
                                        : t.aov == NIMBUS_AOV_TRANSMITTANCE ? fb.transmittance
                                                                            : fb.depth;
        if (src.size() > t.count)
            return setError(ctx, NIMBUS_INTERNAL,
                            "internal error: the frame is larger than "
                            "its camera");
        std::copy(src.begin(), src.end(), t.data);
    }
    return st;
}

std::string sceneText(const nimbus_context* ctx) {
    if (!ctx->fromFile) return ctx->source;
    std::ifstream in(ctx->source, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

nimbus_status renderWrite(nimbus_context* ctx, int frame, const char* path) {
    host::Session& s = loadedSession(ctx);
    io::OutputDesc& out = s.file().output;
    const std::string savedPath = out.path;
    if (path) {
        const std::string p = path;
        if (p.size() < 4 || p.substr(p.size() - 4) != ".exr")
            throw Misuse("output path \"" + p + "\" must end in .exr");
        out.path = p;
    }
    struct Restore {
        io::OutputDesc& o;
        const std::string& p;
        ~Restore() { o.path = p; }
    } restore{out, savedPath};
    Framebuffer fb;
    RenderStats stats;
    FramePlan plan;
    double seconds = 0.0;
    if (nimbus_status st = renderFrame(ctx, frame, nullptr, fb, stats, plan, seconds)) return st;
    // the metadata the command writes (plugin/cli/commands.cpp, settingsOf)
    io::ExrMetadata md;
    md.settings = io::sceneSettings(s.file());
    md.settings["scene"] = s.file().path;
    md.settings["scene_file"] = sceneText(ctx);
    std::string ov;
    for (const std::string& o : ctx->overrides) ov += (ov.empty() ? "" : " ") + o;
    md.settings["overrides"] = ov;
    md.settings["plan"] = plan.explain();
    md.seed = s.scene().render.seed;
    md.renderSeconds = seconds;
    const host::Status st = s.writeFrame(frame, fb, md, stats.nonFinite);
    takeWarnings(ctx, s);
    if (!st.ok()) return setError(ctx, st);
    return NIMBUS_OK;
}

/// The value a C caller passed for an enum parameter, read from its bytes: C lets any int
/// arrive there, and in C++ loading a value outside the enumerators' range through the enum type
/// is undefined (UBSan: "load of value 99, which is not a valid value for type
/// 'nimbus_plan_item'"). The switches below take the int and refuse what they do not know.
template <class E> int enumValue(const E& e) {
    static_assert(sizeof(E) == sizeof(int), "the C ABI's enums are int-sized");
    int v;
    std::memcpy(&v, &e, sizeof v);
    return v;
}

int planItem(const FramePlan& p, const SceneDesc& scene, bool readsGrids, int item) {
    switch (item) {
    case NIMBUS_PLAN_WIDTH:
        return scene.camera.width;
    case NIMBUS_PLAN_HEIGHT:
        return scene.camera.height;
    case NIMBUS_PLAN_INTEGRATOR:
        return p.pathtrace ? 1 : 0;
    case NIMBUS_PLAN_SHADOWS:
        return p.shadows;
    case NIMBUS_PLAN_AMBIENT:
        return p.ambient;
    case NIMBUS_PLAN_BAKE_NOISE:
        return p.bakeNoise;
    case NIMBUS_PLAN_LIGHT_VOLUME:
        return p.lightVolume;
    case NIMBUS_PLAN_VOLUMES:
        return p.volumes;
    case NIMBUS_PLAN_INSTANCES:
        return p.instances;
    case NIMBUS_PLAN_SURFACES:
        return p.surfaces;
    case NIMBUS_PLAN_SOLIDS:
        return p.solids;
    case NIMBUS_PLAN_AOV_TRANSMITTANCE:
        return p.aovs.transmittance;
    case NIMBUS_PLAN_AOV_DEPTH:
        return p.aovs.depth;
    case NIMBUS_PLAN_READS_GRIDS:
        return readsGrids;
    case NIMBUS_PLAN_REFUSED:
        return !p.refusal.empty();
    case NIMBUS_PLAN_WARNINGS:
        return int(p.warnings.size());
    }
    throw Misuse("unknown plan item " + std::to_string(int(item)));
}

double statItem(const nimbus_context* ctx, int item) {
    const RenderStats& st = ctx->stats;
    switch (item) {
    case NIMBUS_STAT_SECONDS:
        return ctx->seconds;
    case NIMBUS_STAT_BAKE_SECONDS:
        return st.bakeSeconds;
    case NIMBUS_STAT_MAJORANT_SECONDS:
        return st.majorantSeconds;
    case NIMBUS_STAT_INTEGRATE_SECONDS:
        return st.integrateSeconds;
    case NIMBUS_STAT_LIGHT_VOLUME_SECONDS:
        return st.lightVolumeSeconds;
    case NIMBUS_STAT_LIGHT_GRID_MB:
        return double(st.lightVolumeVoxels + st.densityGridVoxels) * 4.0 / 1048576.0;
    case NIMBUS_STAT_DIFFUSION_SECONDS:
        return st.diffusionSeconds;
    case NIMBUS_STAT_PHOTON_SECONDS:
        return st.photonSeconds;
    case NIMBUS_STAT_SKY_VOLUME_SECONDS:
        return st.skyVolumeSeconds;
    case NIMBUS_STAT_SKY_VOLUME_MB:
        return double(st.skyVolumeBytes) / 1048576.0;
    case NIMBUS_STAT_LOOKUPS:
        return double(st.lookups());
    case NIMBUS_STAT_SHADOW_LOOKUPS:
        return double(st.shadowSamples);
    case NIMBUS_STAT_MAJORANT_EMPTY_FRACTION:
        return st.majorantEmptyFraction;
    case NIMBUS_STAT_MAJORANT_USED:
        return st.majorantUsed ? 1.0 : 0.0;
    case NIMBUS_STAT_BAKED_NOISE:
        return ctx->bakedNoise ? 1.0 : 0.0;
    case NIMBUS_STAT_NON_FINITE:
        return double(st.nonFinite);
    case NIMBUS_STAT_SIMULATION_STEPS:
        return double(st.automatonSteps + st.advectSteps);
    case NIMBUS_STAT_SIMULATION_SECONDS:
        return st.automatonSeconds + st.advectSeconds;
    case NIMBUS_STAT_PHOTONS:
        return double(st.photonsTraced);
    case NIMBUS_STAT_PHOTONS_FROM_SKY:
        return double(st.photonsFromSky);
    case NIMBUS_STAT_PHOTONS_HANDED_OFF:
        return double(st.photonsHandedOff);
    case NIMBUS_STAT_CLOUD_DEPTH:
        return st.cloudDepth;
    case NIMBUS_STAT_DIFFUSION_MB:
        return st.diffusionBytes / 1048576.0;
    case NIMBUS_STAT_PHOTON_MB:
        return st.photonBytes / 1048576.0;
    case NIMBUS_STAT_ABSORPTION_DEPTH:
        return st.absorptionDepth;
    case NIMBUS_STAT_PHOTON_SCATTERINGS:
        return double(st.photonScatterings);
    }
    throw Misuse("unknown statistic " + std::to_string(int(item)));
}

std::string sceneItem(host::Session& s, int item) {
    switch (item) {
    case NIMBUS_SCENE_PATH:
        return s.file().path;
    case NIMBUS_SCENE_FRAMES:
        return s.file().frames;
    case NIMBUS_SCENE_OUTPUT_PATTERN:
        return s.file().output.path;
    case NIMBUS_SCENE_PREVIEW_PATTERN:
        return s.file().output.preview;
    case NIMBUS_SCENE_OUTPUT_SPACE:
        return s.file().output.colorSpace;
    case NIMBUS_SCENE_WORKING_SPACE:
        return s.workingSpace();
    case NIMBUS_SCENE_COLOR_CONFIG:
        return s.colors().description();
    case NIMBUS_SCENE_HASH:
        return s.sceneHash();
    }
    throw Misuse("unknown scene item " + std::to_string(int(item)));
}

/// --resume's check of `path` for `frame` (nimbus_output_check); `why` says why a file that is
/// there is not current.
nimbus_output_state checkOutput(host::Session& s, int frame, const std::string& path,
                                std::string& why) {
    why.clear();
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) return NIMBUS_OUTPUT_ABSENT;
    if (!std::filesystem::is_regular_file(path, ec)) {
        why = "it is not a regular file";
        return NIMBUS_OUTPUT_STALE;
    }
    io::ExrImage img;
    try {
        img = io::readExr(path);
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception& e) {
        why = std::string("it cannot be read (") + e.what() + ")";
        return NIMBUS_OUTPUT_STALE;
    }
    const auto attr = [&](const char* name) -> const std::string* {
        const auto it = img.attributes.find(name);
        return it == img.attributes.end() ? nullptr : &it->second;
    };
    const std::string* frameAttr = attr("nimbus/frame");
    if (!frameAttr) {
        why = "it is not a Nimbus frame (no nimbus/frame attribute)";
        return NIMBUS_OUTPUT_STALE;
    }
    if (*frameAttr != std::to_string(frame)) {
        why = "it is frame " + *frameAttr + ", not " + std::to_string(frame);
        return NIMBUS_OUTPUT_STALE;
    }
    const int width = s.scene().camera.width, height = s.scene().camera.height;
    if (img.width != width || img.height != height) {
        why = "it is " + std::to_string(img.width) + "x" + std::to_string(img.height) + ", not " +
              std::to_string(width) + "x" + std::to_string(height);
        return NIMBUS_OUTPUT_STALE;
    }
    // the channels the scene's output writes (plugin/io/image_output.h)
    std::vector<std::string> want{"R", "G", "B", "A"};
    if (s.file().output.aovs.depth) want.push_back("depth");
    if (s.file().output.aovs.transmittance)
        for (const char* c : {"transmittance.R", "transmittance.G", "transmittance.B"})
            want.push_back(c);
    std::vector<std::string> have = img.channels;
    std::sort(want.begin(), want.end());
    std::sort(have.begin(), have.end());
    if (have != want) {
        auto join = [](const std::vector<std::string>& v) {
            std::string out;
            for (const std::string& c : v) out += (out.empty() ? "" : " ") + c;
            return out;
        };
        why = "its channels are " + join(have) + ", not " + join(want);
        return NIMBUS_OUTPUT_STALE;
    }
    const std::string* hash = attr("nimbus/sceneHash");
    if (!hash) {
        why = "it carries no scene hash (nimbus/sceneHash; written by an older Nimbus)";
        return NIMBUS_OUTPUT_STALE;
    }
    if (*hash != s.sceneHash()) {
        why = "it was rendered from another scene text or other settings (scene hash " + *hash +
              ", now " + s.sceneHash() + ")";
        return NIMBUS_OUTPUT_STALE;
    }
    return NIMBUS_OUTPUT_CURRENT;
}

} // namespace

extern "C" {

const char* nimbus_version(void) {
    return NIMBUS_VERSION;
}

void nimbus_version_numbers(int* major, int* minor, int* patch) {
    if (major) *major = NIMBUS_VERSION_MAJOR;
    if (minor) *minor = NIMBUS_VERSION_MINOR;
    if (patch) *patch = NIMBUS_VERSION_PATCH;
}

const char* nimbus_status_name(nimbus_status status) {
    switch (enumValue(status)) {
    case NIMBUS_OK:
        return "ok";
    case NIMBUS_INTERNAL:
        return "internal error";
    case NIMBUS_BAD_INPUT:
        return "bad input";
    case NIMBUS_IO:
        return "I/O error";
    case NIMBUS_NO_MEMORY:
        return "out of memory";
    case NIMBUS_INTERRUPTED:
        return "interrupted";
    }
    return "unknown status";
}

int nimbus_aov_channels(int aov) {
    switch (aov) {
    case NIMBUS_AOV_RGBA:
        return 4;
    case NIMBUS_AOV_TRANSMITTANCE:
        return 3;
    case NIMBUS_AOV_DEPTH:
        return 1;
    }
    return 0;
}

nimbus_context* nimbus_create(void) {
    return new (std::nothrow) nimbus_context;
}

void nimbus_destroy(nimbus_context* ctx) {
    try {
        delete ctx;
    } catch (...) {
        // destructors do not throw; nothing may leave the ABI if one did
    }
}

nimbus_status nimbus_load_file(nimbus_context* ctx, const char* path) {
    return guarded(ctx, [&] {
        const std::string p = nonNull(path, "path");
        return loadInto(ctx, true, p, p, ctx->overrides);
    });
}

nimbus_status nimbus_load_string(nimbus_context* ctx, const char* text, const char* name) {
    return guarded(ctx, [&] {
        const std::string t = nonNull(text, "text");
        return loadInto(ctx, false, t, name ? name : "<string>", ctx->overrides);
    });
}

nimbus_status nimbus_set(nimbus_context* ctx, const char* assignment) {
    return guarded(ctx, [&] {
        std::vector<std::string> next = ctx->overrides;
        next.push_back(nonNull(assignment, "assignment"));
        return applyOverrides(ctx, next);
    });
}

nimbus_status nimbus_clear_overrides(nimbus_context* ctx) {
    return guarded(ctx, [&] { return applyOverrides(ctx, {}); });
}

nimbus_status nimbus_frames(nimbus_context* ctx, int* frames, int capacity, int* count) {
    return guarded(ctx, [&] {
        host::Session& s = loadedSession(ctx);
        if (!count) throw Misuse("count is NULL");
        if (capacity < 0 || (capacity > 0 && !frames))
            throw Misuse("frames is NULL or capacity negative");
        const std::vector<int> all = io::parseFrameSpec(s.file().frames);
        for (size_t i = 0; i < all.size() && i < size_t(capacity); ++i) frames[i] = all[i];
        *count = int(std::min<size_t>(all.size(), size_t(std::numeric_limits<int>::max())));
        return NIMBUS_OK;
    });
}

nimbus_status nimbus_plan_int(nimbus_context* ctx, int frame, nimbus_plan_item item, int* value) {
    return guarded(ctx, [&] {
        host::Session& s = loadedSession(ctx);
        if (!value) throw Misuse("value is NULL");
        const FramePlan p = s.plan(frame);
        *value = planItem(p, s.scene(), s.readsGrids(), enumValue(item));
        return NIMBUS_OK;
    });
}

const char* nimbus_plan_explain(nimbus_context* ctx, int frame) {
    return guardedString(ctx, [&] {
        ctx->explainText = loadedSession(ctx).plan(frame).explain();
        return ctx->explainText.c_str();
    });
}

const char* nimbus_output_path(nimbus_context* ctx, int frame) {
    return guardedString(ctx, [&] {
        ctx->outputPathText = loadedSession(ctx).outputPath(frame);
        return ctx->outputPathText.c_str();
    });
}

nimbus_status nimbus_set_progress(nimbus_context* ctx, nimbus_progress_fn fn, void* user) {
    return guarded(ctx, [&] {
        ctx->progress = fn;
        ctx->user = user;
        return NIMBUS_OK;
    });
}

nimbus_status nimbus_cancel(nimbus_context* ctx) {
    if (!ctx) return NIMBUS_BAD_INPUT;
    ctx->cancel.store(true);
    return NIMBUS_OK;
}

nimbus_status nimbus_render(nimbus_context* ctx, int frame, float* rgba, size_t count) {
    return guarded(ctx, [&] {
        const nimbus_buffer b{NIMBUS_AOV_RGBA, rgba, count};
        return renderInto(ctx, frame, &b, 1);
    });
}

nimbus_status nimbus_render_aovs(nimbus_context* ctx, int frame, const nimbus_buffer* buffers,
                                 int n) {
    return guarded(ctx, [&] { return renderInto(ctx, frame, buffers, n); });
}

nimbus_status nimbus_render_write(nimbus_context* ctx, int frame, const char* path) {
    return guarded(ctx, [&] { return renderWrite(ctx, frame, path); });
}

const char* nimbus_warnings(nimbus_context* ctx) {
    return guardedString(ctx, [&] {
        if (ctx->session) takeWarnings(ctx, *ctx->session);
        std::string all;
        for (const std::string& w : ctx->warnings) all += w + "\n";
        ctx->warningsText = std::move(all);
        ctx->warnings.clear();
        return ctx->warningsText.c_str();
    });
}

nimbus_status nimbus_last_error_code(const nimbus_context* ctx) {
    return ctx ? ctx->code : NIMBUS_BAD_INPUT;
}

const char* nimbus_last_error(const nimbus_context* ctx) {
    if (!ctx) return "";
    if (ctx->messageLost) return "out of memory (while storing an error message)";
    return ctx->message.c_str();
}

const char* nimbus_last_error_file(const nimbus_context* ctx) {
    return ctx ? ctx->file.c_str() : "";
}

int nimbus_last_error_line(const nimbus_context* ctx) {
    return ctx ? ctx->line : 0;
}

nimbus_status nimbus_load_file_with(nimbus_context* ctx, const char* path,
                                    const char* const* assignments, int n) {
    return guarded(ctx, [&] {
        const std::string p = nonNull(path, "path");
        if (n < 0 || (n > 0 && !assignments)) throw Misuse("assignments is NULL or n negative");
        std::vector<std::string> overrides;
        for (int i = 0; i < n; ++i) overrides.push_back(nonNull(assignments[i], "an assignment"));
        return loadInto(ctx, true, p, p, overrides);
    });
}

nimbus_status nimbus_set_threads(nimbus_context* ctx, int threads) {
    return guarded(ctx, [&] {
        if (threads < -1) throw Misuse("threads must be -1 (the scene's), 0 (every core) or more");
        const int saved = ctx->threads;
        ctx->threads = threads;
        if (!ctx->session) return NIMBUS_OK;
        const nimbus_status st =
            loadInto(ctx, ctx->fromFile, ctx->source, ctx->name, ctx->overrides);
        if (st != NIMBUS_OK) ctx->threads = saved;
        return st;
    });
}

nimbus_status nimbus_set_output(nimbus_context* ctx, const char* pattern) {
    return guarded(ctx, [&] {
        std::optional<std::string> next;
        if (pattern) {
            const std::string p = pattern;
            if (p.size() < 4 || p.substr(p.size() - 4) != ".exr")
                throw Misuse("output path \"" + p + "\" must end in .exr");
            next = p;
        }
        if (ctx->session) {
            if (next) {
                ctx->session->file().output.path = *next;
            } else if (ctx->output) {
                // back to the scene's own: load it again
                ctx->output.reset();
                return loadInto(ctx, ctx->fromFile, ctx->source, ctx->name, ctx->overrides);
            }
        }
        ctx->output = next;
        return NIMBUS_OK;
    });
}

const char* nimbus_scene_string(nimbus_context* ctx, nimbus_scene_item item) {
    return guardedString(ctx, [&] {
        ctx->sceneString = sceneItem(loadedSession(ctx), enumValue(item));
        return ctx->sceneString.c_str();
    });
}

nimbus_status nimbus_prepare(nimbus_context* ctx, int frame) {
    return guarded(ctx, [&] {
        host::Session& s = loadedSession(ctx);
        const host::Status st = s.bind(frame);
        takeWarnings(ctx, s);
        if (!st.ok()) return setError(ctx, st);
        return NIMBUS_OK;
    });
}

const char* nimbus_plan_warning(nimbus_context* ctx, int frame, int index) {
    return guardedString(ctx, [&] {
        const FramePlan p = loadedSession(ctx).plan(frame);
        if (index < 0 || size_t(index) >= p.warnings.size())
            throw Misuse("plan warning " + std::to_string(index) + " of frame " +
                         std::to_string(frame) + ": the plan has " +
                         std::to_string(p.warnings.size()));
        ctx->planWarningText = p.warnings[size_t(index)];
        return ctx->planWarningText.c_str();
    });
}

nimbus_status nimbus_render_stat(nimbus_context* ctx, nimbus_stat item, double* value) {
    return guarded(ctx, [&] {
        if (!value) throw Misuse("value is NULL");
        *value = statItem(ctx, enumValue(item));
        return NIMBUS_OK;
    });
}

nimbus_status nimbus_output_check(nimbus_context* ctx, int frame, const char* path, int* state,
                                  const char** why) {
    return guarded(ctx, [&] {
        host::Session& s = loadedSession(ctx);
        if (!state) throw Misuse("state is NULL");
        const std::string p = path ? std::string(path) : s.outputPath(frame);
        *state = checkOutput(s, frame, p, ctx->whyText);
        if (why) *why = ctx->whyText.c_str();
        return NIMBUS_OK;
    });
}

nimbus_status nimbus_remove_stale_temp_files(nimbus_context* ctx, const int* frames, int n,
                                             int* removed) {
    return guarded(ctx, [&] {
        host::Session& s = loadedSession(ctx);
        if (n < 0 || (n > 0 && !frames)) throw Misuse("frames is NULL or n negative");
        std::vector<std::string> outs;
        const std::string& preview = s.file().output.preview;
        for (int i = 0; i < n; ++i) {
            outs.push_back(s.outputPath(frames[i]));
            if (!preview.empty()) outs.push_back(io::expandFramePattern(preview, frames[i]));
        }
        const std::size_t count = io::removeStaleTempFiles(outs);
        if (removed) *removed = int(std::min<std::size_t>(count, 0x7fffffff));
        return NIMBUS_OK;
    });
}

void nimbus_discard_writes(void) {
    io::removeInFlightTempFiles();
}

} // extern "C"
