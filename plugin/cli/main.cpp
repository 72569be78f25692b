/// @file main.cpp
/// @brief The `nimbus` command: render frame sequences, measure error against run time, print
/// the scene-file reference.
///
/// Exit codes: 0 success, 1 internal error (an exception no layer handled: the last-resort
/// handlers below and in dispatch.cpp), 2 bad input (command line, scene file, colour names and
/// configuration, limits), 3 I/O failure (cannot read or write a file), 4 out of memory, 130
/// interrupted (SIGINT, SIGTERM, SIGHUP).

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <exception>
#include <cstdio>
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <dlfcn.h>
#include <unistd.h>

#include "plugin/cli/commands.h"
#include "plugin/cli/dispatch.h"
#include "plugin/io/frames.h"

using namespace nimbus;

namespace {

/// --save-reference / --reference of converge and calibrate: a path-traced reference costs
/// minutes, so it can be kept and reused for every later measurement of the same frame.
void addReferenceFileOptions(CLI::App* cmd, std::string& save, std::string& load) {
    auto* s =
        cmd->add_option("--save-reference", save,
                        "Also write the reference to this EXR for later runs: the scene-linear "
                        "working space (ACEScg unless $OCIO says otherwise) and the clouds "
                        "alone on a transparent background, whatever output.color_space and "
                        "render.background say, with its noise and settings in the header");
    cmd->add_option("--reference", load,
                    "Read the reference from an EXR written by --save-reference instead of "
                    "rendering it (its frame and resolution must match)")
        ->excludes(s);
}

/// Loads the commands' shared object from beside the executable and runs `command`.
int run(cli::Command command, const void* options) {
    std::string dir = ".";
    char self[4096];
    const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n > 0) {
        self[n] = '\0';
        dir = self;
        dir = dir.substr(0, dir.find_last_of('/'));
    }
    const bool render = command == cli::Command::Render;
    const std::string path = dir + "/" + (render ? cli::kRenderLibrary : cli::kCommandsLibrary);
    void* lib = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        std::fprintf(stderr, "nimbus: error: cannot load the commands (%s): %s\n", path.c_str(),
                     dlerror());
        return cli::kExitInternal;
    }
    const char* symbol = render ? cli::kRenderSymbol : cli::kDispatchSymbol;
    void* entry = dlsym(lib, symbol);
    if (!entry) {
        std::fprintf(stderr, "nimbus: error: %s has no %s: %s\n", path.c_str(), symbol, dlerror());
        return cli::kExitInternal;
    }
    if (render) return reinterpret_cast<int (*)(const void*)>(entry)(options);
    return reinterpret_cast<int (*)(int, const void*)>(entry)(int(command), options);
}

[[noreturn]] void onTerminate() {
    std::fputs("nimbus: internal error: unhandled exception; please report it\n", stderr);
    _exit(cli::kExitInternal);
}

int mainImpl(int argc, char** argv);

} // namespace

/// A C++ exception never leaves main: whatever no layer handled becomes a message and exit 1.
int main(int argc, char** argv) {
    std::set_terminate(onTerminate);
    try {
        return mainImpl(argc, argv);
    } catch (const std::bad_alloc&) {
        std::fputs("nimbus: error: out of memory\n", stderr);
        return cli::kExitNoMemory;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: internal error: %s; please report it\n", e.what());
        return cli::kExitInternal;
    } catch (...) {
        std::fputs("nimbus: internal error: unknown exception; please report it\n", stderr);
        return cli::kExitInternal;
    }
}

namespace {

int mainImpl(int argc, char** argv) {
    CLI::App app{"nimbus " NIMBUS_VERSION " - offline renderer for volumetric clouds.\n"
                 "Renders TOML scenes (see `nimbus reference`) to colour-managed OpenEXR frame "
                 "sequences.\nExit codes: 0 ok, 1 internal error, 2 bad input, 3 I/O error, "
                 "4 out of memory, 130 interrupted (SIGINT, SIGTERM, SIGHUP)."};
    app.set_version_flag("--version", std::string("nimbus ") + NIMBUS_VERSION);
    app.require_subcommand(1);
    app.footer(
        "Examples:\n"
        "  nimbus render examples/scenes/cumulus.toml\n"
        "  nimbus render scene.toml --frames 1-4 --set render.step=0.5\n"
        "  nimbus render scene.toml --frames 101-110 --resume    # one farm task\n"
        "  nimbus converge scene.toml --csv error.csv\n"
        "  nimbus converge --suite       # march against pathtrace on every cloud\n"
        "  nimbus converge scene.toml --scale 0.25 --reference-spp 1024 "
        "--pathtrace-ladder 4,16,64 --plot error.png\n"
        "  nimbus calibrate scene.toml --scale 0.25\n"
        "  nimbus bake scene.toml -o clouds.####.vdb --frames 1-24 --voxel 0.05\n"
        "  nimbus bench-vdb-render examples/scenes/smoke1.toml --output-dir out/bench\n"
        "  nimbus stress --quick        # stiff and extreme cases, PASS/DEGRADED/FAIL\n"
        "  nimbus export-glsl scene.toml -o out/engine/ --frame 1 "
        "--set 'render.multiple_scattering=\"none\"'\n"
        "  nimbus reference > scene-reference.md\n"
        "Environment:\n"
        "  NIMBUS_VDB_ISOLATE=0        read VDB grids in process (trusted files only; "
        "default 1:\n"
        "                              in a child process, so a corrupt file cannot crash "
        "nimbus)\n"
        "  NIMBUS_VDB_TIMEOUT=600      seconds before that child is stopped\n"
        "  NIMBUS_VDB_MEMORY_LIMIT=16G memory it may map beyond its libraries (default: physical "
        "memory)\n"
        "  NIMBUS_VDB_READER=path      the program that child runs (default: "
        "nimbus-vdb-reader\n"
        "                              beside nimbus's libraries)");

    cli::RenderOptions ro;
    auto* render = app.add_subcommand("render", "Render the frames of a scene to EXR files");
    render->add_option("scene", ro.scene, "Scene file (TOML)")->required();
    render->add_option("-f,--frames", ro.frames,
                       std::string("Frames to render (default: the scene's `frames`). ") +
                           std::string(io::frameSpecSyntax()));
    render
        ->add_option("-s,--set", ro.overrides,
                     "Override a scene value: section.key=value (TOML value), repeatable")
        ->allow_extra_args(false);
    render->add_option("-o,--output", ro.output,
                       std::string("Output EXR path pattern (overrides output.path). ") +
                           std::string(io::framePatternSyntax()));
    render->add_option("-t,--threads", ro.threads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024));
    render->add_flag("--explain", ro.explain, "Print the plan of each frame and exit");
    render->add_flag("--resume", ro.resume,
                     "Skip frames whose output already exists as a complete Nimbus EXR of this "
                     "frame, the scene's resolution and channels, and the same scene hash "
                     "(nimbus/sceneHash: scene text and pixel-changing overrides); others are "
                     "rendered again, and the log says why");
    render
        ->add_option("--progress", ro.progress,
                     "Progress display: auto (bar on a terminal, plain lines otherwise), bar, "
                     "plain, none, or json: one JSON object per line on stderr (events "
                     "frame_start, progress, frame_done with seconds and peak_rss_mb, "
                     "frame_skipped, frame_rerender, warning, error, note, done; "
                     "docs/farm_cli.md)")
        ->check(CLI::IsMember({"auto", "bar", "plain", "json", "none"}));
    render->add_flag("-q,--quiet", ro.quiet, "Only errors and warnings");

    cli::ConvergeOptions co;
    auto* converge = app.add_subcommand(
        "converge", "Measure error against run time: a fine-step reference, then a ladder of "
                    "coarser steps (table + CSV)");
    converge->add_option("scene", co.scene,
                         "Scene file (TOML); with --suite optional (default: "
                         "examples/scenes/cumulus.toml of the repository)");
    converge->add_option("-s,--set", co.overrides, "Override a scene value (as for render)")
        ->allow_extra_args(false);
    converge->add_option("--frame", co.frame, "Frame to measure (default: first of the scene)");
    converge
        ->add_option("--ladder", co.ladder,
                     "march rungs: step multipliers applied to render.step, render.step_growth "
                     "and render.shadow_step")
        ->delimiter(',')
        ->capture_default_str();
    converge
        ->add_option("--reference-step", co.referenceStep,
                     "Step multiplier of a march reference (used when --reference-spp is 0)")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    converge
        ->add_option("--reference-spp", co.referenceSpp,
                     "Make the reference an unbiased pathtrace render with this many samples "
                     "per pixel (0 = a fine-step march reference)")
        ->capture_default_str();
    converge
        ->add_option("--pathtrace-ladder", co.pathtraceLadder,
                     "pathtrace rungs: samples per pixel, e.g. 1,4,16,64")
        ->delimiter(',');
    converge
        ->add_option("--photon-ladder", co.photonLadder,
                     "march rungs with render.multiple_scattering = \"photons\" (one octave), "
                     "photons per frame, e.g. 250000,1000000")
        ->delimiter(',');
    converge->add_option("--scale", co.scale, "Resolution multiplier for every render")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    converge->add_option("--csv", co.csv, "CSV output (default: <scene stem>.converge.csv)");
    converge->add_option("--plot", co.plot, "Also draw error against time, log-log (PNG, gnuplot)");
    converge->add_option("-t,--threads", co.threads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024));
    converge->add_flag("--box-filter", co.boxFilter,
                       "pathtrace renders average over each pixel (by default they sample the "
                       "pixel centres, as march does, so the error is the lighting's, not "
                       "aliasing)");
    addReferenceFileOptions(converge, co.saveReference, co.loadReference);
    converge->add_flag("--suite", co.suite,
                       "Run the validation matrix instead of a ladder: march against a "
                       "pathtrace reference on every cloud x thickness x sun x albedo (see "
                       "below)");
    converge->add_option("--suite-data", co.suiteData,
                         "--suite: folder of VDB files, each file's fog density grid one cloud "
                         "(default: ../shared/data/vdb beside the repository)");
    converge
        ->add_option("--suite-dir", co.suiteDir,
                     "--suite: folder of the cached references (EXR, one per case) and of "
                     "suite.md and suite.csv")
        ->capture_default_str();
    converge
        ->add_option("--suite-filter", co.suiteFilter,
                     "--suite: run only the cases whose name contains one of these substrings "
                     "(comma-separated), e.g. gaffer_fogsphere_small or thick/behind")
        ->delimiter(',');
    converge->add_option("--suite-size", co.suiteSize, "--suite: WIDTHxHEIGHT of every render")
        ->capture_default_str();
    converge
        ->add_option("--suite-spp", co.suiteSpp,
                     "--suite: samples per pixel of a reference's first round (two halves of "
                     "spp/2 with different seeds)")
        ->capture_default_str()
        ->check(CLI::Range(2, 1 << 20));
    converge
        ->add_option("--suite-noise", co.suiteNoise,
                     "--suite: refine each reference in rounds until its noise (relative to its "
                     "mean over the cloud's pixels) is below this, ...")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    converge
        ->add_option("--suite-seconds", co.suiteSeconds,
                     "--suite: ... or its rendering (every round, cached ones included) took "
                     "this long, ...")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    converge
        ->add_option("--suite-max-spp", co.suiteMaxSpp,
                     "--suite: ... or it has this many samples per pixel")
        ->capture_default_str()
        ->check(CLI::Range(2, 1 << 24));
    converge
        ->add_option("--suite-max-depth", co.suiteMaxDepth,
                     "--suite: render.max_depth of the references (0 = the scene's)")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    converge
        ->add_option("--suite-light", co.suiteLight,
                     "--suite: the light of every case: both (the sun and the sky), sun or sky "
                     "alone, to tell which light an error comes from (references cached apart)")
        ->capture_default_str()
        ->check(CLI::IsMember({"both", "sun", "sky"}));
    converge->add_flag("--suite-rerender", co.suiteRerender,
                       "--suite: render every selected reference again instead of reading the "
                       "cache (e.g. after a change to pathtrace)");
    converge->footer(
        "--suite: the validation matrix (docs/accuracy.md, \"The validation matrix\")\n"
        "  Clouds: the scene (default examples/scenes/cumulus.toml, its first frame and camera, "
        "its own render\n"
        "  settings) and every *.vdb of --suite-data: the grid named density (or the file's only "
        "float grid),\n"
        "  framed by a camera from -z (20 deg toward +x, 10 deg up, fov 40); march with the "
        "renderer's defaults\n"
        "  except render.step = render.shadow_step = one voxel. Level sets, empty grids and "
        "files without a\n"
        "  float grid are skipped with a note.\n"
        "  Thickness: tau = sigma_t x density_scale x the density integral along each pixel's "
        "centre ray,\n"
        "  averaged over the pixels whose ray meets density; density_scale is set for a mean "
        "tau of 1 (thin),\n"
        "  20 (medium) and 500 (thick). Albedo 1 and 0.9 (sigma_s = albedo sigma_t, sigma_a = "
        "the rest).\n"
        "  Sun (angle between the sunlight's travel and the view direction): front 20 deg "
        "(behind the camera,\n"
        "  above it), side 90 deg (from the image's right, 30 deg up), behind 150 deg (ahead, "
        "30 deg above the\n"
        "  view axis). Light: sun 12 x (1, 0.93, 0.82), gradient sky zenith (0.16, 0.32, 0.70), "
        "horizon\n"
        "  (0.60, 0.70, 0.82), lin_rec709: the default scene's. Cases are named "
        "CLOUD/THICKNESS/SUN/aALBEDO.\n"
        "  Error: core/image_error.h, relative RMSE over the cloud's pixels (reference alpha > "
        "0.01), RGB,\n"
        "  divided by the reference's mean, its noise (two halves) taken out in quadrature. "
        "Output: a markdown\n"
        "  table on stdout (also DIR/suite.md) and a CSV (--csv, default DIR/suite.csv), worst "
        "first.\n"
        "  -s/--set applies to every cloud's scene; the suite then sets the size, background, "
        "sun, sky and medium\n"
        "  coefficients. A cached reference is used only when every setting it depends on "
        "matches; one of other\n"
        "  settings is kept beside it (CASE.k<hash>.a/b.exr) and taken back when a later run's "
        "settings match it.\n"
        "Examples:\n"
        "  nimbus converge --suite\n"
        "  nimbus converge --suite --suite-filter gaffer_fogsphere_small,cumulus/thin "
        "--suite-spp 64");

    cli::CalibrateOptions ko;
    auto* calibrate = app.add_subcommand(
        "calibrate", "Fit the approximations of march (scattering octaves, sky ambient) to a "
                     "path-traced reference of the scene and print the fitted values");
    calibrate->add_option("scene", ko.scene, "Scene file (TOML)")->required();
    calibrate->add_option("-s,--set", ko.overrides, "Override a scene value (as for render)")
        ->allow_extra_args(false);
    calibrate->add_option("--frame", ko.frame, "Frame to fit (default: first of the scene)");
    calibrate->add_option("--reference-spp", ko.referenceSpp, "Samples per pixel of the reference")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    calibrate->add_option("--scale", ko.scale, "Resolution multiplier of the fitting renders")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    calibrate->add_option("-t,--threads", ko.threads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024));
    calibrate->add_flag("--box-filter", ko.boxFilter,
                        "The reference averages over each pixel (default: pixel centres, as "
                        "march samples them)");
    addReferenceFileOptions(calibrate, ko.saveReference, ko.loadReference);

    cli::BakeOptions bo;
    auto* bake = app.add_subcommand(
        "bake", "Write the density field of a scene (procedural, SDF-sculpted or simulated) as "
                "fog-volume VDB "
                "files that Houdini or Blender can read");
    bake->add_option("scene", bo.scene, "Scene file (TOML)")->required();
    bake->add_option("-o,--output", bo.output,
                     std::string("VDB path pattern, e.g. clouds.####.vdb. ") +
                         std::string(io::framePatternSyntax()))
        ->required();
    bake->add_option("-f,--frames", bo.frames, "Frames to bake (default: the scene's `frames`)");
    bake->add_option("-s,--set", bo.overrides, "Override a scene value (as for render)")
        ->allow_extra_args(false);
    bake->add_option("--grid", bo.grid, "Name of the density grid")->capture_default_str();
    bake->add_option("--voxel", bo.voxel,
                     "Voxel size in world units (default: the majorant cell the plan picks)")
        ->check(CLI::NonNegativeNumber);
    bake->add_option("-t,--threads", bo.threads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024));
    bake->add_flag("--level-set", bo.levelSet,
                   "Also write each [[solid]] as a narrow-band level set (grid \"surface\", or "
                   "\"surface_1\", \"surface_2\", ... for several), re-distanced from its "
                   "surface when the box holds all of it");
    bake->add_option("--level-set-grid", bo.levelSetGrid, "Name of the level-set grid(s)")
        ->capture_default_str();
    bake->add_option("--half-width", bo.halfWidth,
                     "Narrow band of the level sets, in voxels each side of the surface")
        ->capture_default_str()
        ->check(CLI::Range(1.0f, 64.0f));
    bake->add_flag("--velocity", bo.velocity,
                   "Also write the field's velocity (its wind, world units/s) as a vec3s grid "
                   "\"velocity\", cell-centred, over the active density voxels dilated by at "
                   "least one voxel; refused for a field that does not move");
    bake->add_option("--velocity-grid", bo.velocityGrid, "Name of the velocity grid")
        ->capture_default_str();
    std::vector<float> bakeBox;
    bake->add_option("--box", bakeBox,
                     "xmin,ymin,zmin,xmax,ymax,zmax: the box the level sets are baked in (needed "
                     "for an unbounded solid such as a ground plane)")
        ->delimiter(',')
        ->expected(6);

    cli::BenchVdbOptions vo;
    auto* bench = app.add_subcommand(
        "bench-vdb-render",
        "Render a VDB scene with OpenVDB's own VolumeRender (the renderer behind vdb_render) and "
        "with Nimbus march in single scattering, in one process; print the time and the error "
        "of each against a very-fine-step Nimbus reference, over a ladder of steps for both");
    bench
        ->add_option("scene", vo.scene,
                     "Scene file (TOML) with [field] kind = \"vdb\", or a .vdb file (its density "
                     "grid framed at 640x360 as converge --suite frames it, one-voxel steps, "
                     "the sun 30 degrees up from the image's right)")
        ->required();
    bench->add_option("-s,--set", vo.overrides, "Override a scene value (as for render)")
        ->allow_extra_args(false);
    bench->add_option("--frame", vo.frame, "Frame to render (default: first of the scene)");
    bench->add_option("--scale", vo.scale, "Resolution multiplier for every render")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    bench
        ->add_option("-t,--threads", vo.threads,
                     "Worker threads of both renderers (0 = all cores; default: render.threads)")
        ->check(CLI::Range(0, 1024));
    bench
        ->add_option("--ladder", vo.ladder,
                     "nimbus rungs: multipliers of render.step, render.step_growth and "
                     "render.shadow_step (render.shadow_growth kept)")
        ->delimiter(',')
        ->capture_default_str();
    bench
        ->add_option("--vdb-ladder", vo.vdbLadder,
                     "VolumeRender rungs: multipliers of --vdb-step and --vdb-shadow-step")
        ->delimiter(',')
        ->capture_default_str();
    bench->add_option("--vdb-step", vo.vdbStep, "VolumeRender primary step at x1, in voxels")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    bench
        ->add_option("--vdb-shadow-step", vo.vdbShadowStep,
                     "VolumeRender shadow step at x1, in voxels")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    bench
        ->add_option("--vdb-steps", vo.vdbSteps,
                     "More VolumeRender rungs: primary:shadow steps in voxels (empty: none)")
        ->delimiter(',')
        ->capture_default_str();
    bench->add_option("--vdb-cutoff", vo.vdbCutoff,
                      "VolumeRender cutoff (density threshold and early exit on |T|^2; default "
                      "3 render.epsilon^2: the same early exit as march)");
    bench->add_flag("!--no-vdb-defaults", vo.vdbDefaults,
                    "Do not add a VolumeRender row with vdb_render's own defaults (steps 1 and 3 "
                    "voxels, cutoff 0.005)");
    bench
        ->add_option("--reference-step", vo.referenceStep,
                     "Step multiplier of the nimbus reference (steps and shadow growth; early "
                     "exit at 1e-4)")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    bench->add_flag(
        "--check-reference", vo.checkReference,
        "Also render the reference at twice its step and print their difference (at first "
        "order, about the reference's own error)");
    bench
        ->add_option("--repeat", vo.repeat,
                     "Rounds over all rungs; each rung's fastest time is kept (the reference is "
                     "rendered once)")
        ->capture_default_str()
        ->check(CLI::PositiveNumber);
    bench->add_option("--output-dir", vo.outputDir,
                      "Write every image (reference, each rung) as EXR and PNG preview here");
    bench->add_option("--csv", vo.csv, "Also write the table as CSV");
    bench->footer(
        "The same problem for both (see plugin/vdb/volume_render_baseline.h):\n"
        "  VolumeRender computes L += lightColor * scattering/(scattering+absorption) * T_sun * "
        "T * (1 - exp(-sigma_t rho step)),\n"
        "  a single-scattering march with a phase function of 1, no sky, no multiple "
        "scattering, coefficients and\n"
        "  steps per VOXEL length. Nimbus is set to: medium.phase isotropic (1/(4 pi)), "
        "render.octaves 1,\n"
        "  render.inscatter none, sky none, background transparent, march. VolumeRender gets: "
        "light colour =\n"
        "  sun irradiance / (4 pi), light gain 0 (vdb_render's 0.2 imitates multiple "
        "scattering), light direction =\n"
        "  sun direction, scattering/absorption = sigma_s/sigma_a * density_scale * "
        "field.density * voxel size,\n"
        "  a PerspectiveCamera at camera.position turned by lookAt(camera.look_at, camera.up), "
        "aperture 41.2136 mm and\n"
        "  the focal length giving camera.fov vertically at width/height (rays checked equal), "
        "the same\n"
        "  resolution and thread count, steps in voxels. Uniform voxels only (VolumeRender's "
        "requirement).\n"
        "  Differences left: VolumeRender samples a fixed lattice without jitter, starts its "
        "shadow samples a whole\n"
        "  shadow step from the point (too much light, first order in that step), skips "
        "densities below its cutoff\n"
        "  and ends rays at |T|^2 < cutoff (default 3 render.epsilon^2: march's early exit). "
        "The reference is march with\n"
        "  every step and the shadow growth times --reference-step and an early exit at 1e-4; "
        "the rungs keep the\n"
        "  scene's render.epsilon and jitter.\n"
        "Times: Nimbus Renderer::render (majorant grid included); VolumeRender intersector "
        "setup + render; grid\n"
        "loading excluded for both. Errors: RMSE over RGBA against the reference, and relative "
        "to its RMS.\n"
        "Example:\n"
        "  nimbus bench-vdb-render examples/scenes/smoke1.toml --check-reference --output-dir "
        "out/bench");

    cli::StressOptions so;
    auto* stress = app.add_subcommand(
        "stress", "Numerical stability on stiff and extreme cases: run the stress cases in "
                  "process and print, per case, its figures and PASS, DEGRADED or FAIL "
                  "(exit 1 when a case fails)");
    stress->add_flag("--quick", so.quick,
                     "The short list of cases at 16x9 pixels (under a "
                     "minute); default: every case at 32x18");
    stress->add_option("--csv", so.csv, "Also write the table as CSV");
    stress->add_option("--filter", so.filter,
                       "Run only the cases whose name contains this, e.g. tau/ or /pathtrace");
    stress
        ->add_option("--case-limit", so.caseLimit,
                     "Stop the whole run (exit 1, naming the case) when one case runs longer "
                     "than this many seconds: a case that hangs (default: 40x the render "
                     "budget, 120 s with --quick, 800 s without)")
        ->check(CLI::PositiveNumber);
    stress->footer(
        "Cases (docs/stress.md): every integrator (march, pathtrace, photons = march with "
        "multiple_scattering\n"
        "  photons, photonsky = the same with photon_sky, diffusion = march with the grid, "
        "lightvol = march\n"
        "  with shadow = volume) over the field kinds\n"
        "  (homogeneous, cumulus, a VDB grid, gardner, sdf): optical thickness per step 1e-6 to "
        "1e4, density\n"
        "  scales 1e-12 to 1e12, an albedo-1 cube of 1e6 mean free paths (a white furnace, "
        "and sunlit\n"
        "  against the closed form of its single scattering), HG g at +-0.999, "
        "+-0.9999 and +-1,\n"
        "  the sun at the zenith, grazing and below the horizon, the camera inside the medium "
        "and 1e3 to 1e7\n"
        "  units out, world scales and voxel sizes 1e-4 to 1e6 (images compared), steps larger "
        "than the volume\n"
        "  and of 1e-9, march's error against its step, NaN/Inf/negative voxels, empty and "
        "one-voxel grids,\n"
        "  long frame ranges.\n"
        "Checks: no NaN/Inf or negative value in RGBA and the AOVs, transmittance in [0,1] and "
        "non-increasing\n"
        "  along a ray, a white furnace (albedo 1, uniform sky of 1) at most 1 + 4 standard "
        "errors (photons:\n"
        "  5 seeds' frame means, 7 standard errors), march's\n"
        "  error falling by 1.6x or more per halving of the step.\n"
        "  Sunlit frames: no pixel above the sky's brightest + E_sun (phase peak + 1).\n"
        "  DEGRADED: bounded but not exact, with the reason (a depth cap, a time budget: renders "
        "that would\n"
        "  not end are cancelled after it, a warning of the plan).\n"
        "Known failures (docs/stress.md) are left out of --quick and named in its summary; the "
        "full run fails on them.\n"
        "Examples:\n"
        "  nimbus stress --quick\n"
        "  nimbus stress --filter stiff/ --csv stiff.csv");

    cli::RtOptions to; // `nimbus rt`: plugin/cli/rt.cpp
    auto* rt = app.add_subcommand(
        "rt", "Render the frames of a scene on the GPU (the GLSL march pass over a headless "
              "OpenGL 4.5 context; Mesa llvmpipe without a GPU) to the same EXR files as render; "
              "refuses (exit 2) what the GPU path does not support yet, naming the key "
              "(docs/realtime.md)");
    rt->add_option("scene", to.scene, "Scene file (TOML)")->required();
    rt->add_option("-f,--frames", to.frames, "Frames to render (default: the scene's `frames`)");
    rt->add_option("-s,--set", to.overrides, "Override a scene value (as for render)")
        ->allow_extra_args(false);
    rt->add_option("-o,--output", to.output, "EXR path pattern (default: the scene's output.path)");
    rt->add_option("--accumulate", to.accumulate,
                   "Temporal accumulation: each frame is the average of N renders of it, each "
                   "with its own jitter (the step and shadow jitter and the pixel-sample offsets; "
                   "pass 1 is the frame without accumulation): the jitter noise falls as "
                   "1/sqrt(N), the bias of a coarse render.step stays (measured in "
                   "docs/realtime.md)")
        ->check(CLI::Range(1, 4096));
    rt->add_flag("--gpu-display", to.gpuDisplay,
                 "Apply the preview's display/view transform (output.display, output.view) on "
                 "the GPU: OpenColorIO's GLSL shader with its LUT textures, instead of OCIO's "
                 "CPU processor (the EXR is unchanged; docs/realtime.md)");
    rt->add_flag("--explain", to.explain,
                 "Print the plan of each frame and what the shader is compiled with, and exit");
    rt->add_flag("-q,--quiet", to.quiet, "Only errors and warnings");

    cli::ExportGlslOptions eo; // `nimbus export-glsl`: plugin/cli/export_glsl.cpp
    auto* exportGlsl = app.add_subcommand(
        "export-glsl",
        "Write one frame's GPU march shader for engines to a folder: march.comp (GLSL 4.30 "
        "compute, only the features the frame uses: the others' code is not in the text), "
        "params.json (every parameter-block member: name, type, std430 offset, value, meaning, "
        "units; bindings, workgroup size, dispatch, output layout) and params.bin (the block's "
        "bytes). Refuses (exit 2) what `nimbus rt` refuses, naming the key (docs/realtime.md, "
        "\"Export for engines\")");
    exportGlsl->add_option("scene", eo.scene, "Scene file (TOML)")->required();
    exportGlsl->add_option("-o,--output", eo.output, "Folder to write (created)")->required();
    exportGlsl->add_option("--frame", eo.frame, "Frame to export (default: first of the scene)");
    exportGlsl->add_option("-s,--set", eo.overrides, "Override a scene value (as for render)")
        ->allow_extra_args(false);

    auto* reference = app.add_subcommand("reference", "Print the scene-file reference (Markdown)");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int rc = app.exit(e);
        return rc == 0 ? 0 : cli::kExitBadInput;
    }

    // an empty value given on purpose is a mistake, not a request for the scene's value
    for (auto [cmd, opt] :
         {std::pair{render, "--frames"}, std::pair{render, "--output"}, std::pair{bake, "--frames"},
          std::pair{bake, "--output"}, std::pair{rt, "--frames"}, std::pair{rt, "--output"},
          std::pair{exportGlsl, "--output"}})
        if (*cmd && cmd->count(opt) && cmd->get_option(opt)->as<std::string>().empty()) {
            std::fprintf(stderr, "nimbus: error: %s: %s is empty\n", cmd->get_name().c_str(), opt);
            return cli::kExitBadInput;
        }
    if (*render) return run(cli::Command::Render, &ro);
    if (*converge) {
        if (co.suite) {
            // the ladder's options mean nothing to the suite
            for (const char* opt : {"--frame", "--ladder", "--reference-step", "--reference-spp",
                                    "--pathtrace-ladder", "--photon-ladder", "--scale", "--plot",
                                    "--box-filter", "--save-reference", "--reference"})
                if (converge->count(opt)) {
                    std::fprintf(stderr, "nimbus: error: converge: %s does not apply to --suite\n",
                                 opt);
                    return cli::kExitBadInput;
                }
        } else {
            if (co.scene.empty()) {
                std::fprintf(stderr, "nimbus: error: converge: a scene file is required (or "
                                     "--suite)\nRun with --help for more information.\n");
                return cli::kExitBadInput;
            }
            for (const char* opt : {"--suite-data", "--suite-dir", "--suite-filter", "--suite-size",
                                    "--suite-spp", "--suite-noise", "--suite-seconds",
                                    "--suite-max-spp", "--suite-max-depth", "--suite-rerender"})
                if (converge->count(opt)) {
                    std::fprintf(stderr, "nimbus: error: converge: %s needs --suite\n", opt);
                    return cli::kExitBadInput;
                }
        }
        return run(cli::Command::Converge, &co);
    }
    if (*calibrate) return run(cli::Command::Calibrate, &ko);
    if (*bake) {
        if (bake->count("--box")) {
            const Box box{vec3(bakeBox[0], bakeBox[1], bakeBox[2]),
                          vec3(bakeBox[3], bakeBox[4], bakeBox[5])};
            if (!std::all_of(bakeBox.begin(), bakeBox.end(),
                             [](float v) { return std::isfinite(v); }) ||
                !glm::all(glm::lessThan(box.lo, box.hi))) {
                std::fprintf(stderr, "nimbus: error: bake: --box needs finite "
                                     "xmin,ymin,zmin,xmax,ymax,zmax with each min below its "
                                     "max\n");
                return cli::kExitBadInput;
            }
            bo.box = box;
        }
        if ((bo.box || bake->count("--half-width") || bake->count("--level-set-grid")) &&
            !bo.levelSet) {
            std::fprintf(stderr, "nimbus: error: bake: --box, --half-width and "
                                 "--level-set-grid apply to --level-set\n");
            return cli::kExitBadInput;
        }
        return run(cli::Command::Bake, &bo);
    }
    if (*bench) return run(cli::Command::BenchVdb, &vo);
    if (*stress) return run(cli::Command::Stress, &so);
    if (*rt) return run(cli::Command::Rt, &to);
    if (*exportGlsl) return run(cli::Command::ExportGlsl, &eo);
    if (*reference) return run(cli::Command::Reference, nullptr);
    return 0;
}

} // namespace
