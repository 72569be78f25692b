// What the frame plan leaves out costs nothing: the default scene's cloud with no lights (a
// minimal scene) against the same cloud with every optional feature present in the file but
// switched off (sun and sky tables with enabled = false / kind = "none", a ground table with
// enabled = false, photons, a light-attenuation volume, the sky-volume and column-occlusion
// keys, 8 octaves). The two are rendered interleaved (A B B A ...) in one
// process through the render session, so that the machine's load drifts over both alike; the
// ratio of their median frame times is reported (docs/plan.md). No time is asserted anywhere.
//   ./tests/nimbus_bench --benchmark_filter=PlanOff
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <vector>

#include "plugin/host/session.h"

using namespace nimbus;

namespace {

/// The default scene's camera, medium and cloud at 160x90, without lights.
std::string minimalScene() {
    return "frames = \"1\"\n"
           "[camera]\nposition = [0.0, 0.3, -24.0]\nlook_at = [0.0, 5.5, 0.0]\nfov = 45.0\n"
           "width = 160\nheight = 90\n"
           "[sun]\nenabled = false\n"
           "[sky]\nkind = \"none\"\n"
           "[medium]\nsigma_s = 12.0\ng = 0.5\n"
           "[field]\nkind = \"cumulus\"\nbounds_min = [-30.0, 1.2, -20.0]\n"
           "bounds_max = [30.0, 5.2, 40.0]\ncoverage = 0.85\nevaluation = \"direct\"\nseed = 7\n"
           "[render]\nstep = 0.04\nstep_growth = 0.004\nthreads = 2\n";
}

/// The same frame with every optional feature present and switched off: were any of them built
/// (a light volume of 0.1 km voxels over 60 x 4 x 60 km is 14 M voxels, 4 M photons), the
/// frame would take many times longer.
std::string everythingOffScene() {
    return "frames = \"1\"\n"
           "[camera]\nposition = [0.0, 0.3, -24.0]\nlook_at = [0.0, 5.5, 0.0]\nfov = 45.0\n"
           "width = 160\nheight = 90\n"
           "[sun]\nenabled = false\nelevation = 20.0\nazimuth = 90.0\nintensity = 12.0\n"
           "[sky]\nkind = \"none\"\nzenith = [0.16, 0.32, 0.70]\nambient = 1.0\n"
           "[ground]\nenabled = false\nalbedo = 0.3\n"
           "[medium]\nsigma_s = 12.0\ng = 0.5\n"
           "[field]\nkind = \"cumulus\"\nbounds_min = [-30.0, 1.2, -20.0]\n"
           "bounds_max = [30.0, 5.2, 40.0]\ncoverage = 0.85\nevaluation = \"direct\"\nseed = 7\n"
           "[render]\nstep = 0.04\nstep_growth = 0.004\nthreads = 2\n"
           "shadow = \"volume\"\nlight_volume_cell = 0.1\nmultiple_scattering = \"photons\"\n"
           "photons = 4000000\nsky_occlusion = \"column\"\nsky_shadow = \"volume\"\n"
           "sky_directions = 64\noctaves = 8\n"
           "[output]\naovs = []\n";
}

double renderSeconds(host::Session& s, RenderStats& st) {
    Framebuffer fb;
    const auto t0 = std::chrono::steady_clock::now();
    const host::Status status = s.render(1, fb, st);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!status.ok()) return -1.0;
    return t;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Arg: pairs of frames rendered (A B, then B A, alternately).
void BM_PlanOff(benchmark::State& state) {
    host::Session minimal, off;
    if (!minimal.loadString(minimalScene(), "minimal.toml").ok() ||
        !off.loadString(everythingOffScene(), "everything_off.toml").ok()) {
        state.SkipWithError("scene did not load");
        return;
    }
    minimal.takeWarnings();
    off.takeWarnings();
    RenderStats sa, sb;
    renderSeconds(minimal, sa); // bind, warm caches
    renderSeconds(off, sb);
    std::vector<double> ta, tb, ratio;
    for (auto _ : state) {
        for (int k = 0; k < state.range(0); ++k) {
            double a, b;
            if (k % 2 == 0) {
                a = renderSeconds(minimal, sa);
                b = renderSeconds(off, sb);
            } else {
                b = renderSeconds(off, sb);
                a = renderSeconds(minimal, sa);
            }
            if (a < 0.0 || b < 0.0) {
                state.SkipWithError("render failed");
                return;
            }
            ta.push_back(a);
            tb.push_back(b);
            ratio.push_back(b / a);
        }
    }
    state.counters["minimal_s"] = median(ta);
    state.counters["off_s"] = median(tb);
    state.counters["ratio"] = median(ratio);
    state.counters["ratio_min"] = *std::min_element(ratio.begin(), ratio.end());
    state.counters["ratio_max"] = *std::max_element(ratio.begin(), ratio.end());
    state.counters["lookups_minimal"] = double(sa.lookups());
    state.counters["lookups_off"] = double(sb.lookups());
    state.counters["light_voxels_off"] = double(sb.lightVolumeVoxels + sb.densityGridVoxels);
    state.SetLabel("median frame time, everything off / minimal");
}
BENCHMARK(BM_PlanOff)->Arg(10)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

} // namespace
