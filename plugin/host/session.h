/// @file session.h
/// @brief The render session: load a scene (file or string), apply overrides, resolve colours,
/// bind grids and geometry per frame, render a frame into buffers, write outputs. Every error
/// is returned as a Status value (file, line, message); warnings are collected; nothing here
/// prints. The `nimbus` command (plugin/cli) is a thin host of it; the C ABI will wrap it.
///
/// @code
///   host::Session session;
///   host::Status st = session.load("cloud.toml", {"render.step=0.02"});
///   for (const std::string& w : session.takeWarnings()) std::cerr << "nimbus: " << w << "\n";
///   if (!st.ok()) return host::exitCode(st.code);
///   Framebuffer fb;
///   RenderStats stats;
///   if (!(st = session.bind(1)).ok() || !(st = session.render(1, fb, stats)).ok()) ...
/// @endcode
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/bindings.h"
#include "core/render.h"
#include "plugin/io/color.h"
#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"

namespace nimbus::host {

/// What went wrong, by the action it calls for; exitCode() gives the `nimbus` command's
/// documented exit codes.
enum class StatusCode {
    ok,          ///< 0
    bad_input,   ///< 2: scene file, override, colour configuration, missing or bad VDB
    io,          ///< 3: an output could not be written
    no_memory,   ///< 4
    interrupted, ///< 130: cancelled
    internal     ///< 1
};

/// The exit code of the `nimbus` command for a status code.
int exitCode(StatusCode code);

/// The result of a session call.
struct Status {
    StatusCode code = StatusCode::ok;
    std::string file; ///< the file the problem is in (scene file), empty when none
    int line = 0;     ///< 1-based line in `file`, 0 when unknown
    /// The whole message, e.g. "cloud.toml:12:8: render.step: expected ..." or
    /// "scene.toml: frame 3: ...": what follows "nimbus: error: " on the command line.
    std::string message;

    bool ok() const { return code == StatusCode::ok; }
    static Status success() { return {}; }
    static Status error(StatusCode code, std::string message, std::string file = {}, int line = 0);
};

/// The scene hash of Session::sceneHash() for scene `text` loaded with `overrides` under the
/// colour configuration described by `colorConfig`.
std::string computeSceneHash(const std::string& text, const std::vector<std::string>& overrides,
                             const std::string& colorConfig);

/// Called (serialised, from worker threads) after each finished tile.
using ProgressFn = std::function<void(int tilesDone, int tilesTotal)>;

/// One loaded scene and what its frames share (colour system, geometry, baked noise).
class Session {
  public:
    Session();
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    /// Loads a scene file with `section.key=value` overrides, resolves its colours against the
    /// OCIO config and builds the Embree geometry when the scene needs it (surfaces, or
    /// instances to find). `threads` >= 0 overrides render.threads.
    Status load(const std::string& path, const std::vector<std::string>& overrides = {},
                int threads = -1);
    /// The same for scene text; `name` stands for the file in messages (and relative paths
    /// are taken from its directory).
    Status loadString(const std::string& text, const std::string& name,
                      const std::vector<std::string>& overrides = {}, int threads = -1);

    bool loaded() const { return file_.has_value(); }
    const io::SceneFile& file() const { return *file_; }
    /// The loaded scene file, for host-side changes of its output (e.g. an output override).
    io::SceneFile& file() { return *file_; }
    const SceneDesc& scene() const { return file_->scene; }
    const io::ColorSystem& colors() const { return *cs_; }
    /// The working space the scene renders in (io::workingSpace).
    std::string workingSpace() const;
    /// Embree, when the scene has surfaces or instances; else null.
    const std::shared_ptr<const GeometryBackend>& geometry() const { return geometry_; }
    /// The first frame of the scene's frame spec.
    int firstFrame() const;
    /// Whether frames read grids (a VDB field or [[volume]] entries).
    bool readsGrids() const;
    /// The scene hash that writeFrame() stores as `nimbus/sceneHash` and `--resume` compares:
    /// 16 hex digits of FNV-1a 64 over the Nimbus version, the colour configuration's
    /// description, the scene text and the overrides except those of pixelNeutralKeys() (in
    /// order). Not the frame number, not --threads, not the output path. docs/farm_cli.md.
    const std::string& sceneHash() const { return sceneHash_; }
    /// Keys whose overrides change no pixel of a frame and stay out of sceneHash(): the scene
    /// table's rows marked so (io::pixelNeutralKeys()).
    static const std::vector<std::string>& pixelNeutralKeys();

    /// Warnings collected since the last call, oldest first, each as the command line prints
    /// it after "nimbus: " (scene-file warnings carry their "file:line:col: warning:").
    std::vector<std::string> takeWarnings();

    /// Binds frame `frame`: reads the VDB grids of the placed volumes (only those) and attaches
    /// the geometry. Kept until another frame is bound. Errors name the scene file and frame.
    Status bind(int frame);
    /// The bindings of the bound frame (empty before bind()).
    const FrameBindings& bindings() const { return bindings_; }
    /// The frame bind() last bound, if any.
    std::optional<int> boundFrame() const { return boundFrame_; }

    /// The plan of `frame` with its bindings when it is the bound frame; else with only the
    /// geometry bound (a VDB field's grid unread, as `--explain` plans).
    FramePlan plan(int frame, const AovSet& aovs);
    /// The plan with the scene's output AOVs.
    FramePlan plan(int frame);

    /// Renders `frame` (bound first when it is not the bound frame) into fb with the scene's
    /// output AOVs. `interrupted` when cancelled (fb partial); `plan` receives the plan used.
    Status render(int frame, Framebuffer& fb, RenderStats& stats, const ProgressFn& progress = {},
                  const std::atomic<bool>* cancel = nullptr, FramePlan* plan = nullptr);

    /// The output path of `frame` (the scene's output pattern expanded).
    std::string outputPath(int frame) const;
    /// Writes `frame` as the scene's output says: the EXR (atomically, in output.color_space,
    /// with `md`'s metadata; md.frame is set) and the preview PNG when one is configured.
    /// Non-finite values (written as 0, plus `renderNonFinite` from the render) become a
    /// warning. `io` on failure, naming the frame.
    Status writeFrame(int frame, const Framebuffer& fb, io::ExrMetadata md,
                      std::size_t renderNonFinite = 0);
    /// A preview's display transform done elsewhere than OCIO's CPU processor (`nimbus rt
    /// --gpu-display`: OCIO's GPU shader): the preview's linear RGB (io::previewLinearRgb, in
    /// the working space) in, display-encoded RGB (output.display / output.view) out, in place;
    /// false with *error on failure.
    using DisplayTransformFn =
        std::function<bool(std::vector<float>& rgb, int width, int height, std::string* error)>;
    /// writeFrame with the preview's display transform done by `display` (when not empty).
    Status writeFrame(int frame, const Framebuffer& fb, io::ExrMetadata md,
                      std::size_t renderNonFinite, const DisplayTransformFn& display);

    /// The renderer of the loaded scene (shared by its frames: baked noise is kept).
    Renderer& renderer();

  private:
    Status loadString(const std::string& text, const std::string& name,
                      const std::vector<std::string>& overrides, int threads, bool fromFile);

    std::optional<io::ColorSystem> cs_;
    std::optional<io::SceneFile> file_;
    std::shared_ptr<const GeometryBackend> geometry_;
    std::unique_ptr<Renderer> renderer_;
    FrameBindings bindings_;
    std::optional<int> boundFrame_;
    std::vector<std::string> warnings_;
    std::string sceneHash_;
};

} // namespace nimbus::host
