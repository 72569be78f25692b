/// @file suite.cpp
/// @brief `nimbus converge --suite`: the validation matrix of `march` against `pathtrace`.
///
/// Every cloud (the default scene and every fog volume of a VDB folder) at three thicknesses
/// (mean optical depth 1, 20 and 500 over the cloud's pixels), with the sun in front, at the
/// side and behind, at albedo 1 and 0.9: 18 cases per cloud. Each case renders a pathtrace
/// reference as two halves with different seeds (cached on disk, keyed by every setting the
/// reference depends on) and `march` out of the box, and reports the relative RMSE of
/// core/image_error.h with the reference noise taken out in quadrature, the ratio of the means
/// and the times, worst case first (docs/accuracy.md, "The validation matrix").
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <OpenImageIO/hash.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "core/camera.h"
#include "core/image_error.h"
#include "core/lighting/cloud_depth.h"
#include "core/render.h"
#include "plugin/cli/commands.h"
#include "plugin/cli/common.h"
#include "plugin/cli/vdb_scene.h"
#include "plugin/io/image_output.h"
#include "plugin/io/scene_file.h"
#include "plugin/vdb/vdb_error.h"
#include "plugin/vdb/vdb_field.h"
#include "plugin/vdb/vdb_reader.h"

namespace nimbus::cli {

namespace {

namespace fs = std::filesystem;

/// Written into every cached reference; bump it when what a cached file means changes.
constexpr int kSuiteFormat = 1;
/// The accuracy target of the issue: relative RMSE at most this.
constexpr double kTarget = 0.10;

/// Mean optical depth over the cloud's pixels (see measureColumns()).
struct Thickness {
    const char* name;
    double tau;
};
constexpr Thickness kThicknesses[] = {{"thin", 1.0}, {"medium", 20.0}, {"thick", 500.0}};

/// The sun relative to the camera: `theta` is the angle between the direction the sunlight
/// travels and the camera's view direction (0 = from straight behind the camera, 180 = straight
/// into the lens); `phi` says toward which side of the image the sun is moved off that axis
/// (0 = the image's right, 90 = its top).
struct SunPosition {
    const char* name;
    double theta, phi;
};
constexpr SunPosition kSuns[] = {
    {"front", 20.0, 90.0}, {"side", 90.0, 30.0}, {"behind", 150.0, 90.0}};
constexpr double kAlbedos[] = {1.0, 0.9};

// The suite's light, the same for every case (the default scene's, in lin_rec709).
const vec3 kSunIrradiance(1.0f, 0.93f, 0.82f);
constexpr float kSunIntensity = 12.0f;
const vec3 kSkyZenith(0.16f, 0.32f, 0.70f);
const vec3 kSkyHorizon(0.60f, 0.70f, 0.82f);
constexpr const char* kLightSpace = "lin_rec709";

struct Cloud {
    std::string name;   ///< the scene's or the VDB file's stem
    std::string grid;   ///< the VDB grid ("-" for a scene)
    std::string source; ///< the file
    bool vdb = false;
    std::unique_ptr<LoadedScene> ls;
    SceneDesc base; ///< the size of the suite, clouds alone (transparent background)
    FrameBindings bindings;
    int frame = 1;
    float sigmaT0 = 1.0f; ///< extinction per unit density (mean over RGB) of every case
    double voxel = 0.0;   ///< VDB: the smallest voxel side (the march step)
    double column = 0.0;  ///< mean density integral of the camera rays through the cloud
    double columnMedian = 0.0;
    size_t columnPixels = 0; ///< pixels whose centre ray meets density
};

struct Case {
    Cloud* cloud = nullptr;
    const Thickness* thickness = nullptr;
    const SunPosition* sun = nullptr;
    double albedo = 1.0;
    std::string name; ///< cloud/thickness/sun/a<albedo>
};

struct Result {
    const Case* c = nullptr;
    float densityScale = 1.0f;
    double tau = 0.0;      ///< achieved mean optical depth
    double rel = 0.0;      ///< relative RMSE, the reference's noise taken out
    double relRaw = 0.0;   ///< relative RMSE as measured
    double ratio = 0.0;    ///< march mean / reference mean over the cloud's pixels
    double noiseRel = 0.0; ///< reference noise / reference mean
    size_t pixels = 0;
    double marchSeconds = 0.0;
    double refSeconds = 0.0;    ///< render time of the reference, every round (cached ones too)
    double refRunSeconds = 0.0; ///< of that, rendered in this run
    int spp = 0;                ///< of the reference
    int cachedSpp = 0;          ///< of those, read from the cache
    std::string msModel;        ///< march's multiple scattering (Measured::msModel)
    double cloudTau = -1.0;     ///< the cloud's depth along the sun, when "auto" measured it
};

std::string albedoName(double a) {
    return a >= 1.0 ? "1" : "0.9";
}

/// A case's name, CLOUD/THICKNESS/SUN/aALBEDO (also the stem of its cache files).
std::string caseName(const std::string& cloud, const std::string& thickness, const std::string& sun,
                     double albedo) {
    return cloud + "/" + thickness + "/" + sun + "/a" + albedoName(albedo);
}

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

std::string percent(double v) {
    return std::isfinite(v) ? fmt("%.2f%%", 100.0 * v) : std::string("n/a");
}

std::string exeDirectory() {
    char self[4096];
    const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0) return ".";
    self[n] = '\0';
    return fs::path(self).parent_path().string();
}

/// The repository whose examples/scenes/cumulus.toml exists: the working directory, or the
/// parent of the executable's directory (build/nimbus). Empty when neither.
std::string findRepository() {
    for (const fs::path& root : {fs::current_path(), fs::path(exeDirectory()).parent_path()}) {
        std::error_code ec;
        if (fs::is_regular_file(root / "examples/scenes/cumulus.toml", ec)) return root.string();
    }
    return {};
}

/// Size and SHA-1 of a file's contents, for the cache key: a copy of the same file (another
/// checkout, the data folder copied to a farm, which sets new modification times) keeps its
/// references; any change of a byte drops them.
std::string hashFile(const std::string& path) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return "missing";
    OIIO::SHA1 sha;
    std::vector<char> buf(std::size_t(1) << 20);
    std::uint64_t size = 0;
    for (std::size_t got; (got = std::fread(buf.data(), 1, buf.size(), f)) > 0;) {
        sha.append(buf.data(), got);
        size += got;
    }
    const bool failed = std::ferror(f) != 0;
    std::fclose(f);
    if (failed) return "unreadable";
    std::string hex = sha.digest(); // as sha1sum prints it
    for (char& ch : hex) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    return "size " + std::to_string(size) + ", sha1 " + hex;
}

/// hashFile, computed once per file and run: every case of a cloud asks (a VDB may be gigabytes).
std::string fileStamp(const std::string& path) {
    static std::mutex lock;
    static std::map<std::string, std::string> known;
    const std::lock_guard<std::mutex> hold(lock);
    if (auto it = known.find(path); it != known.end()) return it->second;
    std::string stamp = hashFile(path);
    known.emplace(path, stamp);
    return stamp;
}

/// Direction toward the sun for camera `cam` (see SunPosition).
vec3 sunDirection(const Camera& cam, const SunPosition& sp) {
    const float theta = glm::radians(float(sp.theta)), phi = glm::radians(float(sp.phi));
    const vec3 off = std::cos(phi) * cam.right + std::sin(phi) * cam.up;
    return glm::normalize(-std::cos(theta) * cam.forward + std::sin(theta) * off);
}

/// The density integral along the centre ray of every pixel, by the midpoint rule at `step`:
/// the mean and median over the pixels whose ray meets density. False when interrupted.
bool measureColumns(Cloud& c, double step) {
    Renderer r(c.base);
    const FramePlan plan = r.plan(c.frame, c.bindings);
    const Field field = r.fieldFor(plan, c.bindings);
    const Camera cam(c.base.camera);
    const Box box = field.bounds();
    const int w = c.base.camera.width, h = c.base.camera.height;
    std::vector<double> col(size_t(w) * h, 0.0);
    auto rows = [&](const tbb::blocked_range<int>& rr) {
        for (int y = rr.begin(); y < rr.end(); ++y)
            for (int x = 0; x < w; ++x) {
                if (gCancel) return;
                const Ray ray = cam.generate(float(x) + 0.5f, float(y) + 0.5f);
                float t0, t1;
                if (!intersectBox(ray, box, 0.0f, 1e30f, t0, t1)) continue;
                col[size_t(y) * w + x] =
                    integrateDensity(field, ray, t0, t1, step, 1000000).integral();
            }
    };
    const int threads = c.base.render.threads;
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] { tbb::parallel_for(tbb::blocked_range<int>(0, h), rows); });
    if (gCancel) return false;
    std::vector<double> hit;
    for (double v : col)
        if (v > 0.0) hit.push_back(v);
    c.columnPixels = hit.size();
    if (hit.empty()) return true;
    double sum = 0.0;
    for (double v : hit) sum += v;
    c.column = sum / double(hit.size());
    std::nth_element(hit.begin(), hit.begin() + hit.size() / 2, hit.end());
    c.columnMedian = hit[hit.size() / 2];
    return true;
}

/// The scene as the suite measures it: size, transparent background, the noise evaluation the
/// scene's own plan picks.
void prepareBase(Cloud& c, int w, int h) {
    c.base = c.ls->scene();
    c.base.render.background = Background::Transparent;
    c.base.camera.width = w;
    c.base.camera.height = h;
    // the noise evaluation the plan picks at the scene's own size (baked for the default
    // scene), not at the suite's: what the scene renders with out of the box
    Renderer probe(c.ls->scene());
    c.base.field.cumulus.eval = plannedNoiseEval(c.ls->scene(), probe.plan(c.frame, c.bindings));
    const vec3 st = c.base.medium.sigma_s + c.base.medium.sigma_a;
    c.sigmaT0 = (st.x + st.y + st.z) / 3.0f;
}

/// The grid of a VDB file the suite renders: "density" when the file has a scalar grid of that
/// name, else its only scalar grid. Empty with `why` set when there is none to choose.
/// Loads a VDB cloud: picks its grid, reads it in the isolated child (vdb::loadVdbGrid, as
/// scenes do) to frame it and size the step, then loads the in-memory scene through the session
/// (which reads the grid again, the same way). Returns an exit code; `skip` is set (exit code
/// 0) when the file is not a fog volume the suite can use.
int loadVdbCloud(Cloud& c, const ConvergeOptions& o, int w, int h, std::string& skip) {
    VdbFraming framing;
    if (!frameVdbFile(c.source, w, h, "nimbus converge --suite", framing, skip)) return kExitOk;
    c.grid = framing.grid;
    c.voxel = framing.voxel;
    c.ls = std::make_unique<LoadedScene>();
    const host::Status st =
        c.ls->loadString(framing.scene, "suite:" + c.name + ".toml", o.overrides, o.threads);
    printWarnings(*c.ls);
    return report(st);
}

/// The settings named by a key's "key = value" lines.
std::set<std::string> keyNames(const std::string& key) {
    std::set<std::string> out;
    std::istringstream in(key);
    std::string line;
    while (std::getline(in, line)) out.insert(line.substr(0, line.find(" = ")));
    return out;
}

/// The lines of a cached key whose settings the current key names. The current key leaves out
/// what the reference does not read (referenceKey); a cached key's line for such a setting,
/// written when it was kept or before the setting existed, does not count either, so that a
/// setting only `march` reads, old or new, keeps the cached references. A setting the current
/// key names and the cached one lacks still makes it stale.
std::string onNamesOf(const std::string& cached, const std::string& current) {
    const std::set<std::string> names = keyNames(current);
    std::istringstream in(cached);
    std::string out, line;
    while (std::getline(in, line))
        if (names.count(line.substr(0, line.find(" = ")))) out += line + "\n";
    return out;
}

/// The settings a path-traced reference depends on, one "key = value" a line: every scene
/// setting (io::sceneSettings) the path tracer reads (io::pixelNeutralSettings leaves out those
/// whose table row says they are used only by `march`, and threads, tiles and frames), plus the
/// frame, a VDB file's size and SHA-1, the Nimbus version and the suite's format. The output's
/// settings and `color_space` are left out too: the suite keeps working-space pixels and sets
/// every colour of a case itself (sun, sky, medium). So is render.light_volume_cell: the path
/// tracer's shadow roulette draws its probabilities from that grid, which changes the
/// reference's noise, not what it converges to.
std::string referenceKey(const Cloud& c, const SceneDesc& ref, const std::string& caseName) {
    io::SceneFile f = c.ls->file();
    f.scene = ref;
    const std::map<std::string, std::string> m = io::sceneSettings(f);
    const std::set<std::string> neutral = io::pixelNeutralSettings(f);
    std::ostringstream key;
    key << "suite format = " << kSuiteFormat << "\nnimbus = " << NIMBUS_VERSION
        << "\ncase = " << caseName << "\nframe = " << c.frame << "\n";
    // a scene's settings below say all; a VDB file's data is in the file
    if (c.vdb) key << "vdb file = " << fileStamp(c.source) << "\n";
    for (const auto& [k, v] : m)
        if (k.rfind("output.", 0) != 0 && k != "color_space" && k != "render.light_volume_cell" &&
            !neutral.count(k))
            key << k << " = " << v << "\n";
    return key.str();
}

/// The first line where two keys differ, for the message about a stale cache file.
std::string firstDifference(const std::string& want, const std::string& have) {
    std::istringstream a(want), b(have);
    std::string la, lb;
    while (true) {
        const bool ga = bool(std::getline(a, la)), gb = bool(std::getline(b, lb));
        if (!ga && !gb) return "the same";
        if (la != lb || ga != gb)
            return "now \"" + (ga ? la : std::string("(nothing)")) + "\", cached \"" +
                   (gb ? lb : std::string("(nothing)")) + "\"";
    }
}

/// A path-traced reference as two independent halves (different seeds): their mean is the
/// reference, and (core/image_error.h, halvesNoise) half the RMSE of their difference is its
/// noise. Rendered in rounds, each adding the same number of samples to both halves with new
/// seeds, until the noise is below the target, the samples reach their limit or the time its
/// budget; kept on disk as <case>.a.exr and <case>.b.exr, so a later run goes on from there.
struct Halves {
    Framebuffer a, b;
    int spp = 0;          ///< of both halves together
    int rounds = 0;       ///< rounds rendered
    double seconds = 0.0; ///< render time of every round
};

/// The noise of the mean of the halves relative to its mean over the cloud's pixels (NaN when
/// it has no cloud pixels).
double relativeNoise(const Halves& h) {
    const Framebuffer m = halvesMean(h.a, h.b);
    const double mean = imageError(m, m).mean;
    return mean > 0.0 ? halvesNoise(h.a, h.b, m) / mean : std::nan("");
}

/// Reads one cached half. Returns "" when it is usable, else why not.
std::string readHalf(const std::string& path, const std::string& key, int w, int h, Framebuffer& fb,
                     int& spp, int& rounds, double& seconds) {
    std::error_code ec;
    if (!fs::exists(path, ec)) return "not cached";
    io::ExrImage img;
    try {
        img = io::readExr(path);
    } catch (const std::exception& e) {
        return std::string("unreadable (") + e.what() + ")";
    }
    auto attr = [&](const std::string& k) {
        auto it = img.attributes.find(k);
        return it == img.attributes.end() ? std::string() : it->second;
    };
    const std::string have = onNamesOf(attr("nimbus/settings/suite_key"), key);
    if (have.empty()) return path + " is not a suite reference (no suite_key header)";
    if (have != key) return "stale: " + firstDifference(key, have);
    int ch[4];
    const char* names[4] = {"R", "G", "B", "A"};
    for (int k = 0; k < 4; ++k)
        if ((ch[k] = img.channelIndex(names[k])) < 0) return path + " has no R, G, B and A";
    if (img.width != w || img.height != h)
        return path + " is " + std::to_string(img.width) + "x" + std::to_string(img.height);
    spp = std::atoi(attr("nimbus/settings/suite_spp").c_str());
    rounds = std::atoi(attr("nimbus/settings/suite_rounds").c_str());
    seconds = std::strtod(attr("nimbus/settings/suite_seconds").c_str(), nullptr);
    if (spp < 2 || rounds < 1 || !(seconds >= 0.0)) return path + ": bad suite_spp/rounds/seconds";
    fb.resize(w, h, AovSet{});
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < 4; ++k) {
                const float v = img.at(x, y, ch[k]);
                if (!std::isfinite(v)) return path + " has non-finite pixels";
                fb.rgba[(size_t(y) * w + x) * 4 + k] = v;
            }
    return {};
}

/// Reads both cached halves of a case. Returns "" when they are usable, else why not.
std::string readHalves(const std::string& stem, const std::string& key, int w, int h, Halves& out) {
    int sppB = 0, roundsB = 0;
    double secondsB = 0.0;
    std::string why = readHalf(stem + ".a.exr", key, w, h, out.a, out.spp, out.rounds, out.seconds);
    if (why.empty()) why = readHalf(stem + ".b.exr", key, w, h, out.b, sppB, roundsB, secondsB);
    if (why.empty() && (sppB != out.spp || roundsB != out.rounds))
        why = "the halves do not match (" + std::to_string(out.spp) + " and " +
              std::to_string(sppB) + " spp)";
    return why;
}

/// The key a cached half was written with (it names the size too: camera.width and height);
/// "" when it has none or cannot be read.
std::string storedKey(const std::string& path) {
    try {
        const io::ExrImage img = io::readExr(path);
        const auto it = img.attributes.find("nimbus/settings/suite_key");
        return it == img.attributes.end() ? std::string() : it->second;
    } catch (const std::exception&) {
        return {};
    }
}

/// Where a reference of a case rendered under other settings is kept: "<stem>.k<first 12 hex
/// digits of the SHA-1 of its key>", its halves <that>.a.exr and <that>.b.exr. One name per
/// key, so a reference kept again under the same settings replaces its older copy.
std::string stashStem(const std::string& stem, const std::string& key) {
    OIIO::SHA1 sha;
    sha.append(key.data(), key.size());
    std::string hex = sha.digest().substr(0, 12);
    for (char& ch : hex) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    return stem + ".k" + hex;
}

/// Moves both halves of `from` to `to` (the .a.exr and .b.exr of each stem). False if either
/// move failed.
bool moveHalves(const std::string& from, const std::string& to) {
    bool ok = true;
    for (const char* half : {".a.exr", ".b.exr"}) {
        std::error_code ec;
        fs::rename(from + half, to + half, ec);
        ok = ok && !ec;
    }
    return ok;
}

/// Keeps the case's current (stale) halves beside it (stashStem of the key they hold) instead
/// of overwriting them. Returns the file name they were kept under; "" when they hold no key or
/// could not be moved.
std::string keepAside(const std::string& stem) {
    const std::string key = storedKey(stem + ".a.exr");
    if (key.empty()) return {};
    const std::string to = stashStem(stem, key);
    return moveHalves(stem, to) ? fs::path(to).filename().string() : std::string();
}

/// A kept reference of the case that the current `key` accepts (readHalves), or "". The files
/// of the one-generation scheme before (<stem>.a.stale.exr, .b.stale.exr) are moved to their
/// stashStem first.
std::string findStash(const std::string& stem, const std::string& key, int w, int h) {
    const fs::path dir = fs::path(stem).parent_path();
    const std::string base = fs::path(stem).filename().string();
    std::error_code ec;
    if (fs::exists(stem + ".a.stale.exr", ec) && fs::exists(stem + ".b.stale.exr", ec)) {
        const std::string old = storedKey(stem + ".a.stale.exr");
        if (!old.empty()) {
            const std::string to = stashStem(stem, old);
            fs::rename(stem + ".a.stale.exr", to + ".a.exr", ec);
            fs::rename(stem + ".b.stale.exr", to + ".b.exr", ec);
        }
    }
    const std::string prefix = base + ".k", suffix = ".a.exr";
    std::vector<std::string> found;
    for (fs::directory_iterator it(dir.empty() ? fs::path(".") : dir, ec), end; !ec && it != end;
         it.increment(ec)) {
        const std::string name = it->path().filename().string();
        // <base>.k<12 hex>.a.exr exactly: another case's name may start with this one's
        if (name.size() == prefix.size() + 12 + suffix.size() && name.rfind(prefix, 0) == 0 &&
            name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
            found.push_back((dir / name.substr(0, name.size() - suffix.size())).string());
    }
    std::sort(found.begin(), found.end());
    for (const std::string& s : found) {
        Halves probe;
        if (readHalves(s, key, w, h, probe).empty()) return s;
    }
    return {};
}

/// Writes both halves (atomically, each). Returns an error message, "" on success.
std::string writeHalves(const std::string& stem, const std::string& key, const Halves& hv,
                        int frame, const io::ColorSystem& cs, const std::string& ws) {
    for (int k = 0; k < 2; ++k) {
        io::ExrMetadata md;
        md.frame = frame;
        md.renderSeconds = hv.seconds;
        md.settings["suite_key"] = key;
        md.settings["suite_spp"] = std::to_string(hv.spp);
        md.settings["suite_rounds"] = std::to_string(hv.rounds);
        md.settings["suite_seconds"] = fmt("%.6g", hv.seconds);
        md.settings["suite_half"] = k == 0 ? "a" : "b";
        try {
            io::writeExr(stem + (k == 0 ? ".a.exr" : ".b.exr"), k == 0 ? hv.a : hv.b, cs, ws, ws,
                         md);
        } catch (const std::exception& e) {
            return e.what();
        }
    }
    return {};
}

/// Renders one round of `spp` samples (spp / 2 into each half, seeds derived from the scene's
/// seed and the round) and folds it into the halves. False when interrupted.
bool renderRound(const SceneDesc& ref, const FrameBindings& bindings, int frame, int spp,
                 Halves& hv) {
    const int half = std::max(1, spp / 2);
    SceneDesc s = ref;
    s.render.spp = half;
    s.render.seed = ref.render.seed ^ (std::uint32_t(hv.rounds) * 0x85ebca6bu);
    Measured ma, mb;
    if (!measure(s, bindings, frame, ma)) return false;
    s.render.seed ^= 0x9e3779b9u;
    if (!measure(s, bindings, frame, mb)) return false;
    if (hv.spp == 0) {
        hv.a = std::move(ma.fb);
        hv.b = std::move(mb.fb);
    } else {
        const float wOld = float(hv.spp / 2) / float(hv.spp / 2 + half);
        for (size_t i = 0; i < hv.a.rgba.size(); ++i) {
            hv.a.rgba[i] = wOld * hv.a.rgba[i] + (1.0f - wOld) * ma.fb.rgba[i];
            hv.b.rgba[i] = wOld * hv.b.rgba[i] + (1.0f - wOld) * mb.fb.rgba[i];
        }
    }
    hv.spp += 2 * half;
    hv.rounds += 1;
    hv.seconds += ma.seconds + mb.seconds;
    return true;
}

/// Replaces what a file name should not hold.
std::string fileNameOf(const std::string& caseName) {
    std::string s = caseName;
    for (char& ch : s)
        if (ch == '/' || ch == ' ' || ch == '\\' || ch == ':') ch = '.';
    return s;
}

/// "; light: the sun alone" (or the sky's) for the progress header and the table; "" for both.
std::string lightNote(const ConvergeOptions& o) {
    return o.suiteLight == "both" ? "" : "; light: the " + o.suiteLight + " alone";
}

/// The cache files of a run with one light alone (--suite-light) are kept apart from those of
/// both lights: a key that differs would otherwise mark the other run's files stale and render
/// them again in their place.
std::string lightSuffix(const ConvergeOptions& o) {
    return o.suiteLight == "both" ? "" : "." + o.suiteLight;
}

bool parseSize(const std::string& s, int& w, int& h) {
    const size_t x = s.find('x');
    if (x == std::string::npos) return false;
    char* e1 = nullptr;
    char* e2 = nullptr;
    const std::string a = s.substr(0, x), b = s.substr(x + 1);
    const long lw = std::strtol(a.c_str(), &e1, 10), lh = std::strtol(b.c_str(), &e2, 10);
    if (a.empty() || b.empty() || *e1 || *e2 || lw < 1 || lh < 1 || lw > 16384 || lh > 16384)
        return false;
    w = int(lw);
    h = int(lh);
    return true;
}

/// The table's header (scene column `sw` wide).
std::string markdownHeader(int sw) {
    char line[512];
    std::snprintf(line, sizeof line,
                  "| %-*s | %-8s | %-12s | %-8s | %-6s | %-6s | %-9s | %-10s | %-10s | %-8s | "
                  "%-8s | %-10s |\n",
                  sw, "scene", "grid", "thickness", "tau", "sun", "albedo", "rel. RMSE",
                  "mean ratio", "ref. noise", "ref. spp", "march s", "ref. s");
    std::string out = line;
    for (char& ch : line)
        if (ch != '|' && ch != '\n' && ch != '\0') ch = '-';
    return out + line;
}

/// One table row of a result; "?" marks an error smaller than the reference's noise (the
/// noise taken out dominates it), "*" a reference read whole from the cache.
std::string markdownRow(const Result& r, int sw) {
    const Case& c = *r.c;
    const bool unsure = !(r.rel > r.noiseRel);
    char line[512], thick[32];
    std::snprintf(thick, sizeof thick, "%s (%g)", c.thickness->name, c.thickness->tau);
    std::snprintf(line, sizeof line,
                  "| %-*s | %-8s | %-12s | %-8.3g | %-6s | %-6s | %-9s | %-10.3f | %-10s | %-8d | "
                  "%-8.3f | %-10s |\n",
                  sw, c.cloud->name.c_str(), c.cloud->grid.c_str(), thick, r.tau, c.sun->name,
                  albedoName(c.albedo).c_str(), (percent(r.rel) + (unsure ? " ?" : "")).c_str(),
                  r.ratio, percent(r.noiseRel).c_str(), r.spp, r.marchSeconds,
                  (fmt("%.1f", r.refSeconds) + (r.cachedSpp == r.spp ? " *" : "")).c_str());
    return line;
}

} // namespace

int runSuite(const ConvergeOptions& o) {
    int w = 0, h = 0;
    if (!parseSize(o.suiteSize, w, h)) {
        std::fprintf(stderr,
                     "nimbus: error: --suite-size \"%s\": expected WIDTHxHEIGHT, e.g. 64x36 (1 to "
                     "16384 each)\n",
                     o.suiteSize.c_str());
        return kExitBadInput;
    }
    if (o.suiteSpp < 2) {
        std::fprintf(stderr,
                     "nimbus: error: --suite-spp %d: at least 2 (the reference is rendered as two "
                     "halves)\n",
                     o.suiteSpp);
        return kExitBadInput;
    }
    if (o.suiteMaxDepth < 0) {
        std::fprintf(stderr, "nimbus: error: --suite-max-depth %d: must be >= 0\n",
                     o.suiteMaxDepth);
        return kExitBadInput;
    }
    const std::string repo = findRepository();
    std::string scenePath = o.scene;
    if (scenePath.empty()) {
        if (repo.empty()) {
            std::fprintf(stderr,
                         "nimbus: error: --suite: no scene given and examples/scenes/cumulus.toml "
                         "is found neither in the working directory nor beside %s; give the "
                         "scene: nimbus converge --suite SCENE.toml\n",
                         exeDirectory().c_str());
            return kExitBadInput;
        }
        scenePath = (fs::path(repo) / "examples/scenes/cumulus.toml").string();
    }
    std::string dataDir = o.suiteData;
    std::error_code ec;
    if (!dataDir.empty() && !fs::is_directory(dataDir, ec)) {
        std::fprintf(stderr, "nimbus: error: --suite-data %s: not a directory\n", dataDir.c_str());
        return kExitBadInput;
    }
    std::vector<std::string> notes;
    if (dataDir.empty()) {
        // ../shared/data/vdb beside the repository (or the working directory)
        const fs::path guess =
            (repo.empty() ? fs::current_path() : fs::path(repo)).parent_path() / "shared/data/vdb";
        if (fs::is_directory(guess, ec))
            dataDir = fs::weakly_canonical(guess, ec).string();
        else
            notes.push_back("no VDB folder (" + guess.string() +
                            " is absent; --suite-data DIR names one): VDB clouds left out");
    }

    // the clouds, in order: the scene, then the VDB files by name
    std::vector<std::unique_ptr<Cloud>> clouds;
    {
        auto c = std::make_unique<Cloud>();
        c->name = fs::path(scenePath).stem().string();
        c->grid = "-";
        c->source = scenePath;
        clouds.push_back(std::move(c));
    }
    if (!dataDir.empty()) {
        std::vector<std::string> files;
        for (const auto& e : fs::directory_iterator(dataDir, ec))
            if (e.path().extension() == ".vdb") files.push_back(e.path().string());
        std::sort(files.begin(), files.end());
        for (const std::string& f : files) {
            auto c = std::make_unique<Cloud>();
            c->name = fs::path(f).stem().string();
            c->source = f;
            c->vdb = true;
            clouds.push_back(std::move(c));
        }
    }
    // the cases the filter selects
    std::vector<Case> cases;
    for (auto& c : clouds)
        for (const Thickness& t : kThicknesses)
            for (const SunPosition& s : kSuns)
                for (double a : kAlbedos) {
                    Case k{c.get(), &t, &s, a, caseName(c->name, t.name, s.name, a)};
                    bool take = o.suiteFilter.empty();
                    for (const std::string& f : o.suiteFilter)
                        take = take || k.name.find(f) != std::string::npos;
                    if (take) cases.push_back(k);
                }
    if (cases.empty()) {
        std::string names;
        for (auto& c : clouds) names += (names.empty() ? "" : ", ") + c->name;
        std::fprintf(stderr,
                     "nimbus: error: --suite-filter matches no case; cases are named "
                     "CLOUD/THICKNESS/SUN/ALBEDO, e.g. %s/thick/behind/a0.9, with CLOUD one of "
                     "%s, THICKNESS thin, medium or thick, SUN front, side or behind, ALBEDO a1 or "
                     "a0.9\n",
                     clouds[0]->name.c_str(), names.c_str());
        return kExitBadInput;
    }
    fs::create_directories(o.suiteDir, ec);
    if (!fs::is_directory(o.suiteDir, ec)) {
        std::fprintf(stderr, "nimbus: error: --suite-dir %s: cannot create the folder\n",
                     o.suiteDir.c_str());
        return kExitIo;
    }
    installSignalHandlers();
    const auto start = std::chrono::steady_clock::now();
    std::fprintf(stderr,
                 "suite: %zu cases at %dx%d; references: pathtrace at pixel centres, two halves, "
                 "max_depth %s, first round %d spp, refined to a noise of %s or %d spp or %g s; "
                 "cache %s%s\n",
                 cases.size(), w, h,
                 o.suiteMaxDepth > 0 ? std::to_string(o.suiteMaxDepth).c_str() : "of the scene",
                 o.suiteSpp, percent(o.suiteNoise).c_str(), o.suiteMaxSpp, o.suiteSeconds,
                 o.suiteDir.c_str(), lightNote(o).c_str());
    for (const std::string& n : notes) std::fprintf(stderr, "suite: %s\n", n.c_str());

    std::vector<Result> results;
    size_t done = 0;
    for (auto& cp : clouds) {
        Cloud& c = *cp;
        std::vector<const Case*> mine;
        for (const Case& k : cases)
            if (k.cloud == &c) mine.push_back(&k);
        if (mine.empty()) continue;
        // load the cloud
        if (c.vdb) {
            std::string skip;
            if (int rc = loadVdbCloud(c, o, w, h, skip)) return rc;
            if (!skip.empty()) {
                const std::string note = c.name + ".vdb skipped: " + skip;
                std::fprintf(stderr, "suite: %s\n", note.c_str());
                notes.push_back(note);
                done += mine.size();
                continue;
            }
        } else {
            c.ls = std::make_unique<LoadedScene>();
            if (int rc = loadScene(c.source, o.overrides, o.threads, *c.ls)) return rc;
            c.frame = c.ls->firstFrame();
        }
        if (!bindFrame(*c.ls, c.frame, c.bindings)) return kExitBadInput;
        prepareBase(c, w, h);
        // the suite's light, converted from lin_rec709 to the working space
        const std::string ws = c.ls->workingSpace();
        const io::ColorSystem& cs = c.ls->colors();
        c.base.sun.enabled = true;
        c.base.sun.irradiance =
            glm::max(cs.convert(kSunIrradiance * kSunIntensity, kLightSpace, ws), vec3(0.0f));
        c.base.sky.kind = SkyKind::Gradient;
        c.base.sky.zenith = glm::max(cs.convert(kSkyZenith, kLightSpace, ws), vec3(0.0f));
        c.base.sky.horizon = glm::max(cs.convert(kSkyHorizon, kLightSpace, ws), vec3(0.0f));
        // --suite-light: one light alone (the references' keys say which)
        if (o.suiteLight == "sun") c.base.sky.kind = SkyKind::None;
        if (o.suiteLight == "sky") c.base.sun.irradiance = vec3(0.0f);

        const double columnStep = 0.5 * (c.vdb ? c.voxel : double(c.base.render.step));
        if (!measureColumns(c, columnStep)) return kExitInterrupted;
        if (c.columnPixels == 0 || !(c.column > 0.0) || !(c.sigmaT0 > 0.0f)) {
            const std::string note =
                c.name + " skipped: no camera ray meets density (or medium sigma_t is 0)";
            std::fprintf(stderr, "suite: %s\n", note.c_str());
            notes.push_back(note);
            done += mine.size();
            continue;
        }
        std::fprintf(stderr,
                     "suite: %s (grid %s): density integral over %zu of %d pixels: mean %.4g, "
                     "median %.4g; sigma_t %.4g per unit density%s\n",
                     c.name.c_str(), c.grid.c_str(), c.columnPixels, w * h, c.column,
                     c.columnMedian, double(c.sigmaT0),
                     c.vdb ? (", step " + fmt("%.4g", c.voxel) + " (one voxel)").c_str() : "");
        const Camera cam(c.base.camera);

        for (const Case* k : mine) {
            ++done;
            Result r;
            r.c = k;
            // density scale for the target mean optical depth, rounded to 4 digits
            r.densityScale =
                float(std::stod(fmt("%.4g", k->thickness->tau / (double(c.sigmaT0) * c.column))));
            r.tau = double(c.sigmaT0) * double(r.densityScale) * c.column;
            SceneDesc s = c.base;
            s.medium.sigma_s = vec3(float(k->albedo) * c.sigmaT0);
            s.medium.sigma_a = vec3(float(1.0 - k->albedo) * c.sigmaT0);
            s.medium.densityScale = r.densityScale;
            // the sky alone does not depend on the sun's position: one reference per cloud,
            // thickness and albedo, named with the sun "any" and keyed with the first sun's
            // direction, serves the three suns
            const bool skyAlone = o.suiteLight == "sky";
            s.sun.direction = sunDirection(cam, skyAlone ? kSuns[0] : *k->sun);
            const std::string cacheName =
                skyAlone ? caseName(c.name, k->thickness->name, "any", k->albedo) : k->name;

            // the reference: cached or rendered
            SceneDesc refScene = s;
            refScene.render.integrator = Integrator::PathTrace;
            refScene.render.jitter = false; // pixel centres, as march samples them
            if (o.suiteMaxDepth > 0) refScene.render.maxDepth = o.suiteMaxDepth;
            const std::string key = referenceKey(c, refScene, cacheName);
            const std::string stem =
                (fs::path(o.suiteDir) / fileNameOf(cacheName)).string() + lightSuffix(o);
            std::fprintf(stderr, "[%zu/%zu] %s: tau %.3g (density_scale %.4g), reference ", done,
                         cases.size(), k->name.c_str(), r.tau, double(r.densityScale));
            Halves hv;
            std::string why = o.suiteRerender ? "--suite-rerender" : "";
            if (why.empty()) why = readHalves(stem, key, w, h, hv);
            // a stale reference may have cost hours (a --set of a setting the path tracer reads,
            // or another --suite-size, makes every selected one stale): kept beside, not
            // overwritten, and taken back when a later run's settings match it again
            const bool stale = why.rfind("stale: ", 0) == 0;
            const std::string kept = stale ? keepAside(stem) : std::string();
            // (never over a stale reference that could not be kept)
            if (!why.empty() && !o.suiteRerender && (!stale || !kept.empty())) {
                const std::string stash = findStash(stem, key, w, h);
                if (!stash.empty() && moveHalves(stash, stem) &&
                    readHalves(stem, key, w, h, hv).empty()) {
                    std::fprintf(stderr, "%s; taken back from %s.a/b.exr", why.c_str(),
                                 fs::path(stash).filename().string().c_str());
                    if (!kept.empty())
                        std::fprintf(stderr, " (the other one kept as %s.a/b.exr)", kept.c_str());
                    std::fprintf(stderr, ", ");
                    why.clear();
                }
            }
            if (why.empty()) {
                r.cachedSpp = hv.spp;
                std::fprintf(stderr, "cached %d spp", hv.spp);
            } else {
                hv = Halves{};
                std::fprintf(stderr, "%s", why.c_str());
                if (!kept.empty())
                    std::fprintf(stderr, " (the old one kept as %s.a/b.exr)", kept.c_str());
            }
            // refine until the noise, the samples or the time say enough
            while (true) {
                int add = o.suiteSpp;
                if (hv.spp > 0) {
                    const double noise = relativeNoise(hv);
                    if (!(noise > o.suiteNoise) || hv.spp >= o.suiteMaxSpp ||
                        hv.seconds >= o.suiteSeconds)
                        break;
                    const double need = hv.spp * (noise / o.suiteNoise) * (noise / o.suiteNoise);
                    const double perSpp = hv.seconds / hv.spp;
                    double more = std::min(1.05 * need - hv.spp, double(o.suiteMaxSpp - hv.spp));
                    if (perSpp > 0.0) more = std::min(more, (o.suiteSeconds - hv.seconds) / perSpp);
                    add = 2 * int(std::floor(more / 2.0));
                    if (add < std::max(2, hv.spp / 4)) break; // not worth another round
                }
                std::fprintf(stderr, ", +%d spp", add);
                std::fflush(stderr);
                const double before = hv.seconds;
                if (!renderRound(refScene, c.bindings, c.frame, add, hv)) {
                    std::fprintf(stderr, "\nnimbus: interrupted\n");
                    return kExitInterrupted;
                }
                r.refRunSeconds += hv.seconds - before;
                std::fprintf(stderr, " (noise %s)", percent(relativeNoise(hv)).c_str());
                const std::string err = writeHalves(stem, key, hv, c.frame, cs, ws);
                if (!err.empty()) {
                    std::fprintf(stderr, "\nnimbus: error: --suite-dir: %s\n", err.c_str());
                    return kExitIo;
                }
            }
            Measured ref;
            ref.fb = halvesMean(hv.a, hv.b);
            ref.seconds = hv.seconds;
            const double noise = halvesNoise(hv.a, hv.b, ref.fb);
            r.spp = hv.spp;
            // march out of the box
            SceneDesc m = s;
            m.render.integrator = Integrator::March;
            Measured mr;
            if (!measure(m, c.bindings, c.frame, mr)) {
                std::fprintf(stderr, "\nnimbus: interrupted\n");
                return kExitInterrupted;
            }
            // kept beside the reference, to look at where the error is
            try {
                io::ExrMetadata mmd;
                mmd.frame = c.frame;
                mmd.seed = m.render.seed;
                mmd.renderSeconds = mr.seconds;
                mmd.settings["case"] = k->name;
                io::writeExr(stem + ".march.exr", mr.fb, cs, ws, ws, mmd);
            } catch (const std::exception& e) {
                std::fprintf(stderr, "\nnimbus: error: --suite-dir: %s\n", e.what());
                return kExitIo;
            }
            const ImageError e = imageError(mr.fb, ref.fb);
            r.pixels = e.pixels;
            const double nan = std::nan("");
            r.relRaw = e.mean > 0.0 ? e.rmse / e.mean : nan;
            r.rel = e.mean > 0.0 ? withoutNoise(e.rmse, noise) / e.mean : nan;
            r.noiseRel = e.mean > 0.0 ? noise / e.mean : nan;
            r.ratio = e.mean > 0.0 ? imageError(ref.fb, mr.fb, &ref.fb).mean / e.mean : nan;
            r.marchSeconds = mr.seconds;
            r.refSeconds = ref.seconds;
            r.msModel = mr.msModel;
            r.cloudTau = mr.cloudTau;
            std::fprintf(
                stderr, "; march (%s%s%s) %.2f s: %s (noise %s), mean ratio %.3f\n",
                mr.msModel.c_str(),
                mr.photonCellScale > 0.0
                    ? (fmt(" on %g light-volume cells", mr.photonCellScale) +
                       (mr.photonVoxelDepth >= 0.0
                            ? fmt(" (%.3g mean free paths)", mr.photonVoxelDepth)
                            : std::string()) +
                       (mr.marchOrders > 1 ? fmt(", orders 2-%g by paths", double(mr.marchOrders))
                                           : std::string()))
                          .c_str()
                    : "",
                mr.cloudTau >= 0.0
                    ? (", auto: depth " + depthText(mr.cloudTau) + " along the sun").c_str()
                    : "",
                mr.seconds, percent(r.rel).c_str(), percent(r.noiseRel).c_str(), r.ratio);
            results.push_back(r);
        }
        c.ls.reset(); // free the grid
        c.bindings = FrameBindings{};
    }

    // worst first; a case without cloud pixels (no error) counts as worst
    std::stable_sort(results.begin(), results.end(), [](const Result& a, const Result& b) {
        const double ea = std::isfinite(a.rel) ? a.rel : 1e300;
        const double eb = std::isfinite(b.rel) ? b.rel : 1e300;
        return ea > eb;
    });
    std::ostringstream md, csv;
    md << "march against pathtrace: relative RMSE over the cloud's pixels (reference alpha > "
       << kCloudAlpha << "), RGB, divided by the reference's mean there, the reference's noise "
       << "taken out in quadrature (? = the error is below that noise); " << w << "x" << h
       << ", references at pixel centres, refined to a noise of " << percent(o.suiteNoise) << " or "
       << o.suiteMaxSpp << " spp or " << o.suiteSeconds << " s"
       << (o.suiteMaxDepth > 0 ? ", max_depth " + std::to_string(o.suiteMaxDepth) : "")
       << lightNote(o)
       << "; ref. s = its render time over every round (* = read whole from the cache)\n\n";
    int sw = 5;
    for (const Result& r : results) sw = std::max(sw, int(r.c->cloud->name.size()));
    md << markdownHeader(sw);
    csv << "case,scene,grid,thickness,tau_target,tau_achieved,density_scale,sun,albedo,"
           "relative_rmse,relative_rmse_raw,mean_ratio,reference_noise,reference_spp,cloud_"
           "pixels,march_seconds,reference_seconds,reference_seconds_this_run,march_multiple_"
           "scattering,cloud_tau_sun\n";
    size_t pass = 0;
    double marchTotal = 0.0, refTotal = 0.0, refAll = 0.0;
    for (const Result& r : results) {
        md << markdownRow(r, sw);
        const Case& k = *r.c;
        csv << k.name << "," << k.cloud->name << "," << k.cloud->grid << "," << k.thickness->name
            << "," << k.thickness->tau << "," << r.tau << "," << r.densityScale << ","
            << k.sun->name << "," << k.albedo << "," << r.rel << "," << r.relRaw << "," << r.ratio
            << "," << r.noiseRel << "," << r.spp << "," << r.pixels << "," << r.marchSeconds << ","
            << r.refSeconds << "," << r.refRunSeconds << "," << r.msModel << ","
            << (r.cloudTau >= 0.0 ? fmt("%.4g", r.cloudTau) : std::string()) << "\n";
        if (std::isfinite(r.rel) && r.rel <= kTarget) ++pass;
        marchTotal += r.marchSeconds;
        refTotal += r.refRunSeconds;
        refAll += r.refSeconds;
    }
    md << "\n";
    // the median error of a set of cases (those with a finite error; NaN when none has one)
    auto median = [](std::vector<double> v) {
        v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }),
                v.end());
        if (v.empty()) return std::nan("");
        std::sort(v.begin(), v.end());
        const size_t m = v.size() / 2;
        return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
    };
    if (!results.empty()) {
        const Result& worst = results.front();
        std::vector<double> all;
        for (const Result& r : results) all.push_back(r.rel);
        md << "worst: " << worst.c->name << " at " << percent(worst.rel) << " (mean ratio "
           << fmt("%.3f", worst.ratio) << "); " << pass << " of " << results.size()
           << " cases within " << percent(kTarget) << "; median " << percent(median(all)) << "\n";
    }
    // the worst case along each axis of the matrix
    auto byAxis = [&](const char* axis, auto value) {
        std::map<std::string, std::pair<size_t, const Result*>> worst; // value -> (passed, worst)
        std::vector<std::string> order;
        for (const Result& r : results) {
            const std::string v = value(*r.c);
            if (!worst.count(v)) {
                order.push_back(v);
                worst[v] = {0, &r}; // sorted worst first: the first seen is the worst
            }
            if (std::isfinite(r.rel) && r.rel <= kTarget) ++worst[v].first;
        }
        md << "by " << axis << ":";
        std::sort(order.begin(), order.end());
        for (const std::string& v : order) {
            std::vector<double> rel;
            for (const Result& r : results)
                if (value(*r.c) == v) rel.push_back(r.rel);
            md << " " << v << " " << worst[v].first << "/" << rel.size() << " (median "
               << percent(median(rel)) << ", worst " << percent(worst[v].second->rel) << ");";
        }
        md << "\n";
    };
    if (!results.empty()) {
        byAxis("cloud", [](const Case& k) { return k.cloud->name; });
        byAxis("thickness", [](const Case& k) { return std::string(k.thickness->name); });
        byAxis("sun", [](const Case& k) { return std::string(k.sun->name); });
        byAxis("albedo", [](const Case& k) { return "a" + albedoName(k.albedo); });
    }
    md << "march " << fmt("%.1f", marchTotal) << " s in all; references " << fmt("%.1f", refAll)
       << " s of rendering in all, " << fmt("%.1f", refTotal) << " s of it in this run; the run "
       << fmt("%.1f", secondsSince(start)) << " s\n";
    for (const std::string& n : notes) md << "note: " << n << "\n";
    std::cout << md.str();
    const std::string stemOut = (fs::path(o.suiteDir) / ("suite" + lightSuffix(o))).string();
    const std::string csvPath = o.csv.empty() ? stemOut + ".csv" : o.csv;
    if (!writeText(csvPath, csv.str())) return kExitIo;
    if (!writeText(stemOut + ".md", md.str())) return kExitIo;
    std::fprintf(stderr, "wrote %s and %s.md\n", csvPath.c_str(), stemOut.c_str());
    return kExitOk;
}

} // namespace nimbus::cli
