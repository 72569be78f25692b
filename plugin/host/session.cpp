#include "plugin/host/session.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <new>
#include <stdexcept>

#include <sys/resource.h>

#include "core/lighting/diffusion.h"
#include "core/tracking/volumes.h"
#include "plugin/geom/embree_geometry.h"
#include "plugin/io/frames.h"
#include "plugin/io/scene_setup.h"
#include "plugin/vdb/vdb_field.h"
#include "plugin/vdb/vdb_velocity.h"

namespace nimbus::host {

int exitCode(StatusCode code) {
    switch (code) {
    case StatusCode::ok:
        return 0;
    case StatusCode::bad_input:
        return 2;
    case StatusCode::io:
        return 3;
    case StatusCode::no_memory:
        return 4;
    case StatusCode::interrupted:
        return 130;
    case StatusCode::internal:
        return 1;
    }
    return 1;
}

Status Status::error(StatusCode code, std::string message, std::string file, int line) {
    Status s;
    s.code = code;
    s.message = std::move(message);
    s.file = std::move(file);
    s.line = line;
    return s;
}

namespace {

/// A SceneError's message starts "file:line:column: ..." (an override's "--set ...:" has no
/// line): the file and line of its first problem.
Status sceneStatus(const std::string& what) {
    Status s = Status::error(StatusCode::bad_input, what);
    const std::string first = what.substr(0, what.find('\n'));
    // scan from the right of each ": " for "<file>:<line>:<column>"
    for (size_t end = first.find(": "); end != std::string::npos; end = first.find(": ", end + 1)) {
        const std::string head = first.substr(0, end);
        const size_t c2 = head.rfind(':');
        if (c2 == std::string::npos || c2 == 0) continue;
        const size_t c1 = head.rfind(':', c2 - 1);
        if (c1 == std::string::npos || c1 == 0) continue;
        const std::string line = head.substr(c1 + 1, c2 - c1 - 1);
        const std::string col = head.substr(c2 + 1);
        auto digits = [](const std::string& t) {
            return !t.empty() && t.find_first_not_of("0123456789") == std::string::npos;
        };
        if (!digits(line) || !digits(col)) continue;
        s.file = head.substr(0, c1);
        s.line = std::atoi(line.c_str());
        break;
    }
    return s;
}

std::string directoryOf(const std::string& path) {
    return std::filesystem::path(path).parent_path().string();
}

std::string readText(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

/// FNV-1a, 64 bit, continued from `h` over `text` and a separating NUL.
std::uint64_t fnv1a(std::uint64_t h, const std::string& text) {
    for (const unsigned char c : text) {
        h ^= c;
        h *= 0x100000001b3ull;
    }
    return h * 0x100000001b3ull; // the NUL: one more round with c = 0
}

/// The key of an override "section.key = value", without spaces.
std::string overrideKey(const std::string& o) {
    std::string k = o.substr(0, o.find('='));
    k.erase(0, k.find_first_not_of(" \t"));
    k.erase(k.find_last_not_of(" \t") + 1);
    return k;
}

} // namespace

std::string computeSceneHash(const std::string& text, const std::vector<std::string>& overrides,
                             const std::string& colorConfig) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    h = fnv1a(h, "nimbus-scene-hash-1");
    h = fnv1a(h, NIMBUS_VERSION);
    h = fnv1a(h, colorConfig);
    h = fnv1a(h, text);
    const std::vector<std::string>& neutral = Session::pixelNeutralKeys();
    for (const std::string& o : overrides)
        if (std::find(neutral.begin(), neutral.end(), overrideKey(o)) == neutral.end())
            h = fnv1a(h, o);
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", (unsigned long long)h);
    return hex;
}

Session::Session() = default;
Session::~Session() = default;

Status Session::load(const std::string& path, const std::vector<std::string>& overrides,
                     int threads) {
    return loadString({}, path, overrides, threads, /*fromFile=*/true);
}

Status Session::loadString(const std::string& text, const std::string& name,
                           const std::vector<std::string>& overrides, int threads) {
    return loadString(text, name, overrides, threads, /*fromFile=*/false);
}

Status Session::loadString(const std::string& text, const std::string& name,
                           const std::vector<std::string>& overrides, int threads, bool fromFile) {
    file_.reset();
    sceneHash_.clear();
    renderer_.reset();
    geometry_.reset();
    bindings_ = FrameBindings{};
    boundFrame_.reset();
    try {
        if (!cs_) cs_.emplace(io::ColorSystem::load());
    } catch (const std::bad_alloc&) {
        return Status::error(StatusCode::no_memory, "out of memory");
    } catch (const std::exception& e) {
        return Status::error(StatusCode::bad_input,
                             std::string("colour configuration: ") + e.what());
    }
    io::SceneFile f;
    try {
        f = fromFile ? io::loadSceneFile(name, overrides)
                     : io::parseSceneText(text, name, overrides);
        if (threads >= 0) f.scene.render.threads = threads;
        io::resolveColours(f, *cs_);
    } catch (const io::SceneError& e) {
        return sceneStatus(e.what());
    } catch (const std::bad_alloc&) {
        return Status::error(StatusCode::no_memory, "out of memory");
    } catch (const std::exception& e) {
        return Status::error(StatusCode::bad_input, name + ": " + e.what(), name);
    }
    for (const std::string& w : f.warnings) warnings_.push_back(w);
    // Embree only for scenes that need it: surfaces, or instances to find
    const SceneDesc& s = f.scene;
    if (s.ground.enabled || !s.meshes.empty() || isInstanced(s)) {
        std::vector<std::string> warnings;
        try {
            geometry_ = geom::makeEmbreeGeometry(s, directoryOf(f.path), warnings);
        } catch (const std::bad_alloc&) {
            return Status::error(StatusCode::no_memory, "out of memory");
        } catch (const std::exception& e) {
            return Status::error(StatusCode::bad_input, f.path + ": " + e.what(), f.path);
        }
        for (const std::string& w : warnings) warnings_.push_back("warning: " + w);
    }
    file_.emplace(std::move(f));
    sceneHash_ = computeSceneHash(fromFile ? readText(name) : text, overrides, cs_->description());
    return Status::success();
}

const std::vector<std::string>& Session::pixelNeutralKeys() {
    static const std::vector<std::string> keys = io::pixelNeutralKeys();
    return keys;
}

std::string Session::workingSpace() const {
    return io::workingSpace(*cs_);
}

int Session::firstFrame() const {
    return io::parseFrameSpec(file_->frames).front();
}

bool Session::readsGrids() const {
    return scene().field.kind == FieldKind::Vdb || !scene().volumes.empty();
}

std::vector<std::string> Session::takeWarnings() {
    std::vector<std::string> w;
    w.swap(warnings_);
    return w;
}

Renderer& Session::renderer() {
    if (!renderer_) renderer_ = std::make_unique<Renderer>(file_->scene);
    return *renderer_;
}

Status Session::bind(int frame) {
    const SceneDesc& s = scene();
    const std::string& path = file_->path;
    const std::string dir = directoryOf(path);
    FrameBindings b;
    b.geometry = geometry_;
    b.grids.resize(1 + s.volumes.size());
    std::vector<std::string> warnings;
    try {
        if (isPlaced(s, 0)) {
            b.grids[0] = vdb::bindVdbField(s.field, dir, frame, warnings);
            // [field.advect] wind = "grid": the frame's velocity grid (read only when named)
            vdb::bindVdbVelocity(s.field, dir, frame, b.velocity, b.velocityStaggered, warnings);
        }
        for (size_t i = 0; i < s.volumes.size(); ++i) {
            if (!isPlaced(s, int(i) + 1)) continue; // never read
            try {
                b.grids[i + 1] = vdb::bindVdbField(s.volumes[i].field, dir, frame, warnings);
            } catch (const std::exception& e) {
                throw std::runtime_error("volume \"" + s.volumes[i].name + "\": " + e.what());
            }
        }
    } catch (const std::exception& e) {
        return Status::error(StatusCode::bad_input,
                             path + ": frame " + std::to_string(frame) + ": " + e.what(), path);
    }
    for (const std::string& w : warnings) warnings_.push_back("warning: " + w);
    bindings_ = std::move(b);
    boundFrame_ = frame;
    return Status::success();
}

namespace {

/// The message for a std::bad_alloc during frame `frame`: what its plan allocates and where
/// the process stood, so that the user knows what to make smaller.
std::string outOfMemoryWhileRendering(int frame, const FramePlan& p, int width, int height) {
    rusage ru{};
    const double peakMb = getrusage(RUSAGE_SELF, &ru) == 0 ? double(ru.ru_maxrss) / 1024.0 : 0.0;
    const double mb = 1.0 / 1048576.0;
    const double image = double(width) * double(height) *
                         (4.0 + (p.aovs.transmittance ? 3.0 : 0.0) + (p.aovs.depth ? 1.0 : 0.0)) *
                         sizeof(float);
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "frame %d: out of memory while rendering it; its plan allocates %.3g MB of "
                  "light-volume grids, %.3g MB of sky volume and %.3g MB of frame buffer (%dx%d) "
                  "beside the field, and the process had reached %.0f MB at its peak: lower the "
                  "resolution or coarsen render.light_volume_cell and render.majorant_cell "
                  "(nimbus render --explain shows the plan)",
                  frame, p.lightGridBytes * mb, p.skyVolumeBytes * mb, image * mb, width, height,
                  peakMb);
    return buf;
}

} // namespace

FramePlan Session::plan(int frame, const AovSet& aovs) {
    if (boundFrame_ == frame) return renderer().plan(frame, bindings_, aovs);
    FrameBindings unbound;
    unbound.geometry = geometry_;
    unbound.unread = true;
    return renderer().plan(frame, unbound, aovs);
}

FramePlan Session::plan(int frame) {
    return plan(frame, file_->output.aovs);
}

Status Session::render(int frame, Framebuffer& fb, RenderStats& stats, const ProgressFn& progress,
                       const std::atomic<bool>* cancel, FramePlan* planOut) {
    if (boundFrame_ != frame)
        if (Status st = bind(frame); !st.ok()) return st;
    const FramePlan p = plan(frame);
    if (planOut) *planOut = p;
    if (!p.refusal.empty())
        return Status::error(StatusCode::bad_input,
                             file_->path + ": frame " + std::to_string(frame) + ": " + p.refusal,
                             file_->path);
    RenderCallbacks cb;
    cb.progress = progress;
    cb.cancel = cancel;
    bool complete = false;
    try {
        complete = renderer().render(p, bindings_, fb, stats, cb);
    } catch (const std::bad_alloc&) {
        return Status::error(StatusCode::no_memory,
                             outOfMemoryWhileRendering(frame, p, file_->scene.camera.width,
                                                       file_->scene.camera.height));
    }
    if (!complete || (cancel && cancel->load())) {
        // no io::removeInFlightTempFiles() here: a render writes no file, and that registry is
        // the process's, so it would also remove the temp file of a frame another session is
        // writing (tests/test_capi.cpp, CApiThreads); the command clears it on a signal itself
        return Status::error(StatusCode::interrupted, "interrupted during frame " +
                                                          std::to_string(frame) +
                                                          "; no output written for it");
    }
    if (!stats.diffusionConverged) {
        char text[320];
        std::snprintf(text, sizeof text,
                      "warning: frame %d: the multiple-scattering grid's solve stopped at its cap "
                      "of %d iterations with its residual at %.3g of the light it balances "
                      "(wanted %.3g): its light may be off; a coarser render.light_volume_cell "
                      "gives it fewer voxels",
                      frame, stats.diffusionIterations, double(stats.diffusionResidual),
                      double(DiffusionParams{}.tolerance));
        warnings_.push_back(text);
    }
    return Status::success();
}

std::string Session::outputPath(int frame) const {
    return io::expandFramePattern(file_->output.path, frame);
}

Status Session::writeFrame(int frame, const Framebuffer& fb, io::ExrMetadata md,
                           std::size_t renderNonFinite) {
    return writeFrame(frame, fb, std::move(md), renderNonFinite, DisplayTransformFn());
}

Status Session::writeFrame(int frame, const Framebuffer& fb, io::ExrMetadata md,
                           std::size_t renderNonFinite, const DisplayTransformFn& display) {
    const io::OutputDesc& out = file_->output;
    const std::string ws = workingSpace();
    md.frame = frame;
    if (md.sceneHash.empty()) md.sceneHash = sceneHash_;
    try {
        std::size_t bad = io::writeExr(outputPath(frame), fb, *cs_, ws, out.colorSpace, md);
        if (!out.preview.empty() && display) {
            const std::string path = io::expandFramePattern(out.preview, frame);
            std::size_t replaced = 0;
            std::vector<float> rgb = io::previewLinearRgb(path, fb, &replaced);
            bad += replaced;
            std::string error;
            if (!display(rgb, fb.width, fb.height, &error))
                return Status::error(StatusCode::internal, "frame " + std::to_string(frame) +
                                                               ": the preview's display "
                                                               "transform: " +
                                                               error);
            io::writeEncodedPreviewPng(path, fb.width, fb.height, rgb, out.display, out.view);
        } else if (!out.preview.empty())
            bad += io::writePreviewPng(io::expandFramePattern(out.preview, frame), fb, *cs_, ws,
                                       out.display, out.view);
        if (bad + renderNonFinite > 0)
            warnings_.push_back("warning: frame " + std::to_string(frame) + ": " +
                                std::to_string(bad + renderNonFinite) +
                                " non-finite values replaced by 0");
    } catch (const std::bad_alloc&) {
        return Status::error(StatusCode::no_memory, "out of memory");
    } catch (const std::exception& e) {
        return Status::error(StatusCode::io, "frame " + std::to_string(frame) + ": " + e.what());
    }
    return Status::success();
}

} // namespace nimbus::host
