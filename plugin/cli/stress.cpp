/// @file stress.cpp
/// @brief `nimbus stress [--quick]`: the numerical-stability report of issue 17 (docs/stress.md).
///
/// A list of cases run in process on core's Renderer with scenes built in code (tiny images):
/// every integrator (march, pathtrace, photons, diffusion, light volume) over the field kinds
/// (homogeneous, cumulus, a VDB grid built here, Gardner, SDF) at stiff and extreme settings:
/// optical thickness per step from 1e-6 to 1e4, density scales from 1e-12 to 1e12, an albedo-1
/// medium a million mean free paths thick (a white furnace, and sunlit against the closed form of
/// its single scattering), HG g near and at +-1, the sun at the zenith, grazing
/// and below the horizon, the camera inside the medium and 1e7 units out, voxel sizes and world
/// scales from 1e-4 to 1e6 (scale invariance: images compared), steps larger than the volume and
/// of 1e-9, NaN/Inf/negative voxels, empty and single-voxel grids, long frame ranges. Each case
/// prints its figures and a verdict: PASS, DEGRADED (the result is bounded but not what an exact
/// method gives, and the case says why: a depth cap, a time budget, a warning) or FAIL. Work that
/// would not end is bounded by a time budget: a timer thread sets the renderer's cancel flag
/// (core/cancel.h) and the case reports "stopped at budget".
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include <unistd.h>

#include <glm/gtc/matrix_transform.hpp>

#include "core/camera.h"
#include "core/media/phase.h"
#include "core/render.h"
#include "plugin/cli/commands.h"
#include "plugin/cli/common.h"
#include "plugin/cli/stress_checks.h"
#include "plugin/io/frames.h"
#include "plugin/io/scene_file.h"
#include "plugin/vdb/vdb_field.h"
#include "plugin/vdb/vdb_writer.h"

namespace nimbus::cli {
namespace {

namespace fs = std::filesystem;
using namespace nimbus::stress;
using Clock = std::chrono::steady_clock;

enum class Verdict { Pass = 0, Degraded = 1, Fail = 2 };

const char* verdictName(Verdict v) {
    return v == Verdict::Pass ? "PASS" : v == Verdict::Degraded ? "DEGRADED" : "FAIL";
}

/// What a case found.
struct Outcome {
    Verdict verdict = Verdict::Pass;
    std::vector<std::string> notes;
    std::vector<std::pair<std::string, std::string>> figures;
    // for the summary's worst figures
    double furnaceExcess = -INFINITY; ///< furnace mean minus the sky, in standard errors
    double furnaceMean = NAN;
    double scaleDiff = NAN; ///< relative image difference of a scaled world
    double farDiff = NAN;   ///< relative image difference far from the origin
    std::uint64_t nonFinite = 0;

    void fail(const std::string& why) {
        verdict = Verdict::Fail;
        notes.push_back(why);
    }
    void degrade(const std::string& why) {
        verdict = std::max(verdict, Verdict::Degraded);
        notes.push_back(why);
    }
    void note(const std::string& what) { notes.push_back(what); }
    void fig(const std::string& k, double v) {
        char b[64];
        std::snprintf(b, sizeof b, "%.4g", v);
        figures.emplace_back(k, b);
    }
    void fig(const std::string& k, const std::string& v) { figures.emplace_back(k, v); }
};

std::string fmt(const char* f, double v) {
    char b[256];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

enum class Method { March, PathTrace, Photons, PhotonSky, Diffusion, LightVolume };
constexpr Method kMethods[] = {Method::March,     Method::PathTrace, Method::Photons,
                               Method::PhotonSky, Method::Diffusion, Method::LightVolume};

const char* methodName(Method m) {
    switch (m) {
    case Method::March:
        return "march";
    case Method::PathTrace:
        return "pathtrace";
    case Method::Photons:
        return "photons";
    case Method::PhotonSky:
        return "photonsky";
    case Method::Diffusion:
        return "diffusion";
    case Method::LightVolume:
        return "lightvol";
    }
    return "?";
}

bool deterministic(Method m) {
    return m != Method::PathTrace && m != Method::Photons && m != Method::PhotonSky;
}

/// Shared by the cases of one run.
struct Context {
    bool quick = false;
    int width = 32, height = 18;
    double budget = 20.0;     ///< hang guard of every render, seconds
    double shortBudget = 3.0; ///< renders expected not to end (a step of 1e-9)
    fs::path dir;             ///< temp folder for the VDB grids
    std::map<std::string, std::pair<GridBinding, std::vector<std::string>>> grids;
    int gridFiles = 0;
};

void applyMethod(SceneDesc& s, Method m, const Context& c) {
    s.render.integrator = Integrator::March;
    s.render.shadow = ShadowMethod::March;
    s.render.multipleScattering = MultipleScattering::None;
    switch (m) {
    case Method::March:
        break;
    case Method::PathTrace:
        s.render.integrator = Integrator::PathTrace;
        s.render.spp = c.quick ? 4 : 16;
        break;
    case Method::PhotonSky:
        // the sky's light traced by photons too (render.photon_sky): its photons start on the
        // rectangle that covers the field's box seen from a direction of the sphere
        s.render.photonSky = true;
        [[fallthrough]];
    case Method::Photons:
        s.render.multipleScattering = MultipleScattering::Photons;
        s.render.photons = c.quick ? 4000 : 20000;
        s.render.photonCellScale = 1.0f; // the light-volume grid: its cell, whatever the count
        break;
    case Method::Diffusion:
        s.render.multipleScattering = MultipleScattering::Grid;
        break;
    case Method::LightVolume:
        s.render.shadow = ShadowMethod::Volume;
        break;
    }
}

CameraDesc camera(vec3 pos, vec3 at, float fov, const Context& c) {
    CameraDesc cam;
    cam.position = pos;
    cam.lookAt = at;
    cam.fovY = fov;
    cam.width = c.width;
    cam.height = c.height;
    return cam;
}

void defaultLight(SceneDesc& s) {
    const float el = glm::radians(40.0f), az = glm::radians(30.0f);
    s.sun.direction = vec3(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
    s.sun.irradiance = vec3(3.0f);
    s.render.background = Background::Sky;
}

/// A homogeneous box [-1, 1]^3 seen from -z.
SceneDesc homogeneousScene(const Context& c) {
    SceneDesc s;
    s.camera = camera(vec3(0.0f, 0.0f, -4.0f), vec3(0.0f), 45.0f, c);
    s.field.kind = FieldKind::Homogeneous;
    s.field.homogeneous.box = Box{vec3(-1.0f), vec3(1.0f)};
    s.medium.sigma_s = vec3(2.0f);
    defaultLight(s);
    return s;
}

/// A small cumulus layer (direct noise) seen from its side.
SceneDesc cumulusScene(const Context& c) {
    SceneDesc s;
    s.camera = camera(vec3(0.0f, 2.5f, -9.0f), vec3(0.0f, 2.8f, 0.0f), 50.0f, c);
    s.field.kind = FieldKind::Cumulus;
    s.field.cumulus.bounds = Box{vec3(-6.0f, 1.5f, -6.0f), vec3(6.0f, 4.0f, 6.0f)};
    s.field.cumulus.eval = NoiseEval::Direct;
    s.field.cumulus.baseOctaves = 2;
    s.field.cumulus.detailOctaves = 1;
    s.medium.sigma_s = vec3(6.0f);
    s.render.step = 0.05f;
    s.render.shadowStep = 0.05f;
    defaultLight(s);
    return s;
}

SceneDesc gardnerScene(const Context& c) {
    SceneDesc s;
    s.camera = camera(vec3(0.0f, 4.0f, -24.0f), vec3(0.0f, 4.0f, 0.0f), 45.0f, c);
    s.field.kind = FieldKind::Gardner;
    s.field.gardner.scatter.enabled = true;
    s.medium.sigma_s = vec3(2.0f);
    defaultLight(s);
    return s;
}

SceneDesc sdfScene(const Context& c) {
    SceneDesc s;
    s.camera = camera(vec3(0.0f, 0.0f, -4.0f), vec3(0.0f), 45.0f, c);
    s.field.kind = FieldKind::Sdf;
    s.field.sdf.root = sdfSphere(1.0f);
    s.medium.sigma_s = vec3(4.0f);
    defaultLight(s);
    return s;
}

/// A VDB blob: 16^3 voxels of size `voxel`, density 1 - r^2 (r = distance from the centre in
/// units of 8 voxels), centred on `centre`; `flaw` adds NaN, Inf and negative voxels ("bad"),
/// or makes the grid "empty" or one voxel ("single").
GridBinding vdbBlob(Context& c, double voxel, glm::dvec3 centre, const std::string& flaw,
                    std::vector<std::string>& warnings) {
    char keyb[160];
    std::snprintf(keyb, sizeof keyb, "%.17g/%.17g/%.17g/%.17g/%s", voxel, centre.x, centre.y,
                  centre.z, flaw.c_str());
    const std::string key = keyb;
    auto it = c.grids.find(key);
    if (it != c.grids.end()) {
        warnings.insert(warnings.end(), it->second.second.begin(), it->second.second.end());
        return it->second.first;
    }
    const fs::path file = c.dir / ("grid" + std::to_string(c.gridFiles++) + ".vdb");
    if (flaw.empty() && std::abs(centre.x) + std::abs(centre.y) + std::abs(centre.z) == 0.0) {
        // a scale-translate map (OpenVDB refuses an affine map of determinant below ~1e-15: a
        // voxel of 1e-5)
        std::vector<float> dense(16 * 16 * 16);
        for (int k = 0; k < 16; ++k)
            for (int j = 0; j < 16; ++j)
                for (int i = 0; i < 16; ++i) {
                    const double x = (i - 7.5) / 8.0, y = (j - 7.5) / 8.0, z = (k - 7.5) / 8.0;
                    dense[size_t(i + 16 * (j + 16 * k))] =
                        float(std::max(0.0, 1.0 - (x * x + y * y + z * z)));
                }
        vdb::writeFogVdb(file.string(), "density", 16, 16, 16, dense.data(),
                         vec3(centre - glm::dvec3(7.5 * voxel)), vec3(float(voxel)));
    } else {
        vdb::VdbGridSpec g;
        g.worldFromIndex = glm::translate(glm::dmat4(1.0), centre - glm::dvec3(7.5 * voxel)) *
                           glm::scale(glm::dmat4(1.0), glm::dvec3(voxel));
        if (flaw == "single") {
            g.voxels.push_back({ivec3(7, 7, 7), 1.0, true});
        } else if (flaw != "empty") {
            for (int k = 0; k < 16; ++k)
                for (int j = 0; j < 16; ++j)
                    for (int i = 0; i < 16; ++i) {
                        const double x = (i - 7.5) / 8.0, y = (j - 7.5) / 8.0, z = (k - 7.5) / 8.0;
                        const double v = 1.0 - (x * x + y * y + z * z);
                        if (v > 0.0) g.voxels.push_back({ivec3(i, j, k), v, true});
                    }
            if (flaw == "bad")
                for (size_t n = 0; n < g.voxels.size(); n += 7)
                    g.voxels[n].value = n % 3 == 0   ? double(NAN)
                                        : n % 3 == 1 ? double(INFINITY)
                                                     : -5.0;
        }
        vdb::writeVdbGrids(file.string(), {g});
    }
    FieldDesc fd;
    fd.kind = FieldKind::Vdb;
    fd.vdb.path = file.string();
    std::vector<std::string> w;
    GridBinding b = vdb::bindVdbField(fd, "", 1, w);
    c.grids[key] = {b, w};
    warnings.insert(warnings.end(), w.begin(), w.end());
    return b;
}

/// A scene with the VDB blob of `vdbBlob` seen from -z at 4 blob radii.
SceneDesc vdbScene(const Context& c, double voxel, glm::dvec3 centre) {
    SceneDesc s;
    const double r = 8.0 * voxel;
    s.camera = camera(vec3(centre + glm::dvec3(0.0, 0.0, -4.0 * r)), vec3(centre), 45.0f, c);
    s.field.kind = FieldKind::Vdb;
    s.field.vdb.path = "(built by nimbus stress)";
    s.medium.sigma_s = vec3(float(3.0 / r));
    defaultLight(s);
    return s;
}

/// Ends the process (exit 1) when one case runs longer than `limit` seconds, naming the case: a
/// case that hangs (a wait that nothing bounds) fails the run instead of stopping it for ever.
/// The renders' time budgets (Budget) stop the work that is expected not to end; this is the
/// bound on everything else.
class CaseWatchdog {
  public:
    CaseWatchdog(double limit, fs::path dir) : limit_(limit), dir_(std::move(dir)) {
        thread_ = std::thread([this] { watch(); });
    }
    ~CaseWatchdog() {
        {
            std::lock_guard<std::mutex> lock(m_);
            done_ = true;
        }
        cv_.notify_all();
        thread_.join();
    }
    void begin(const std::string& name) {
        std::lock_guard<std::mutex> lock(m_);
        name_ = name;
        start_ = Clock::now();
        running_ = true;
        cv_.notify_all();
    }
    void end() {
        std::lock_guard<std::mutex> lock(m_);
        running_ = false;
        cv_.notify_all();
    }

  private:
    void watch() {
        std::unique_lock<std::mutex> lock(m_);
        while (!done_) {
            if (!running_) {
                cv_.wait(lock);
                continue;
            }
            const auto start = start_;
            const auto until = start + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(limit_));
            if (cv_.wait_until(lock, until, [&] { return done_ || !running_ || start_ != start; }))
                continue;
            // The case's lines so far are printed (flushed per case); the CSV rows too.
            const std::string m = "nimbus: error: stress: case " + name_ + " has run " +
                                  fmt("%.3g s", secondsSince(start)) +
                                  fmt(", over the limit of %g s per case (--case-limit): "
                                      "stopping the run (a wait that nothing bounds?)\n",
                                      limit_);
            [[maybe_unused]] const ssize_t w = ::write(STDERR_FILENO, m.data(), m.size());
            std::error_code ec;
            fs::remove_all(dir_, ec);
            _exit(kExitInternal);
        }
    }

    double limit_;
    fs::path dir_;
    std::mutex m_;
    std::condition_variable cv_;
    std::string name_;
    Clock::time_point start_{};
    bool running_ = false;
    bool done_ = false;
    std::thread thread_;
};

/// Sets the cancel flag after `seconds` unless destroyed first.
class Budget {
  public:
    explicit Budget(double seconds) {
        thread_ = std::thread([this, seconds] {
            std::unique_lock<std::mutex> lock(m_);
            if (!cv_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return done_; }))
                cancel.store(true);
        });
    }
    ~Budget() {
        {
            std::lock_guard<std::mutex> lock(m_);
            done_ = true;
        }
        cv_.notify_all();
        thread_.join();
    }
    std::atomic<bool> cancel{false};

  private:
    std::mutex m_;
    std::condition_variable cv_;
    bool done_ = false;
    std::thread thread_;
};

struct Frame {
    Framebuffer fb;
    RenderStats stats;
    FramePlan plan;
    bool completed = false;
    bool refused = false;
    double seconds = 0.0;
    FrameCheck check;
    /// photon frames: each seed's mean RGB value (render()), what the energy and white-furnace
    /// checks average
    std::vector<double> seedMeans;
};

/// Renders `s` once with a time budget (the global interrupt flag, SIGINT/SIGTERM, stops it too).
Frame renderOnce(const SceneDesc& s, const FrameBindings& b, double budget, AovSet aovs) {
    Frame f;
    Renderer r(s);
    f.plan = r.plan(1, b, aovs);
    if (!f.plan.refusal.empty()) {
        f.refused = true;
        return f;
    }
    const auto t0 = Clock::now();
    Budget guard(budget);
    std::atomic<bool> both{false};
    RenderCallbacks cb;
    // the renderer polls one flag: a watcher folds the interrupt flag into the budget's
    cb.cancel = &guard.cancel;
    std::thread watch([&] {
        while (!both.load()) {
            if (gCancel.load()) guard.cancel.store(true);
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
    });
    f.completed = r.render(f.plan, b, f.fb, f.stats, cb);
    both.store(true);
    watch.join();
    f.seconds = secondsSince(t0);
    f.check = checkFrame(f.fb);
    return f;
}

/// Seeds a photon frame's energy checks average over (its own and kSeeds - 1 more), and how many
/// of their standard errors the mean may exceed a bound by (Student's t with 4 degrees of
/// freedom: about 0.1% of unbiased frames above it).
constexpr int kSeeds = 5;
constexpr double kSeedZ = 7.0;

/// Renders `s` with a time budget (the global interrupt flag, SIGINT/SIGTERM, stops it too).
/// A photon frame that completes is rendered with kSeeds - 1 more seeds: one photon map's noise
/// is shared by every pixel, so the pixels' spread says nothing of the frame mean's; the seeds'
/// frame means do (Frame::seedMeans; the frame itself stays the first seed's). Every seed's
/// NaN/Inf, negative and replaced values are counted.
Frame render(const SceneDesc& s, const FrameBindings& b, double budget,
             AovSet aovs = AovSet{true, true}) {
    Frame f = renderOnce(s, b, budget, aovs);
    if (!f.completed || f.refused || s.render.multipleScattering != MultipleScattering::Photons)
        return f;
    std::vector<double> means{f.check.meanRgb};
    for (int k = 1; k < kSeeds; ++k) {
        SceneDesc t = s;
        t.render.seed = s.render.seed + 7919u * std::uint32_t(k);
        const Frame g = renderOnce(t, b, budget, aovs);
        f.check.nonFinite += g.check.nonFinite;
        f.check.negative += g.check.negative;
        f.stats.nonFinite += g.stats.nonFinite;
        f.seconds += g.seconds;
        if (!g.completed) return f; // no spread: the checks take the first frame alone
        means.push_back(g.check.meanRgb);
    }
    f.seedMeans = std::move(means);
    return f;
}

/// Mean and standard error of the mean of a few values (n - 1 in the variance).
std::pair<double, double> meanAndSe(const std::vector<double>& v) {
    double m = 0.0, q = 0.0;
    for (double x : v) m += x;
    m /= double(v.size());
    for (double x : v) q += (x - m) * (x - m);
    return {m, std::sqrt(q / double(v.size() - 1) / double(v.size()))};
}

Frame render(const SceneDesc& s, double budget, AovSet aovs = AovSet{true, true}) {
    return render(s, FrameBindings{}, budget, aovs);
}

/// The checks every rendered frame gets: values finite, non-negative and in range (RGBA and
/// AOVs), the renderer's own count of replaced non-finite samples, the budget, the plan's
/// warnings (as notes).
void judge(Outcome& o, const Frame& f, double budget, const std::string& what = "") {
    const std::string p = what.empty() ? "" : what + ": ";
    if (f.refused) {
        o.degrade(p + "refused: " + f.plan.refusal);
        return;
    }
    for (const std::string& w : f.plan.warnings) o.note(p + "warned: " + w);
    o.nonFinite += f.check.nonFinite + f.stats.nonFinite;
    if (!f.completed) o.degrade(p + "stopped at budget (" + fmt("%g s", budget) + ", cancel flag)");
    if (f.check.nonFinite) o.fail(p + std::to_string(f.check.nonFinite) + " NaN/Inf values");
    if (f.stats.nonFinite)
        o.fail(p + std::to_string(f.stats.nonFinite) + " non-finite pixels replaced by 0");
    if (f.check.negative) o.fail(p + std::to_string(f.check.negative) + " negative values");
    if (f.check.alphaOutside)
        o.fail(p + std::to_string(f.check.alphaOutside) + " alpha values outside [0,1]");
    if (f.check.transOutside)
        o.fail(p + std::to_string(f.check.transOutside) + " transmittances outside [0,1]");
}

/// Adds a frame's common figures, and checks a loose energy bound of a sunlit frame: no
/// radiance above the sky's brightest plus the sun's irradiance times (the phase function's
/// peak + 1) (single scattering reaches at most E p_max; a thick isotropic albedo-1 medium
/// reflects at most about 0.7 E). A pathtrace frame is held to it in the mean (one path may
/// carry more), the others pixel by pixel.
void figures(Outcome& o, const Frame& f, const SceneDesc& s, bool stochastic) {
    o.fig("max", f.check.maxRgb);
    o.fig("mean", f.check.meanRgb);
    if (!f.fb.transmittance.empty()) o.fig("Tmin", f.check.minT);
    if (f.refused || !f.completed) return;
    const vec3 skyMax = s.sky.kind == SkyKind::None      ? vec3(0.0f)
                        : s.sky.kind == SkyKind::Uniform ? s.sky.zenith
                                                         : glm::max(s.sky.zenith, s.sky.horizon);
    const double sky = std::max({skyMax.x, skyMax.y, skyMax.z});
    double bound = sky;
    if (s.sun.enabled) {
        const double e = std::max({s.sun.irradiance.x, s.sun.irradiance.y, s.sun.irradiance.z});
        bound += e * (double(PhaseFunction::fromMedium(s.medium).eval(1.0f).x) + 1.0);
    }
    // a stochastic frame's mean may exceed the bound by its noise: z standard errors, from the
    // seeds' frame means (photons) or the pixels (pathtrace: independent from pixel to pixel)
    double v = stochastic ? f.check.meanRgb : f.check.maxRgb, slack = 0.0;
    std::string over = stochastic ? "mean" : "largest";
    if (stochastic && f.seedMeans.size() >= 2) {
        const auto [m, se] = meanAndSe(f.seedMeans);
        v = m;
        slack = kSeedZ * se;
        over = fmt("mean (%g seeds, ", double(f.seedMeans.size())) + fmt("se %.2g)", se);
    } else if (stochastic) {
        slack = 4.0 * f.check.seRgb;
    }
    if (v > bound * (1.0 + 1e-4) + slack)
        o.fail(std::string("energy not bounded: ") + over +
               fmt(" radiance %.4g above the bound ", v) +
               fmt("%.4g (sky + E (p_max + 1))", bound) +
               (slack > 0.0 ? fmt(" + %.2g", slack) : std::string()));
}

/// The white furnace: albedo 1, no sun, a uniform sky of 1 seen as background too.
SceneDesc furnaceOf(SceneDesc s) {
    s.medium.sigma_s += s.medium.sigma_a;
    s.medium.sigma_a = vec3(0.0f);
    s.sun.enabled = false;
    s.sky.kind = SkyKind::Uniform;
    s.sky.zenith = vec3(1.0f);
    s.sky.horizon = vec3(1.0f);
    s.render.background = Background::Sky;
    return s;
}

void judgeFurnace(Outcome& o, const Frame& f) {
    if (f.refused || !f.completed || f.fb.rgba.empty()) return;
    Furnace w{f.check.meanRgb, f.check.seRgb, f.check.maxRgb};
    double z = 4.0;
    std::string over = "1 + 4 se";
    if (f.seedMeans.size() >= 2) { // photons: the seeds' frame means (render())
        std::tie(w.mean, w.se) = meanAndSe(f.seedMeans);
        z = kSeedZ;
        over = fmt("1 + %g se of ", kSeedZ) + fmt("%g seeds' means", double(f.seedMeans.size()));
        o.fig("seeds", double(f.seedMeans.size()));
    }
    o.fig("furnace", w.mean);
    o.fig("se", w.se);
    o.furnaceMean = w.mean;
    o.furnaceExcess = w.se > 0.0 ? (w.mean - 1.0) / w.se : (w.mean > 1.0 + 1e-4 ? 1e9 : 0.0);
    if (!w.bounded(1.0, z))
        o.fail(fmt("energy not bounded: white furnace mean %.5g > ", w.mean) + over +
               fmt(" (se %.2g)", w.se));
}

// ------------------------------------------------------------------ the cases

struct Case {
    std::string name;
    bool quick; ///< in --quick
    std::function<void(Context&, Outcome&)> run;
    /// A known failure (docs/stress.md): why. Left out of --quick, whose exit code a test and
    /// CI check; the full run runs it and fails on it.
    std::string known = {};
};

/// Marks the cases whose name contains `part` as known failures.
[[maybe_unused]] void markKnown(std::vector<Case>& cs, const std::string& part,
                                const std::string& why) {
    for (Case& k : cs)
        if (k.name.find(part) != std::string::npos) k.known = why;
}

using Cases = std::vector<Case>;

SceneDesc fieldScene(const std::string& kind, Context& c, FrameBindings& b,
                     std::vector<std::string>& warnings) {
    if (kind == "homogeneous") return homogeneousScene(c);
    if (kind == "cumulus") return cumulusScene(c);
    if (kind == "gardner") return gardnerScene(c);
    if (kind == "sdf") return sdfScene(c);
    b.grids = {vdbBlob(c, 0.125, glm::dvec3(0.0), "", warnings)};
    return vdbScene(c, 0.125, glm::dvec3(0.0));
}

void addFieldCases(Cases& cs) {
    for (const char* kind : {"homogeneous", "cumulus", "vdb", "gardner", "sdf"})
        for (Method m : kMethods) {
            const std::string k = kind;
            cs.push_back({"field/" + k + "/" + methodName(m), true, [k, m](Context& c, Outcome& o) {
                              FrameBindings b;
                              std::vector<std::string> w;
                              SceneDesc s = fieldScene(k, c, b, w);
                              applyMethod(s, m, c);
                              const Frame f = render(s, b, c.budget);
                              judge(o, f, c.budget);
                              figures(o, f, s, !deterministic(m));
                              // and the same field as a white furnace
                              const Frame wf = render(furnaceOf(s), b, c.budget);
                              judge(o, wf, c.budget, "furnace");
                              judgeFurnace(o, wf);
                          }});
        }
}

/// Optical thickness per step: a homogeneous cube of side 2, steps 0.05, sigma_t = tau / 0.05.
void addTauCases(Cases& cs) {
    for (double tau : {1e-6, 1e-3, 1.0, 1e2, 1e4})
        for (Method m : kMethods) {
            const bool quick = tau == 1e-6 || tau == 1.0 || tau == 1e4;
            cs.push_back({"tau/" + std::string(methodName(m)) + "/" + fmt("%g", tau), quick,
                          [tau, m](Context& c, Outcome& o) {
                              SceneDesc s = homogeneousScene(c);
                              s.render.step = s.render.shadowStep = 0.05f;
                              s.medium.sigma_s = vec3(float(tau / 0.05));
                              applyMethod(s, m, c);
                              s = furnaceOf(s);
                              s.render.epsilon = 0.0f;
                              o.fig("mfp", 2.0 * tau / 0.05);
                              const Frame f = render(s, c.budget);
                              judge(o, f, c.budget);
                              figures(o, f, s, !deterministic(m));
                              judgeFurnace(o, f);
                              // the centre pixel's ray crosses 2 units: T = exp(-2 sigma_t)
                              if (f.completed && !f.fb.transmittance.empty()) {
                                  const size_t i = size_t(c.height / 2) * c.width + c.width / 2;
                                  const double t = f.fb.transmittance[3 * i];
                                  const double ex = std::exp(-2.0 * tau / 0.05);
                                  o.fig("Tcentre", t);
                                  // pathtrace: ratio tracking at sigma_maj = sigma_t is 0 or 1
                                  // per sample: a binomial's spread over spp samples
                                  const double sd = m == Method::PathTrace
                                                        ? std::sqrt(ex * (1.0 - ex) / s.render.spp)
                                                        : 0.0;
                                  if (std::abs(t - ex) > 1e-4 + 1e-3 * ex + 4.0 * sd)
                                      o.fail(fmt("centre transmittance %.6g", t) +
                                             fmt(", exp(-sigma_t L) = %.6g", ex));
                              }
                          }});
        }
}

/// Density scales on the cumulus (heterogeneous: majorant grids, null collisions).
void addDensityCases(Cases& cs) {
    for (double scale : {1e-12, 1e-6, 1.0, 100.0, 1e6, 1e12})
        for (Method m : kMethods) {
            const bool quick = scale == 1e-12 || scale == 1e12;
            cs.push_back({"density/" + std::string(methodName(m)) + "/" + fmt("%g", scale), quick,
                          [scale, m](Context& c, Outcome& o) {
                              SceneDesc s = cumulusScene(c);
                              s.medium.densityScale = float(scale);
                              applyMethod(s, m, c);
                              const Frame f = render(s, c.budget);
                              judge(o, f, c.budget);
                              figures(o, f, s, !deterministic(m));
                              const Frame wf = render(furnaceOf(s), c.budget);
                              judge(o, wf, c.budget, "furnace");
                              judgeFurnace(o, wf);
                              o.fig("lookups", double(f.stats.lookups()));
                              if ((!f.completed || !wf.completed) && !deterministic(m))
                                  o.note(fmt("delta tracking takes about sigma_maj x length "
                                             "tentative collisions per flight (sigma_t x scale "
                                             "= %.3g per unit here): only the budget bounds "
                                             "the walks",
                                             6.0 * scale));
                          }});
        }
}

/// An albedo-1 cube a million mean free paths across under a uniform sky of 1 (white
/// furnace). What bounds the work: march and the grids stop a ray at transmittance < epsilon
/// (0.01) after a few steps; pathtrace and photons cap a walk at render.max_depth events (2^20
/// by default; at the old default of 256 the cap lost the light of longer walks, DESIGN.md,
/// "Depth caps bias albedo-1 media"); uncapped, a walk in the cube takes up to ~1e12 events and
/// only the time budget ends it.
void addStiffCases(Cases& cs) {
    auto stiff = [](Context& c, Method m) {
        SceneDesc s = homogeneousScene(c);
        s.medium.sigma_s = vec3(5e5f); // side 2: 1e6 mean free paths
        applyMethod(s, m, c);
        return furnaceOf(s);
    };
    for (Method m : kMethods)
        cs.push_back({"stiff/" + std::string(methodName(m)) + "/1e6mfp", true,
                      [m, stiff](Context& c, Outcome& o) {
                          const SceneDesc s = stiff(c, m);
                          const Frame f = render(s, c.budget);
                          judge(o, f, c.budget);
                          judgeFurnace(o, f);
                          o.fig("lookups", double(f.stats.lookups()));
                          if (!deterministic(m)) {
                              o.note("work bounded by render.max_depth = " +
                                     std::to_string(s.render.maxDepth) + " events per walk");
                              if (o.furnaceMean < 0.99)
                                  o.degrade(fmt(m == Method::PhotonSky
                                                    ? "the furnace returns %.3g of the sky: the "
                                                      "sky's photons record their light on "
                                                      "voxels 1e5 mean free paths deep, and a "
                                                      "walk of N scatterings reaches about "
                                                      "sqrt(N) of them in (docs/stress.md)"
                                                    : "the furnace returns %.3g of the sky: "
                                                      "walks cut at render.max_depth lose it",
                                                o.furnaceMean));
                          } else {
                              o.note("work bounded by the early exit at transmittance < "
                                     "render.epsilon");
                          }
                      }});
    cs.push_back({"stiff/pathtrace-uncapped/1e6mfp", true, [stiff](Context& c, Outcome& o) {
                      SceneDesc s = stiff(c, Method::PathTrace);
                      s.render.maxDepth = 1 << 30;
                      s.render.spp = 1;
                      const Frame f = render(s, c.shortBudget);
                      judge(o, f, c.shortBudget);
                      o.fig("lookups", double(f.stats.lookups()));
                      if (f.completed) judgeFurnace(o, f);
                      o.note("max_depth 2^30: only the time budget bounds the walks");
                  }});
}

/// The sun's single scattering off the face of an albedo-1 cube 10 to 1e6 mean free paths
/// across, isotropic: a ray at cosine mu to the face's normal sees E p mu0 / (mu0 + mu) (the
/// half-space's closed form), whatever the steps. march's steps (0.05 here) are up to 2.5e4
/// mean free paths deep, split into 64 at most: it looks at each step's light where the step's
/// transmittance puts it (kern::lightFraction), so the mean over a pixel's samples is right,
/// however noisy one sample is; looked at the sample's own place, the light at 1e6 mean free
/// paths was 0.03 of it. The mean ratio over the pixels must stay within 3% plus 4 standard
/// errors (of the ratios' spread) of 1; pathtrace at max_depth 1 checks the closed form itself.
void addStiffSunCases(Cases& cs) {
    for (Method m : {Method::March, Method::PathTrace})
        for (double mfp : {1e1, 1e3, 1e6})
            cs.push_back(
                {"stiff/sun-single/" + std::string(methodName(m)) + "/" + fmt("%g", mfp) + "mfp",
                 true, [m, mfp](Context& c, Outcome& o) {
                     SceneDesc s;
                     // every pixel on the face z = -1
                     s.camera = camera(vec3(0.0f, 0.0f, -4.0f), vec3(0.0f), 20.0f, c);
                     s.field.kind = FieldKind::Homogeneous;
                     s.field.homogeneous.box = Box{vec3(-1.0f), vec3(1.0f)};
                     s.medium.sigma_s = vec3(float(mfp / 2.0));
                     s.medium.phase = PhaseKind::Isotropic;
                     s.sun.enabled = true;
                     s.sun.direction = glm::normalize(vec3(0.3f, 0.4f, -1.0f));
                     s.sun.irradiance = vec3(1.0f);
                     s.sky.kind = SkyKind::None;
                     applyMethod(s, m, c);
                     s.render.background = Background::Transparent;
                     s.render.inScatter = InScatter::None;
                     s.render.octaves = 1;
                     s.render.step = s.render.shadowStep = 0.05f;
                     s.render.maxDepth = 1;
                     s.render.spp = c.quick ? 16 : 64;
                     s.render.pixelSamples = c.quick ? 16 : 64;
                     const Frame f = render(s, c.budget);
                     judge(o, f, c.budget);
                     if (!f.completed || f.fb.rgba.empty()) return;
                     const Camera cam(s.camera);
                     const double mu0 = -double(s.sun.direction.z);
                     MeanSe ratio; // over the pixels, of the pixel over the closed form
                     for (int y = 0; y < f.fb.height; ++y)
                         for (int x = 0; x < f.fb.width; ++x) {
                             const double mu = cam.generate(x + 0.5f, y + 0.5f).d.z;
                             const double want = mu0 / (mu0 + mu) / (4.0 * 3.14159265358979);
                             ratio.add(f.fb.rgba[4 * (size_t(y) * f.fb.width + x)] / want);
                         }
                     const double mean = ratio.mean(), se = ratio.se();
                     o.fig("ratio", mean);
                     o.fig("se", se);
                     if (std::abs(mean - 1.0) > 4.0 * se + 0.03)
                         o.fail(
                             fmt("the sun's single scattering is %.4g of the closed form", mean));
                 }});
}

/// Numerical normalisation of a phase function over the sphere, 2 pi int p(mu) dmu, with the
/// nodes crowded toward both ends (mu = +-(1 - 10^-x)): the peak of |g| -> 1 lies within
/// (1 - |g|)^2 of the end.
double phaseIntegral(const PhaseFunction& p) {
    double sum = 0.0;
    // mu = 1 - e on the forward half, e from 1e-16 to 1; and mu = -1 + e on the back half
    const int n = 4000;
    for (int side = 0; side < 2; ++side) {
        double prevE = 0.0, prevV = 0.0;
        for (int i = 0; i <= n; ++i) {
            const double e = std::pow(10.0, -16.0 + 16.0 * i / n);
            const double mu = side == 0 ? 1.0 - e : -1.0 + e;
            const double v = double(p.eval(float(mu)).x);
            if (i > 0)
                sum += 0.5 * (v + prevV) * (e - prevE);
            else
                sum += v * e; // [0, e0]
            prevE = e;
            prevV = v;
        }
    }
    return 2.0 * M_PI * sum;
}

void addPhaseCases(Cases& cs) {
    for (double g : {0.999, -0.999, 0.9999, -0.9999, 1.0, -1.0})
        cs.push_back(
            {"phase/hg/" + fmt("%g", g), true, [g](Context&, Outcome& o) {
                 const PhaseFunction p(kern::phaseParamsHG(float(g)));
                 std::uint64_t bad = 0;
                 for (int i = 0; i <= 20000; ++i) {
                     const float mu = -1.0f + 2.0f * float(i) / 20000.0f;
                     const float v = p.eval(mu).x;
                     if (!std::isfinite(v) || v < 0.0f) ++bad;
                 }
                 for (float mu :
                      {1.0f, -1.0f, std::nextafter(1.0f, 0.0f), std::nextafter(-1.0f, 0.0f)}) {
                     const float v = p.eval(mu).x;
                     if (!std::isfinite(v) || v < 0.0f) ++bad;
                 }
                 o.fig("eval_bad", double(bad));
                 if (bad) o.fail(std::to_string(bad) + " eval values NaN/Inf/negative");
                 const double norm = phaseIntegral(p);
                 o.fig("integral", norm);
                 // sampling: stratified u; cosines in [-1, 1], pdf finite, mean = g
                 const int n = 200000;
                 double mean = 0.0;
                 std::uint64_t sbad = 0;
                 for (int i = 0; i < n; ++i) {
                     const PhaseSample ps = p.sample(vec2((i + 0.5f) / n, 0.5f));
                     if (!std::isfinite(ps.cosTheta) || std::abs(ps.cosTheta) > 1.0f ||
                         !std::isfinite(ps.pdf) || ps.pdf < 0.0f)
                         ++sbad;
                     else
                         mean += ps.cosTheta;
                 }
                 mean /= n;
                 o.fig("sample_bad", double(sbad));
                 o.fig("mean_cos", mean);
                 if (sbad) o.fail(std::to_string(sbad) + " samples non-finite or out of range");
                 if (std::abs(mean - g) > 2e-3)
                     o.fail(fmt("mean cosine of the samples %.6g", mean) + fmt(" != g = %g", g));
                 // the lobe is (1 - |g|)^2 wide in cos; float resolves cos near +-1 to
                 // 6e-8 (2^-24)
                 const double width = (1.0 - std::abs(g)) * (1.0 - std::abs(g));
                 if (std::abs(g) < 1.0 && width < 1e-7) {
                     o.fig("lobe_width", width);
                     if (std::abs(norm - 1.0) > 2e-3)
                         o.degrade(fmt("the lobe (%.2g wide in cos) is narrower than "
                                       "float's resolution of cos near +-1 (6e-8): eval "
                                       "over float cosines integrates to ",
                                       width) +
                                   fmt("%.4g; sampling and its mean cosine are exact", norm));
                 } else if (std::abs(g) < 1.0) {
                     if (std::abs(norm - 1.0) > 2e-3)
                         o.fail(fmt("eval integrates to %.6g over the sphere", norm));
                 } else {
                     // a delta: no density can integrate to 1 in float; the scene file
                     // refuses it, and in core eval must stay finite
                     o.note("g = +-1 is a delta function: the scene file refuses it "
                            "(medium.g in (-1, 1))");
                     try {
                         io::parseSceneText("[medium]\ng = " + fmt("%.1f", g) + "\n",
                                            "stress.toml");
                         o.fail("the scene file accepted medium.g = " + fmt("%g", g));
                     } catch (const io::SceneError& e) {
                         std::string m = e.what();
                         o.fig("refusal", m.substr(0, m.find('\n')));
                     }
                     o.degrade(fmt("sampling gives the delta (mean cosine %.6g)", mean) +
                               fmt("; eval integrates to %.3g", norm));
                 }
             }});
    for (double g : {0.9999, -0.9999})
        for (Method m : kMethods)
            cs.push_back({"phase/render/" + std::string(methodName(m)) + "/" + fmt("%g", g),
                          m == Method::March || m == Method::PathTrace,
                          [g, m](Context& c, Outcome& o) {
                              SceneDesc s = cumulusScene(c);
                              s.medium.g = float(g);
                              applyMethod(s, m, c);
                              const Frame f = render(s, c.budget);
                              judge(o, f, c.budget);
                              figures(o, f, s, !deterministic(m));
                              const Frame wf = render(furnaceOf(s), c.budget);
                              judge(o, wf, c.budget, "furnace");
                              judgeFurnace(o, wf);
                          }});
}

void addSunCases(Cases& cs) {
    const std::pair<const char*, double> suns[] = {
        {"zenith", 90.0}, {"grazing-89.99", 0.01}, {"below-horizon", -20.0}};
    for (const auto& [name, elevation] : suns)
        for (Method m : kMethods) {
            const double el = elevation;
            cs.push_back({"sun/" + std::string(name) + "/" + methodName(m), true,
                          [el, m](Context& c, Outcome& o) {
                              SceneDesc s = cumulusScene(c);
                              const double e = glm::radians(el), az = glm::radians(30.0);
                              s.sun.direction = vec3(
                                  glm::normalize(glm::dvec3(std::sin(az) * std::cos(e), std::sin(e),
                                                            std::cos(az) * std::cos(e))));
                              applyMethod(s, m, c);
                              const Frame f = render(s, c.budget);
                              judge(o, f, c.budget);
                              figures(o, f, s, !deterministic(m));
                              // energy: the same sun alone (no sky), albedo 1, can at most
                              // scatter the irradiance it brings: radiance <= E * max phase
                              // is loose; the furnace of the same scene stays <= 1 instead
                              SceneDesc w = furnaceOf(s);
                              const Frame wf = render(w, c.budget);
                              judge(o, wf, c.budget, "furnace");
                              judgeFurnace(o, wf);
                          }});
        }
}

/// The camera inside the medium, and far from the origin (the scene translated by 1e7: the
/// image must be the one at the origin).
void addCameraCases(Cases& cs) {
    for (Method m : kMethods)
        cs.push_back(
            {"camera/inside/" + std::string(methodName(m)), true, [m](Context& c, Outcome& o) {
                 SceneDesc s = cumulusScene(c);
                 s.camera.position = vec3(0.0f, 2.8f, 0.0f);
                 s.camera.lookAt = vec3(0.0f, 3.0f, 5.0f);
                 s.camera.fovY = 90.0f;
                 applyMethod(s, m, c);
                 const Frame f = render(s, c.budget);
                 judge(o, f, c.budget);
                 figures(o, f, s, !deterministic(m));
                 const Frame wf = render(furnaceOf(s), c.budget);
                 judge(o, wf, c.budget, "furnace");
                 judgeFurnace(o, wf);
             }});
    for (double offset : {1e3, 1e5, 1e7})
        for (Method m : kMethods)
            cs.push_back({"camera/far-" + fmt("%g", offset) + "/" + methodName(m),
                          offset == 1e7 && (m == Method::March || m == Method::PathTrace),
                          [offset, m](Context& c, Outcome& o) {
                              std::vector<std::string> w;
                              const double voxel = 0.125;
                              FrameBindings b0, b1;
                              b0.grids = {vdbBlob(c, voxel, glm::dvec3(0.0), "", w)};
                              const glm::dvec3 at(offset, 0.0, 0.0);
                              // the grid's transform in double (writeFogVdb's origin is float)
                              b1.grids = {vdbBlob(c, voxel, at, "far", w)};
                              SceneDesc s0 = vdbScene(c, voxel, glm::dvec3(0.0));
                              SceneDesc s1 = vdbScene(c, voxel, at);
                              applyMethod(s0, m, c);
                              applyMethod(s1, m, c);
                              s0.render.background = s1.render.background = Background::Transparent;
                              const Frame f0 = render(s0, b0, c.budget);
                              const Frame f1 = render(s1, b1, c.budget);
                              judge(o, f1, c.budget);
                              figures(o, f1, s1, !deterministic(m));
                              const double d = relativeDifference(f1.fb, f0.fb);
                              o.fig("diff_vs_origin", d);
                              o.farDiff = d;
                              // pathtrace and photons: noise differs once a path's floats do
                              const double tol = deterministic(m) ? 1e-2 : 0.25;
                              if (!(d <= tol)) {
                                  const std::string msg =
                                      fmt("image differs from the origin's by %.3g", d) +
                                      fmt(" (tolerance %g)", tol);
                                  bool warned = false;
                                  for (const std::string& x : f1.plan.warnings)
                                      warned |= x.find("origin") != std::string::npos;
                                  if (warned)
                                      o.degrade(msg + "; the plan warns of it");
                                  else
                                      o.fail(msg + " without a warning");
                              }
                          }});
}

/// Scale invariance: the world scaled by k and the coefficients by 1/k render the same image.
/// A homogeneous cube (scaleWorld) and the VDB blob with voxel size 0.125 k.
void addScaleCases(Cases& cs) {
    for (double k : {1e-4, 1e-2, 1e2, 1e4, 1e6})
        for (Method m : kMethods) {
            const bool quick =
                (k == 1e-4 || k == 1e6) &&
                (m == Method::March || m == Method::Diffusion || m == Method::PathTrace);
            auto compare = [m](Outcome& o, const Frame& f0, const Frame& f1) {
                const double d = relativeDifference(f1.fb, f0.fb);
                o.fig("diff_vs_k1", d);
                o.scaleDiff = d;
                const double tol = deterministic(m) ? 2e-3 : 0.25;
                if (!(d <= tol))
                    o.fail(fmt("scaled image differs by %.3g", d) + fmt(" (tolerance %g)", tol));
            };
            cs.push_back({"scale/homogeneous/" + std::string(methodName(m)) + "/" + fmt("%g", k),
                          quick, [k, m, compare](Context& c, Outcome& o) {
                              SceneDesc s = homogeneousScene(c);
                              s.render.step = s.render.shadowStep = 0.05f;
                              s.render.background = Background::Transparent;
                              applyMethod(s, m, c);
                              const Frame f0 = render(s, c.budget);
                              const Frame f1 = render(scaleWorld(s, k), c.budget);
                              judge(o, f1, c.budget);
                              figures(o, f1, scaleWorld(s, k), !deterministic(m));
                              compare(o, f0, f1);
                          }});
            // the voxel sizes 1e-4 ... 1e6 against 0.125
            const double kv = k / 0.125;
            cs.push_back(
                {"scale/vdb-voxel/" + std::string(methodName(m)) + "/" + fmt("%g", 0.125 * kv),
                 quick, [k = kv, m, compare](Context& c, Outcome& o) {
                     std::vector<std::string> w;
                     FrameBindings b0, b1;
                     b0.grids = {vdbBlob(c, 0.125, glm::dvec3(0.0), "", w)};
                     b1.grids = {vdbBlob(c, 0.125 * k, glm::dvec3(0.0), "", w)};
                     SceneDesc s0 = vdbScene(c, 0.125, glm::dvec3(0.0));
                     SceneDesc s1 = vdbScene(c, 0.125 * k, glm::dvec3(0.0));
                     for (SceneDesc* s : {&s0, &s1}) {
                         applyMethod(*s, m, c);
                         s->render.background = Background::Transparent;
                     }
                     const Frame f0 = render(s0, b0, c.budget);
                     const Frame f1 = render(s1, b1, c.budget);
                     judge(o, f1, c.budget);
                     figures(o, f1, s1, !deterministic(m));
                     o.fig("step", double(f1.plan.step));
                     compare(o, f0, f1);
                 }});
        }
}

/// Steps larger than the whole volume, and steps of 1e-9 (bounded by the time budget; the plan
/// warns).
void addStepCases(Cases& cs) {
    for (Method m : kMethods) {
        if (m == Method::PathTrace) continue; // no step
        cs.push_back({"step/huge/" + std::string(methodName(m)), true, [m](Context& c, Outcome& o) {
                          SceneDesc s = cumulusScene(c);
                          s.render.step = s.render.shadowStep = 1000.0f;
                          applyMethod(s, m, c);
                          const Frame f = render(s, c.budget);
                          judge(o, f, c.budget);
                          figures(o, f, s, !deterministic(m));
                          const Frame wf = render(furnaceOf(s), c.budget);
                          judge(o, wf, c.budget, "furnace");
                          judgeFurnace(o, wf);
                      }});
    }
    for (const char* which : {"primary", "shadow"}) {
        const std::string w = which;
        cs.push_back({"step/1e-9-" + w + "/march", true, [w](Context& c, Outcome& o) {
                          SceneDesc s = cumulusScene(c);
                          applyMethod(s, Method::March, c);
                          if (w == "primary") {
                              s.render.step = 1e-9f;
                              s.render.stepGrowth = 0.0f;
                          } else {
                              s.render.shadowStep = 1e-9f;
                              s.render.shadowGrowth = 0.0f;
                          }
                          const Frame f = render(s, c.shortBudget);
                          judge(o, f, c.shortBudget);
                          figures(o, f, s, false);
                          o.fig("lookups", double(f.stats.lookups()));
                          if (f.plan.warnings.empty())
                              o.fail("no warning of the step in the plan (--explain)");
                      }});
    }
}

/// march's error against the primary step (jitter off, one sample per pixel, a fixed fine
/// shadow step, whole steps: render.step_tau splits coarse steps more than fine ones, so the
/// error would not follow the step): halving the step must shrink the error at the method's
/// order.
void addOrderCases(Cases& cs) {
    for (const char* kind : {"homogeneous", "cumulus"}) {
        const std::string k = kind;
        cs.push_back({"order/march/" + k, k == "homogeneous", [k](Context& c, Outcome& o) {
                          SceneDesc s = k == "homogeneous" ? homogeneousScene(c) : cumulusScene(c);
                          applyMethod(s, Method::March, c);
                          s.render.jitter = false;
                          s.render.epsilon = 0.0f;
                          s.render.inScatter = InScatter::None;
                          s.sky.kind = SkyKind::None;
                          s.render.background = Background::Transparent;
                          s.render.shadowStep = 0.02f;
                          s.render.shadowGrowth = k == "homogeneous" ? 0.0f : 0.3f;
                          s.render.stepGrowth = 0.0f;
                          s.render.stepTau = 0.0f;
                          const double h0 = 0.2;
                          SceneDesc r = s;
                          r.render.step = float(h0 / 64.0);
                          const Frame ref = render(r, c.budget);
                          judge(o, ref, c.budget, "reference");
                          double prev = 0.0;
                          for (int i = 0; i < 3; ++i) {
                              SceneDesc t = s;
                              t.render.step = float(h0 / double(1 << i));
                              const Frame f = render(t, c.budget);
                              judge(o, f, c.budget);
                              const double e = relativeDifference(f.fb, ref.fb);
                              o.fig(fmt("err(%g)", h0 / double(1 << i)), e);
                              if (i > 0) {
                                  const double ratio = prev / e;
                                  o.fig(fmt("ratio%g", double(i)), ratio);
                                  if (!(ratio > 1.6))
                                      o.fail(fmt("halving the step divided the error by %.3g "
                                                 "(first order: 2)",
                                                 ratio));
                              }
                              prev = e;
                          }
                      }});
    }
}

/// Transmittance along one ray through a slab of growing depth d (sigma_t 1): in [0, 1],
/// non-increasing, exp(-d).
void addTransmittanceCases(Cases& cs) {
    for (Method m : {Method::March, Method::PathTrace, Method::LightVolume})
        cs.push_back(
            {"transmittance/" + std::string(methodName(m)), true, [m](Context& c, Outcome& o) {
                 double prev = 1.0, worst = 0.0, worstZ = 0.0;
                 const int spp = 4096;
                 for (double d : {1e-4, 1e-2, 0.1, 1.0, 3.0, 10.0, 30.0}) {
                     SceneDesc s;
                     s.camera = camera(vec3(0.0f, 0.0f, -1.0f), vec3(0.0f, 0.0f, 1.0f), 0.01f, c);
                     s.camera.width = s.camera.height = 1;
                     s.field.kind = FieldKind::Homogeneous;
                     s.field.homogeneous.box =
                         Box{vec3(-1.0f, -1.0f, 0.0f), vec3(1.0f, 1.0f, float(d))};
                     s.medium.sigma_s = vec3(0.7f);
                     s.medium.sigma_a = vec3(0.3f);
                     s.render.epsilon = 0.0f;
                     s.render.step = s.render.shadowStep = 0.05f;
                     applyMethod(s, m, c);
                     s.render.spp = spp;
                     const Frame f = render(s, c.budget, AovSet{true, true});
                     judge(o, f, c.budget, fmt("d=%g", d));
                     if (f.fb.transmittance.empty()) continue;
                     const double t = f.fb.transmittance[0], ex = std::exp(-d);
                     // pathtrace estimates T per sample: at most a binomial's spread
                     const double sd =
                         m == Method::PathTrace ? std::sqrt(ex * (1.0 - ex) / spp) : 0.0;
                     worst = std::max(worst, std::abs(t - ex));
                     if (sd > 0.0) worstZ = std::max(worstZ, std::abs(t - ex) / sd);
                     if (t > prev + 1e-6 + 4.0 * sd)
                         o.fail(fmt("transmittance rises to %.6g", t) + fmt(" at depth %g", d));
                     if (std::abs(t - ex) > 1e-4 + 4.0 * sd)
                         o.fail(fmt("transmittance %.6g", t) + fmt(" off exp(-d) at d = %g", d));
                     prev = t;
                 }
                 o.fig("max|T-exp(-d)|", worst);
                 if (m == Method::PathTrace) o.fig("max z", worstZ);
             }});
}

/// Hostile grids: NaN/Inf/negative voxels (sanitised by the loader, with a warning), an
/// empty grid, a single voxel.
void addVoxelCases(Cases& cs) {
    for (const char* flaw : {"bad", "empty", "single"})
        for (Method m : kMethods) {
            const std::string fl = flaw;
            cs.push_back({"voxels/" + std::string(fl == "bad" ? "nan-inf-negative" : flaw) + "/" +
                              methodName(m),
                          m == Method::March || m == Method::PathTrace,
                          [fl, m](Context& c, Outcome& o) {
                              std::vector<std::string> w;
                              FrameBindings b;
                              b.grids = {vdbBlob(c, 0.125, glm::dvec3(0.0), fl, w)};
                              SceneDesc s = vdbScene(c, 0.125, glm::dvec3(0.0));
                              if (fl == "single") s.medium.sigma_s = vec3(200.0f);
                              applyMethod(s, m, c);
                              const Frame f = render(s, b, c.budget);
                              judge(o, f, c.budget);
                              figures(o, f, s, !deterministic(m));
                              for (const std::string& x : w) o.note("loader: " + x);
                              if (fl == "bad" && w.empty())
                                  o.fail("NaN/Inf/negative voxels loaded without a warning");
                              if (fl == "single" && f.check.maxT >= 1.0 && f.check.minT >= 1.0)
                                  o.note("the single voxel is not seen");
                          }});
        }
}

/// Long frame ranges: parsed, or refused with the limit.
/// [field.advect] at CFL numbers from 0.1 to 50 per step (8 steps to frame 1, MacCormack and
/// semi-Lagrangian): the frame's grid stays within the source's range, finite; and motion blur
/// with the widest shutter and winds up to 1e6 units a second (swept majorants over the shutter).
void addMotionCases(Cases& cs) {
    for (double cfl : {0.1, 1.0, 10.0, 50.0})
        for (bool mac : {true, false})
            cs.push_back({"advect/cfl-" + fmt("%g", cfl) + (mac ? "/maccormack" : "/sl"),
                          cfl == 50.0 || cfl == 1.0, [cfl, mac](Context& c, Outcome& o) {
                              SceneDesc s = cumulusScene(c);
                              AdvectDesc& a = s.field.advect;
                              a.enabled = true;
                              a.maccormack = mac;
                              a.voxel = 0.1f;
                              // the default domain: the cloud carried until frame 1 fits
                              a.until = 1.0f / s.render.fps;
                              a.step = 1.0f / (8.0f * s.render.fps);
                              a.wind = AdvectWind::Layered; // shear: no whole-cell moves
                              const float u = float(cfl) * a.voxel / a.step;
                              a.layers = {AutomatonWindRow{1.5f, vec3(0.3f * u, 0.0f, 0.1f * u)},
                                          AutomatonWindRow{4.0f, vec3(u, 0.0f, -0.2f * u)}};
                              o.fig("cfl", cfl);
                              Renderer r(s);
                              const FramePlan p = r.plan(1);
                              const Field src = makeAdvectSource(s.field, GridBinding{});
                              const Field f = r.fieldFor(p);
                              float srcMax = 0.0f;
                              for (float v :
                                   sampleSource(AdvectDomain{sim::GridFrame{p.advectBounds.lo,
                                                                            p.advectVoxel},
                                                             p.advectRes, p.advectBounds},
                                                src)
                                       .v)
                                  srcMax = std::max(srcMax, v);
                              float lo = 0.0f, hi = 0.0f;
                              bool finite = true;
                              if (f.kind == FieldKind::Advected)
                                  for (float v : f.as<AdvectedField>().grid.frame->density.v) {
                                      finite = finite && std::isfinite(v);
                                      lo = std::min(lo, v);
                                      hi = std::max(hi, v);
                                  }
                              o.fig("max/source", srcMax > 0.0f ? hi / srcMax : 0.0);
                              if (f.kind != FieldKind::Advected)
                                  o.fail("the frame's field is not the advected grid");
                              else if (!finite || lo < 0.0f || hi > srcMax)
                                  o.fail(fmt("advected density in [%g, ", lo) +
                                         fmt("%g], source max ", hi) + fmt("%g", srcMax));
                              const Frame fr = render(s, c.budget);
                              judge(o, fr, c.budget);
                              figures(o, fr, s, false);
                          }});
    for (double wind : {10.0, 1e3, 1e6})
        for (Method m : {Method::March, Method::PathTrace})
            cs.push_back({"blur/wind-" + fmt("%g", wind) + "/" + methodName(m), wind == 1e6,
                          [wind, m](Context& c, Outcome& o) {
                              SceneDesc s = cumulusScene(c);
                              s.field.cumulus.wind = vec3(float(wind), 0.0f, 0.3f * float(wind));
                              s.render.shutterOpen = -4.0f;
                              s.render.shutterClose = 4.0f;
                              s.render.pixelSamples = 4;
                              applyMethod(s, m, c);
                              o.fig("wind", wind);
                              const Frame f = render(s, c.budget);
                              if (!f.plan.motionBlur) o.fail("the plan left the blur out");
                              judge(o, f, c.budget);
                              figures(o, f, s, !deterministic(m));
                          }});
}

void addFrameCases(Cases& cs) {
    struct Spec {
        const char* spec;
        long long frames; ///< expected count, -1: refused
    };
    const Spec specs[] = {{"1-1000000", 1000000},
                          {"1-1000001", -1},
                          {"-2147483648--2146483649", 1000000},
                          {"1-2147483647x2148", 999760},
                          {"1-2147483647x2147", -1},
                          {"1-1000000,1-1000000,500000-1000000x2", 1000000},
                          {"1-1000000,1-1000000,1-1000000,1-1000000,1-1000000,1-1000000,"
                           "1-1000000,1-1000000,1-1000000",
                           -1},
                          {"1-2147483648", -1},
                          {"2147483647", 1}};
    for (const Spec& sp : specs) {
        const std::string spec = sp.spec;
        const long long expect = sp.frames;
        std::string name = spec.size() > 40 ? spec.substr(0, 37) + "..." : spec;
        cs.push_back({"frames/" + name, true, [spec, expect](Context&, Outcome& o) {
                          try {
                              const std::vector<int> f = io::parseFrameSpec(spec);
                              o.fig("frames", double(f.size()));
                              if (expect < 0)
                                  o.fail("accepted (" + std::to_string(f.size()) +
                                         " frames); expected a refusal");
                              else if ((long long)f.size() != expect)
                                  o.fail("parsed " + std::to_string(f.size()) + " frames");
                              if (!std::is_sorted(f.begin(), f.end())) o.fail("frames not sorted");
                              // and a pattern with the largest frame
                              if (!f.empty())
                                  o.fig("last", io::expandFramePattern("f.####.exr", f.back()));
                          } catch (const std::invalid_argument& e) {
                              std::string m = e.what();
                              o.fig("refusal", m.size() > 120 ? m.substr(0, 117) + "..." : m);
                              if (expect >= 0) o.fail("refused: " + m);
                          }
                      }});
    }
}

Cases allCases() {
    Cases cs;
    addFieldCases(cs);
    addTauCases(cs);
    addDensityCases(cs);
    addStiffCases(cs);
    addStiffSunCases(cs);
    addPhaseCases(cs);
    addSunCases(cs);
    addCameraCases(cs);
    addScaleCases(cs);
    addStepCases(cs);
    addOrderCases(cs);
    addTransmittanceCases(cs);
    addVoxelCases(cs);
    addFrameCases(cs);
    addMotionCases(cs);

    return cs;
}

std::string csvQuote(const std::string& s) {
    std::string o = "\"";
    for (char ch : s) {
        if (ch == '"') o += '"';
        o += ch;
    }
    return o + "\"";
}

} // namespace

int runStress(const StressOptions& opt) {
    installSignalHandlers();
    Context c;
    c.quick = opt.quick;
    c.width = opt.quick ? 16 : 32;
    c.height = opt.quick ? 9 : 18;
    c.budget = opt.quick ? 3.0 : 20.0;
    c.shortBudget = opt.quick ? 1.0 : 3.0;
    c.dir = fs::temp_directory_path() / ("nimbus_stress_" + std::to_string(getpid()));
    fs::create_directories(c.dir);

    Cases cases;
    std::vector<std::string> leftOut;
    for (Case& k : allCases()) {
        if (!opt.filter.empty() && k.name.find(opt.filter) == std::string::npos) continue;
        if (opt.quick && !k.known.empty()) leftOut.push_back(k.name);
        if (opt.quick && (!k.quick || !k.known.empty())) continue;
        cases.push_back(std::move(k));
    }
    if (cases.empty()) {
        std::fprintf(stderr, "nimbus: error: stress: no case matches --filter \"%s\"\n",
                     opt.filter.c_str());
        fs::remove_all(c.dir);
        return kExitBadInput;
    }
    std::ofstream csv;
    if (!opt.csv.empty()) {
        csv.open(opt.csv);
        if (!csv) {
            std::fprintf(stderr, "nimbus: error: stress: cannot write %s\n", opt.csv.c_str());
            fs::remove_all(c.dir);
            return kExitIo;
        }
        csv << "case,verdict,seconds,figures,notes\n";
    }
    std::printf("nimbus stress%s: %zu cases, %dx%d pixels, render budget %g s (%g s where the "
                "work is unbounded)\n",
                opt.quick ? " --quick" : "", cases.size(), c.width, c.height, c.budget,
                c.shortBudget);
    int counts[3] = {0, 0, 0};
    double worstFurnace = -INFINITY, worstScale = 0.0, worstFar = 0.0, total = 0.0;
    std::string worstFurnaceCase, worstScaleCase, worstFarCase, slowestCase;
    double slowest = 0.0;
    std::uint64_t nonFinite = 0;
    bool interrupted = false;
    CaseWatchdog watchdog(opt.caseLimit > 0.0 ? opt.caseLimit : 40.0 * c.budget, c.dir);
    for (Case& k : cases) {
        if (gCancel.load()) {
            interrupted = true;
            break;
        }
        Outcome o;
        const auto t0 = Clock::now();
        watchdog.begin(k.name);
        try {
            k.run(c, o);
        } catch (const std::exception& e) {
            o.fail(std::string("exception: ") + e.what());
        }
        watchdog.end();
        const double sec = secondsSince(t0);
        if (!k.known.empty())
            o.note(o.verdict == Verdict::Fail ? "known failure: " + k.known
                                              : "a known failure that no longer fails: " + k.known);
        total += sec;
        ++counts[int(o.verdict)];
        nonFinite += o.nonFinite;
        if (sec > slowest) slowest = sec, slowestCase = k.name;
        if (std::isfinite(o.furnaceMean) && o.furnaceMean > worstFurnace)
            worstFurnace = o.furnaceMean, worstFurnaceCase = k.name;
        if (std::isfinite(o.scaleDiff) && o.scaleDiff >= worstScale)
            worstScale = o.scaleDiff, worstScaleCase = k.name;
        if (!std::isnan(o.farDiff) && !(o.farDiff < worstFar))
            worstFar = o.farDiff, worstFarCase = k.name;
        std::string figs, notes;
        for (const auto& [key, v] : o.figures) figs += (figs.empty() ? "" : " ") + key + "=" + v;
        for (const std::string& n : o.notes) notes += (notes.empty() ? "" : "; ") + n;
        std::printf("%-42s %-8s %7.2fs  %s\n", k.name.c_str(), verdictName(o.verdict), sec,
                    figs.c_str());
        if (!notes.empty()) std::printf("%52s%s\n", "", clipped(notes).c_str());
        std::fflush(stdout);
        if (csv) {
            csv << csvQuote(k.name) << "," << verdictName(o.verdict) << "," << fmt("%.3f", sec)
                << "," << csvQuote(figs) << "," << csvQuote(notes) << std::endl;
        }
    }
    const int run = counts[0] + counts[1] + counts[2];
    std::printf("\nsummary: %d cases: %d PASS, %d DEGRADED, %d FAIL; %.1f s\n", run, counts[0],
                counts[1], counts[2], total);
    std::printf("  NaN/Inf values or replaced pixels: %llu\n", (unsigned long long)nonFinite);
    if (std::isfinite(worstFurnace))
        std::printf("  white furnace, highest mean (sky = 1): %.5g (%s)\n", worstFurnace,
                    worstFurnaceCase.c_str());
    if (!worstScaleCase.empty())
        std::printf("  scale invariance, largest image difference: %.3g (%s)\n", worstScale,
                    worstScaleCase.c_str());
    if (!worstFarCase.empty())
        std::printf("  far from the origin, largest image difference: %.3g (%s)\n", worstFar,
                    worstFarCase.c_str());
    std::printf("  slowest case: %.2f s (%s)\n", slowest, slowestCase.c_str());
    if (!leftOut.empty()) {
        std::printf("  left out of --quick: %zu known failure(s) (docs/stress.md):",
                    leftOut.size());
        for (const std::string& n : leftOut) std::printf(" %s", n.c_str());
        std::printf("\n");
    }
    fs::remove_all(c.dir);
    if (interrupted) {
        std::fprintf(stderr, "nimbus: interrupted\n");
        return kExitInterrupted;
    }
    return counts[2] == 0 ? kExitOk : kExitInternal;
}

} // namespace nimbus::cli
