/* SPDX-License-Identifier: see LICENSE */
/**
 * @file nimbus.h
 * @brief The C ABI of libnimbus.so: load a Nimbus scene, override its parameters, query the
 * frame plan, render frames into your buffers or to EXR files. C99; no C++ type, exception or
 * allocator crosses it.
 *
 * The library wraps the render session of the `nimbus` command (plugin/host/session.h): the
 * same scene files, the same `--set` keys and checks, the same frame plan (`--explain`), the
 * same pixels (bit-identical for the same scene and frame) and the same EXR writer.
 *
 * @code
 *   #include "nimbus.h"
 *
 *   nimbus_context* ctx = nimbus_create();
 *   if (!ctx) return 1;                                   // out of memory
 *   if (nimbus_load_file(ctx, "cloud.toml") != NIMBUS_OK ||
 *       nimbus_set(ctx, "camera.width=320") != NIMBUS_OK ||
 *       nimbus_set(ctx, "camera.height=180") != NIMBUS_OK) {
 *       fprintf(stderr, "%s\n", nimbus_last_error(ctx));  // "cloud.toml:12:8: render.step: ..."
 *       nimbus_destroy(ctx);
 *       return 2;
 *   }
 *   int w = 0, h = 0;
 *   nimbus_plan_int(ctx, 1, NIMBUS_PLAN_WIDTH, &w);
 *   nimbus_plan_int(ctx, 1, NIMBUS_PLAN_HEIGHT, &h);
 *   float* rgba = malloc(sizeof(float) * 4 * (size_t)w * (size_t)h);
 *   nimbus_status st = nimbus_render(ctx, 1, rgba, 4 * (size_t)w * (size_t)h);
 *   ...
 *   free(rgba);
 *   nimbus_destroy(ctx);
 * @endcode
 *
 * ## Linking
 * Link with `-lnimbus` (soname `libnimbus.so.0`), or `dlopen("libnimbus.so.0")` and look the
 * functions up by name (examples/host_c). Only the functions declared here are exported, all
 * named `nimbus_*`, under the symbol version `NIMBUS_0`. The soname's number is
 * NIMBUS_VERSION_MAJOR: within one major version functions and enum values are only added,
 * never changed or removed (tests/test_capi.cpp checks the exported set against
 * plugin/capi/nimbus.abi).
 *
 * ## Errors
 * Functions that can fail return a ::nimbus_status, whose values are the exit codes of the
 * `nimbus` command (2 bad input, 3 I/O, 4 out of memory, 130 interrupted, 1 internal).
 * Functions returning a string return NULL on failure. Either way the context keeps the last
 * error: nimbus_last_error() (the whole message, as the command line prints it after
 * "nimbus: error: "), nimbus_last_error_file() and nimbus_last_error_line() (where in a scene
 * file the first problem is, when it is in one), nimbus_last_error_code(). Every call on a
 * context except those four accessors and nimbus_cancel() first clears it, so after a call
 * that succeeded the code is NIMBUS_OK and the message empty. A failed call leaves the context
 * usable: a failed load or override keeps the scene (and overrides) loaded before it.
 * Misuse (a NULL argument, a buffer too small, no scene loaded) is NIMBUS_BAD_INPUT with a
 * message saying what was wrong; a NULL context cannot hold an error and only returns the code.
 *
 * No C++ exception ever leaves the library: every entry point catches everything
 * (std::bad_alloc gives NIMBUS_NO_MEMORY, anything else NIMBUS_INTERNAL with its message).
 * The library prints nothing; warnings are collected (nimbus_warnings()).
 *
 * ## Threads
 * - A context is used by one thread at a time: calls on the same context must not overlap
 *   (the library detects an overlapping call and refuses it with NIMBUS_BAD_INPUT, but do not
 *   rely on it). Which thread makes the calls may change between calls.
 * - Different contexts may be used concurrently from different threads: they share nothing
 *   mutable, and two contexts rendering at once give the same pixels as one after the other.
 * - nimbus_cancel() is the exception: it may be called from any thread at any time (also from
 *   a signal handler: it only stores to an atomic flag), while a render on that context runs.
 * - A render uses a thread pool of its own (render.threads, 0 = every core); the progress
 *   callback is called on those worker threads (never two calls at once), not on the thread
 *   that called nimbus_render(). From inside it, call only nimbus_cancel().
 * - The functions taking no context (version, status names) may be called from anywhere.
 *
 * ## Ownership
 * The caller owns the context (nimbus_create() / nimbus_destroy()) and every buffer it passes;
 * the library keeps no pointer to a caller's buffer or string after a call returns, except the
 * progress callback's `user` pointer, kept until replaced or the context is destroyed.
 * Strings returned by the library belong to the context: each stays valid until the next call
 * on that context other than the nimbus_last_error*() accessors and nimbus_cancel(), or until
 * nimbus_destroy(); copy it to keep it. The strings of nimbus_version() and
 * nimbus_status_name() are static. All strings are UTF-8 (paths as the file system has them)
 * and NUL-terminated.
 *
 * ## Pixels
 * Buffers are row-major from the top-left pixel, `float`, scene-linear in the scene's working
 * space (ACEScg unless the OCIO config says otherwise); RGBA is premultiplied. See ::nimbus_aov
 * for the layers and their channel counts.
 */
#ifndef NIMBUS_H
#define NIMBUS_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__) || defined(__clang__)
#define NIMBUS_API __attribute__((visibility("default")))
#else
#define NIMBUS_API
#endif

/** The version of the Nimbus this header belongs to. The library's own is nimbus_version();
 * a host built against a header of major version M needs a library of major version M and a
 * minor version at least this header's. */
#define NIMBUS_VERSION_MAJOR 0
#define NIMBUS_VERSION_MINOR 2
#define NIMBUS_VERSION_PATCH 0

/** What a call did; the values are the `nimbus` command's exit codes. */
typedef enum nimbus_status {
    NIMBUS_OK = 0,           /**< success */
    NIMBUS_INTERNAL = 1,     /**< a bug in Nimbus: the message says what; please report it */
    NIMBUS_BAD_INPUT = 2,    /**< scene file, override, colour configuration, missing or bad VDB
                                  file, a frame that cannot be rendered as configured, or a
                                  misused call (NULL argument, buffer too small, no scene) */
    NIMBUS_IO = 3,           /**< an output could not be written */
    NIMBUS_NO_MEMORY = 4,    /**< out of memory */
    NIMBUS_INTERRUPTED = 130 /**< cancelled (progress callback or nimbus_cancel()) */
} nimbus_status;

/** An opaque render context: one loaded scene, its overrides, the noise it baked, the last
 * error, the progress callback. Created by nimbus_create(), freed by nimbus_destroy(). */
typedef struct nimbus_context nimbus_context;

/** The layers a frame can be rendered into (nimbus_render_aovs()), with their floats per
 * pixel. */
typedef enum nimbus_aov {
    NIMBUS_AOV_RGBA = 0,          /**< 4: premultiplied colour and alpha (1 - mean transmittance) */
    NIMBUS_AOV_TRANSMITTANCE = 1, /**< 3: RGB transmittance of the whole camera ray */
    NIMBUS_AOV_DEPTH = 2          /**< 1: distance where transmittance falls below 0.5, or 0 */
} nimbus_aov;

/** One caller-owned buffer for nimbus_render_aovs(): `count` floats at `data`, at least
 * width x height x nimbus_aov_channels(aov). */
typedef struct nimbus_buffer {
    int aov;      /**< a ::nimbus_aov */
    float* data;  /**< filled row-major, top row first */
    size_t count; /**< floats available at data */
} nimbus_buffer;

/** What nimbus_plan_int() can tell about a frame's plan (what `nimbus render --explain` prints). */
typedef enum nimbus_plan_item {
    NIMBUS_PLAN_WIDTH = 0,        /**< image width in pixels (camera.width) */
    NIMBUS_PLAN_HEIGHT = 1,       /**< image height in pixels (camera.height) */
    NIMBUS_PLAN_INTEGRATOR = 2,   /**< 0 march, 1 pathtrace */
    NIMBUS_PLAN_SHADOWS = 3,      /**< 1 when the sun lights the frame */
    NIMBUS_PLAN_AMBIENT = 4,      /**< 1 when the sky lights the frame */
    NIMBUS_PLAN_BAKE_NOISE = 5,   /**< 1 when cumulus noise is baked into tiles first */
    NIMBUS_PLAN_LIGHT_VOLUME = 6, /**< 1 when the sun's transmittance comes from a light volume */
    NIMBUS_PLAN_VOLUMES = 7,      /**< volumes: the field and the [[volume]] entries */
    NIMBUS_PLAN_INSTANCES = 8,    /**< placements of those volumes */
    NIMBUS_PLAN_SURFACES = 9,     /**< 1 with a ground or meshes */
    NIMBUS_PLAN_SOLIDS = 10,      /**< [[solid]] entries */
    NIMBUS_PLAN_AOV_TRANSMITTANCE = 11, /**< 1 when the scene's output writes transmittance */
    NIMBUS_PLAN_AOV_DEPTH = 12,         /**< 1 when the scene's output writes depth */
    NIMBUS_PLAN_READS_GRIDS = 13,       /**< 1 when frames read VDB grids */
    NIMBUS_PLAN_REFUSED = 14,           /**< 1 when the frame cannot be rendered as configured (the
                                             reason is in nimbus_plan_explain()) */
    NIMBUS_PLAN_WARNINGS = 15           /**< settings that will make the frame absurdly slow */
} nimbus_plan_item;

/**
 * Progress of a render: called after each finished tile with the tiles done so far and the
 * frame's total, on one of the render's worker threads (serialised: never two at once).
 * Return 0 to go on, non-zero to cancel: the render then stops within milliseconds and
 * returns NIMBUS_INTERRUPTED. Call no nimbus function from it except nimbus_cancel().
 */
typedef int (*nimbus_progress_fn)(void* user, int tiles_done, int tiles_total);

/* ---- version (no context; any thread) ---- */

/** The library's version, "MAJOR.MINOR.PATCH" (static storage). */
NIMBUS_API const char* nimbus_version(void);
/** The library's version as numbers; any pointer may be NULL. */
NIMBUS_API void nimbus_version_numbers(int* major, int* minor, int* patch);
/** A status as words ("ok", "bad input", "I/O error", "out of memory", "interrupted",
 * "internal error"; "unknown status" for other values). Static storage. */
NIMBUS_API const char* nimbus_status_name(nimbus_status status);
/** Floats per pixel of a layer (4, 3, 1), 0 for an unknown one. */
NIMBUS_API int nimbus_aov_channels(int aov);

/* ---- contexts ---- */

/** A new context with no scene loaded; NULL when out of memory. Cheap: the colour
 * configuration is read at the first load. */
NIMBUS_API nimbus_context* nimbus_create(void);
/** Frees the context and everything it owns (strings it returned included). NULL is ignored.
 * Must not overlap any other call on the context (a render on another thread: cancel it and
 * let nimbus_render() return first). */
NIMBUS_API void nimbus_destroy(nimbus_context* ctx);

/* ---- scenes ---- */

/**
 * Loads the scene file at `path` (strict TOML, examples/scenes/reference.md) with the
 * context's overrides (nimbus_set()), resolves its colours and builds its geometry. Relative
 * paths in the scene (VDB files, meshes, outputs) are taken as `nimbus render` takes them.
 * On failure (NIMBUS_BAD_INPUT: unreadable file, syntax error, unknown key, value out of
 * range; the error's file and line name the first problem) the previously loaded scene stays.
 */
NIMBUS_API nimbus_status nimbus_load_file(nimbus_context* ctx, const char* path);
/**
 * Loads a scene from TOML text. `name` stands for the file in error messages and its
 * directory anchors relative paths (NULL: "<string>", relative to the working directory).
 * Otherwise as nimbus_load_file().
 */
NIMBUS_API nimbus_status nimbus_load_string(nimbus_context* ctx, const char* text,
                                            const char* name);
/**
 * Overrides one parameter: `assignment` is "section.key=value", exactly as `nimbus render
 * --set` takes it (value in TOML syntax; a bare word is a string), with the same keys and
 * checks. Overrides accumulate in the order given (a later one of the same key wins) and
 * apply to the loaded scene at once (it is loaded again with them) and to every later load.
 * A bad key or value is refused with NIMBUS_BAD_INPUT and not kept; the scene and the earlier
 * overrides stay as they were. Without a scene loaded, the overrides are checked against the
 * default scene (an empty scene file): keys of another field kind need `field.kind=...` set
 * before them, or a scene loaded first.
 */
NIMBUS_API nimbus_status nimbus_set(nimbus_context* ctx, const char* assignment);
/** Drops every override (the loaded scene is loaded again without them). */
NIMBUS_API nimbus_status nimbus_clear_overrides(nimbus_context* ctx);
/** The frames of the scene's frame spec (`frames = "1-24"`), in order: writes at most
 * `capacity` of them to `frames` (which may be NULL when capacity is 0) and their total to
 * `*count`. */
NIMBUS_API nimbus_status nimbus_frames(nimbus_context* ctx, int* frames, int capacity, int* count);

/* ---- the frame plan ---- */

/** One number of frame `frame`'s plan (see ::nimbus_plan_item), planned as `--explain` plans:
 * a VDB field's grid is not read for it. */
NIMBUS_API nimbus_status nimbus_plan_int(nimbus_context* ctx, int frame, nimbus_plan_item item,
                                         int* value);
/** The plan of frame `frame` as `nimbus render --explain` prints it (several lines). NULL on
 * failure. Owned by the context. */
NIMBUS_API const char* nimbus_plan_explain(nimbus_context* ctx, int frame);
/** Where nimbus_render_write() writes frame `frame` with a NULL path: the scene's
 * output.path with the frame number substituted. NULL on failure. Owned by the context. */
NIMBUS_API const char* nimbus_output_path(nimbus_context* ctx, int frame);

/* ---- rendering ---- */

/** Sets the progress callback of later renders (NULL: none); `user` is passed to it. */
NIMBUS_API nimbus_status nimbus_set_progress(nimbus_context* ctx, nimbus_progress_fn fn,
                                             void* user);
/** Asks the render running on this context to stop (it returns NIMBUS_INTERRUPTED). Any thread,
 * any time, async-signal-safe; no effect when no render runs (each render starts uncancelled).
 * Returns NIMBUS_BAD_INPUT only for a NULL context. */
NIMBUS_API nimbus_status nimbus_cancel(nimbus_context* ctx);
/**
 * Renders frame `frame` into `rgba` (at least width x height x 4 floats: NIMBUS_PLAN_WIDTH,
 * NIMBUS_PLAN_HEIGHT). Reads the frame's VDB grids first when it has any (kept for the next
 * render of the same frame). The pixels equal those of `nimbus render` for the same scene,
 * overrides and frame. When interrupted the buffer holds a partial frame.
 */
NIMBUS_API nimbus_status nimbus_render(nimbus_context* ctx, int frame, float* rgba, size_t count);
/**
 * Renders frame `frame` into `n` buffers, one per layer (see ::nimbus_buffer; each layer at
 * most once; RGBA need not be among them). Layers are computed as asked, whatever the scene's
 * output lists; asking for more layers does not change the RGBA pixels.
 */
NIMBUS_API nimbus_status nimbus_render_aovs(nimbus_context* ctx, int frame,
                                            const nimbus_buffer* buffers, int n);
/**
 * Renders frame `frame` and writes it as the `nimbus` command does: an OpenEXR (written
 * atomically: a temp file renamed into place, so an interrupted write leaves no partial file
 * under the final name) in output.color_space with the scene's output layers and Nimbus
 * metadata, plus the PNG preview when output.preview is set. `path` (ending in .exr) replaces
 * output.path for this call; NULL writes to nimbus_output_path(). NIMBUS_IO when a file
 * cannot be written.
 */
NIMBUS_API nimbus_status nimbus_render_write(nimbus_context* ctx, int frame, const char* path);

/* ---- messages ---- */

/** The warnings collected since the last call of this function (scene-file warnings with
 * their "file:line:col: warning:", non-finite pixels replaced, ...), one per line; "" when
 * none. Owned by the context. */
NIMBUS_API const char* nimbus_warnings(nimbus_context* ctx);
/** The status of the last call on the context that failed since it was cleared (see Errors). */
NIMBUS_API nimbus_status nimbus_last_error_code(const nimbus_context* ctx);
/** The last error's message ("" when none; never NULL, also for a NULL context). */
NIMBUS_API const char* nimbus_last_error(const nimbus_context* ctx);
/** The scene file the last error is in ("" when none). */
NIMBUS_API const char* nimbus_last_error_file(const nimbus_context* ctx);
/** The 1-based line of the last error in that file (0 when unknown, e.g. an override). */
NIMBUS_API int nimbus_last_error_line(const nimbus_context* ctx);

/* ---- for hosts of sequences (`nimbus render` is one: docs/farm_cli.md) ---- */

/** Strings about the loaded scene (nimbus_scene_string()). */
typedef enum nimbus_scene_item {
    NIMBUS_SCENE_PATH = 0,            /**< the scene file's path (the name of scene text) */
    NIMBUS_SCENE_FRAMES = 1,          /**< its frame spec (`frames`, e.g. "1-24") */
    NIMBUS_SCENE_OUTPUT_PATTERN = 2,  /**< output.path as writes use it (nimbus_set_output()) */
    NIMBUS_SCENE_PREVIEW_PATTERN = 3, /**< output.preview ("" when none) */
    NIMBUS_SCENE_OUTPUT_SPACE = 4,    /**< output.color_space */
    NIMBUS_SCENE_WORKING_SPACE = 5,   /**< the scene-linear space frames render in */
    NIMBUS_SCENE_COLOR_CONFIG = 6,    /**< which OCIO configuration is in use, in words */
    /** The scene hash that every frame written carries as its `nimbus/sceneHash` attribute:
     * 16 hex digits of FNV-1a (64 bit) over the Nimbus version, the colour configuration, the
     * scene text and the overrides that may change pixels (docs/farm_cli.md says exactly
     * which). Frames of the same scene text and overrides have the same hash; the frame number
     * is not in it (frames carry it as `nimbus/frame`). */
    NIMBUS_SCENE_HASH = 7
} nimbus_scene_item;

/** Statistics of the last render on the context (nimbus_render_stat()). */
typedef enum nimbus_stat {
    NIMBUS_STAT_SECONDS = 0,              /**< wall-clock seconds of the render (not the write) */
    NIMBUS_STAT_BAKE_SECONDS = 1,         /**< noise baking charged to the frame */
    NIMBUS_STAT_MAJORANT_SECONDS = 2,     /**< majorant grids and the instance query */
    NIMBUS_STAT_INTEGRATE_SECONDS = 3,    /**< marching or path tracing the pixels */
    NIMBUS_STAT_LIGHT_VOLUME_SECONDS = 4, /**< the per-frame light grids */
    NIMBUS_STAT_LIGHT_GRID_MB = 5,        /**< their memory, MiB */
    NIMBUS_STAT_DIFFUSION_SECONDS = 6,    /**< the multiple-scattering grid */
    NIMBUS_STAT_PHOTON_SECONDS = 7,       /**< photons of the sun (and of the sky) */
    NIMBUS_STAT_SKY_VOLUME_SECONDS = 8,   /**< the single-scattered sky's integrals */
    NIMBUS_STAT_SKY_VOLUME_MB = 9,        /**< their memory, MiB */
    NIMBUS_STAT_LOOKUPS = 10,             /**< density lookups, all rays */
    NIMBUS_STAT_SHADOW_LOOKUPS = 11,      /**< of them, on shadow rays */
    NIMBUS_STAT_MAJORANT_EMPTY_FRACTION = 12, /**< fraction of majorant cells that are empty */
    NIMBUS_STAT_MAJORANT_USED = 13,           /**< 1 when march skipped space with that grid */
    NIMBUS_STAT_BAKED_NOISE = 14,             /**< 1 when the plan baked the noise */
    NIMBUS_STAT_NON_FINITE = 15,              /**< non-finite pixels replaced by 0 */
    /** simulation steps this frame computed: the automaton's, or [field.advect]'s (a lone
     * frame: all from the start; a frame after its predecessor: the steps in between) */
    NIMBUS_STAT_SIMULATION_STEPS = 16,
    NIMBUS_STAT_SIMULATION_SECONDS = 17, /**< the seconds that simulation and the field took */
    NIMBUS_STAT_PHOTONS = 18,            /**< photons traced (from the sun and the sky) */
    NIMBUS_STAT_PHOTONS_FROM_SKY = 19,   /**< of them, from the sky (render.photon_sky) */
    /** of them, those whose light went on in the diffusion grid (render.photon_bounces) */
    NIMBUS_STAT_PHOTONS_HANDED_OFF = 20,
    /** render.multiple_scattering = "auto": the cloud's mean optical depth along the sun that
     * chose photons (at most render.photon_depth, or any in a medium whose absorption keeps its
     * diffuse light within it) or the grid; -1 when nothing was measured */
    NIMBUS_STAT_CLOUD_DEPTH = 21,
    /** MiB the multiple-scattering grid's solve held at its peak (what `--explain` estimates
     * as the plan's diffusion memory); 0 when the frame solved no grid */
    NIMBUS_STAT_DIFFUSION_MB = 22,
    /** MiB the photon pass held beyond the light grids (the photons' voxels and their own
     * tracking grid; what `--explain` estimates); 0 when no photons were traced */
    NIMBUS_STAT_PHOTON_MB = 23,
    /** render.multiple_scattering = "auto" in a medium that absorbs: the depth, in mean free
     * paths, its diffuse light reaches before absorption takes it (1 / sqrt(3 (1 - a)(1 - a g))),
     * where that is less than NIMBUS_STAT_CLOUD_DEPTH and so what "auto" compared with
     * render.photon_depth; -1 otherwise */
    NIMBUS_STAT_ABSORPTION_DEPTH = 24,
    /** scatterings of the photons' walks (with render.photon_similarity, a scattering of the
     * similar medium counts one); 0 when no photons were traced */
    NIMBUS_STAT_PHOTON_SCATTERINGS = 25
} nimbus_stat;

/** What nimbus_output_check() found at a frame's output path. */
typedef enum nimbus_output_state {
    NIMBUS_OUTPUT_ABSENT = 0,  /**< no file there */
    NIMBUS_OUTPUT_CURRENT = 1, /**< a complete frame of this scene: rendering it again would
                                    write the same pixels */
    NIMBUS_OUTPUT_STALE = 2    /**< a file that is not that (the reason says why) */
} nimbus_output_state;

/**
 * Loads the scene file at `path` with exactly the `n` overrides `assignments` (each as
 * nimbus_set() takes it), in one load: they replace the context's overrides when the load
 * succeeds. Unlike nimbus_set() before a load, a key of the file's own field kind needs no
 * `field.kind=...` first. `assignments` may be NULL when n is 0. Otherwise as
 * nimbus_load_file().
 */
NIMBUS_API nimbus_status nimbus_load_file_with(nimbus_context* ctx, const char* path,
                                               const char* const* assignments, int n);
/** Sets render.threads for the loaded scene and every later load (0 = every core, -1 = the
 * scene's own). Not an override: it changes no pixel, is not in the frames' `overrides`
 * metadata and not in the scene hash. */
NIMBUS_API nimbus_status nimbus_set_threads(nimbus_context* ctx, int threads);
/** Replaces output.path (an EXR path pattern with frame tokens, ending in .exr) for the loaded
 * scene and every later load; NULL goes back to the scene's own. Not an override (not in the
 * scene hash). NIMBUS_BAD_INPUT for a path not ending in .exr. */
NIMBUS_API nimbus_status nimbus_set_output(nimbus_context* ctx, const char* pattern);
/** A string about the loaded scene (see ::nimbus_scene_item); NULL on failure. Owned by the
 * context. */
NIMBUS_API const char* nimbus_scene_string(nimbus_context* ctx, nimbus_scene_item item);
/** Reads frame `frame`'s VDB grids (what a render of the frame does first, and keeps them for
 * it), so that errors in them come before the render and the frame's plan (warnings included)
 * is made with them. */
NIMBUS_API nimbus_status nimbus_prepare(nimbus_context* ctx, int frame);
/** Warning `index` (0-based, below NIMBUS_PLAN_WARNINGS) of frame `frame`'s plan, one line;
 * NULL on failure. Owned by the context. */
NIMBUS_API const char* nimbus_plan_warning(nimbus_context* ctx, int frame, int index);
/** One statistic (see ::nimbus_stat) of the last render on the context that finished, also
 * when its write failed; 0 before any. */
NIMBUS_API nimbus_status nimbus_render_stat(nimbus_context* ctx, nimbus_stat item, double* value);
/**
 * Checks the file at `path` (NULL: nimbus_output_path(frame)) for `--resume`: `*state` is
 * NIMBUS_OUTPUT_CURRENT when it opens as an EXR, is a Nimbus frame numbered `frame`, has the
 * scene's resolution and exactly the channels its output writes, and carries the scene's hash
 * (NIMBUS_SCENE_HASH) in `nimbus/sceneHash`; NIMBUS_OUTPUT_STALE with the first reason that
 * fails in `*why` ("it is 64x36, not 32x18", "it was rendered from another scene or other
 * settings (scene hash ... , now ...)"); NIMBUS_OUTPUT_ABSENT when there is no file. `why` may
 * be NULL; the string is owned by the context ("" unless stale).
 */
NIMBUS_API nimbus_status nimbus_output_check(nimbus_context* ctx, int frame, const char* path,
                                             int* state, const char** why);
/** Removes the temp files that writes of these frames' outputs (EXR and preview) by processes
 * of this host which no longer run left behind (a SIGKILLed render); `*removed` (may be NULL)
 * gets how many. Temp files of running processes and other hosts stay. */
NIMBUS_API nimbus_status nimbus_remove_stale_temp_files(nimbus_context* ctx, const int* frames,
                                                        int n, int* removed);
/** Unlinks the temp file of every write in flight in this process (nimbus_render_write() on
 * any context), so that a write stopped by a signal leaves nothing behind; that write then
 * fails with NIMBUS_IO. Async-signal-safe: for a SIGINT/SIGTERM handler (with nimbus_cancel()). */
NIMBUS_API void nimbus_discard_writes(void);

#ifdef __cplusplus
}
#endif

#endif /* NIMBUS_H */
