#include "core/media/mie.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace nimbus {

namespace {

using cdouble = std::complex<double>;
constexpr double kPi = std::numbers::pi;

/// Wiscombe 1980: number of terms of the Mie series.
int seriesLength(double x) {
    return std::max(1, int(x + 4.0 * std::cbrt(x) + 2.0));
}

/// Scattering angles (degrees) of the half grid [0, 90], ascending: fine near 0 for the
/// diffraction peak; the table mirrors it to [90, 180] so the glory gets the same resolution.
std::vector<double> halfGridDegrees() {
    struct Segment {
        double end, step;
    };
    const Segment segments[] = {{1.0, 0.02}, {3.0, 0.05}, {10.0, 0.1}, {90.0, 0.2}};
    std::vector<double> deg{0.0};
    double start = 0.0;
    for (const Segment& s : segments) {
        const int n = int(std::lround((s.end - start) / s.step));
        for (int i = 1; i <= n; ++i) deg.push_back(start + (s.end - start) * i / n);
        start = s.end;
    }
    return deg;
}

/// Radii [lo, hi] (micrometres) outside which the area-weighted gamma density
/// r^{1/v - 1} exp(-r / (r_eff v)) is below cutoff times its peak.
std::pair<double, double> radiusRange(double rEff, double v, double cutoff) {
    const double k = 1.0 / v, theta = rEff * v;
    const double mode = std::max((k - 1.0) * theta, 1e-6);
    const double logCut = std::log(cutoff);
    auto logRatio = [&](double r) { return (k - 1.0) * std::log(r / mode) - (r - mode) / theta; };
    auto solve = [&](double a, double b) { // logRatio(a) >= logCut > logRatio(b), monotone
        for (int i = 0; i < 200; ++i) {
            double m = 0.5 * (a + b);
            (logRatio(m) >= logCut ? a : b) = m;
        }
        return 0.5 * (a + b);
    };
    double hi = mode + theta;
    while (logRatio(hi) >= logCut) hi = mode + 2.0 * (hi - mode);
    double lo = 0.0;
    if (k > 1.0 && logRatio(mode * 1e-9) < logCut) lo = solve(mode, mode * 1e-9);
    return {lo, solve(mode, hi)};
}

/// The hot loop of the table: adds the term of one n to the sums of Re/Im of a pi (A0, A1),
/// b tau (A2, A3), a tau (A4, A5) and b pi (A6, A7) over the H half-grid angles. (Separate
/// restrict pointers: GCC 12 does not vectorise the loop when they are offsets of one array.)
void accumulateTerm(const float* __restrict pi, const float* __restrict tau, float* __restrict A0,
                    float* __restrict A1, float* __restrict A2, float* __restrict A3,
                    float* __restrict A4, float* __restrict A5, float* __restrict A6,
                    float* __restrict A7, int H, float ar, float ai, float br, float bi) {
    for (int j = 0; j < H; ++j) {
        const float p = pi[j], q = tau[j];
        A0[j] += ar * p;
        A1[j] += ai * p;
        A2[j] += br * q;
        A3[j] += bi * q;
        A4[j] += ar * q;
        A5[j] += ai * q;
        A6[j] += br * p;
        A7[j] += bi * p;
    }
}

} // namespace

// ------------------------------------------------------------------------------------------
// BHMIE
// ------------------------------------------------------------------------------------------

void mieCoefficients(cdouble m, double x, std::vector<cdouble>& a, std::vector<cdouble>& b) {
    const int nstop = seriesLength(x);
    const cdouble y = m * x;
    // start far enough above |mx| for the recurrence to forget its start value: the
    // transition region of D_n around n = |mx| is ~|mx|^{1/3} wide (B&H's |mx| + 15 is not
    // enough when m x > x + 4 x^{1/3}: errors of 1e-5 at x = 100, m = 1.33)
    const double ymod = std::abs(y);
    const int nmx = std::max(nstop, int(ymod + 4.0 * std::cbrt(ymod))) + 15;
    // logarithmic derivative D_n(mx) by downward recurrence from D_nmx = 0
    std::vector<cdouble> D(nmx + 1);
    D[nmx] = 0.0;
    for (int n = nmx; n >= 1; --n) {
        const cdouble ny = double(n) / y;
        D[n - 1] = ny - 1.0 / (D[n] + ny);
    }
    a.resize(nstop);
    b.resize(nstop);
    // Riccati-Bessel psi_n, chi_n by upward recurrence; xi_n = psi_n - i chi_n
    double psi0 = std::cos(x), psi1 = std::sin(x);
    double chi0 = -std::sin(x), chi1 = std::cos(x);
    cdouble xi1(psi1, -chi1);
    for (int n = 1; n <= nstop; ++n) {
        const double en = n;
        const double psi = (2.0 * en - 1.0) * psi1 / x - psi0;
        const double chi = (2.0 * en - 1.0) * chi1 / x - chi0;
        const cdouble xi(psi, -chi);
        const cdouble da = D[n] / m + en / x;
        const cdouble db = m * D[n] + en / x;
        a[n - 1] = (da * psi - psi1) / (da * xi - xi1);
        b[n - 1] = (db * psi - psi1) / (db * xi - xi1);
        psi0 = psi1;
        psi1 = psi;
        chi0 = chi1;
        chi1 = chi;
        xi1 = cdouble(psi1, -chi1);
    }
}

namespace {

/// Efficiencies and asymmetry from the coefficients (Bohren & Huffman 1983, ch. 4).
void efficiencies(double x, const std::vector<cdouble>& a, const std::vector<cdouble>& b,
                  MieSphere& out) {
    const int N = int(a.size());
    double sca = 0.0, ext = 0.0, asym = 0.0;
    cdouble back = 0.0;
    for (int i = 0; i < N; ++i) {
        const double n = i + 1;
        sca += (2.0 * n + 1.0) * (std::norm(a[i]) + std::norm(b[i]));
        ext += (2.0 * n + 1.0) * (a[i].real() + b[i].real());
        asym += (2.0 * n + 1.0) / (n * (n + 1.0)) * (a[i] * std::conj(b[i])).real();
        if (i + 1 < N)
            asym += n * (n + 2.0) / (n + 1.0) *
                    (a[i] * std::conj(a[i + 1]) + b[i] * std::conj(b[i + 1])).real();
        back += (2.0 * n + 1.0) * (i % 2 ? 1.0 : -1.0) * (a[i] - b[i]);
    }
    out.terms = N;
    out.qsca = 2.0 / (x * x) * sca;
    out.qext = 2.0 / (x * x) * ext;
    out.qback = std::norm(back) / (x * x);
    out.g = out.qsca > 0.0 ? 4.0 / (x * x) * asym / out.qsca : 0.0;
}

} // namespace

MieSphere mieSphere(cdouble m, double x, std::span<const double> cosTheta) {
    std::vector<cdouble> a, b;
    mieCoefficients(m, x, a, b);
    MieSphere out;
    efficiencies(x, a, b, out);
    out.s1.assign(cosTheta.size(), 0.0);
    out.s2.assign(cosTheta.size(), 0.0);
    for (size_t j = 0; j < cosTheta.size(); ++j) {
        const double mu = cosTheta[j];
        double pi0 = 0.0, pi1 = 1.0; // pi_{n-1}, pi_n
        cdouble s1 = 0.0, s2 = 0.0;
        for (int i = 0; i < int(a.size()); ++i) {
            const double n = i + 1;
            const double tau = n * mu * pi1 - (n + 1.0) * pi0;
            const double c = (2.0 * n + 1.0) / (n * (n + 1.0));
            s1 += c * (a[i] * pi1 + b[i] * tau);
            s2 += c * (a[i] * tau + b[i] * pi1);
            const double next = ((2.0 * n + 1.0) * mu * pi1 - (n + 1.0) * pi0) / n;
            pi0 = pi1;
            pi1 = next;
        }
        out.s1[j] = s1;
        out.s2[j] = s2;
    }
    return out;
}

// ------------------------------------------------------------------------------------------
// The table
// ------------------------------------------------------------------------------------------

MieTable MieTable::compute(const MieTableParams& params) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    MieTable t;
    t.params_ = params;

    // angle grid: half [0, 90] (mu_j = cos, descending), full grid mirrored, mu ascending
    const std::vector<double> half = halfGridDegrees();
    const int H = int(half.size()); // half.back() == 90
    std::vector<double> muHalf(H);
    for (int j = 0; j < H; ++j) muHalf[j] = j == H - 1 ? 0.0 : std::cos(half[j] * kPi / 180.0);
    const int M = 2 * H - 1;
    // full node k (mu ascending): k < H - 1 -> -muHalf[k]; k >= H - 1 -> muHalf[M - 1 - k]
    auto plusIndex = [&](int j) { return M - 1 - j; };
    auto minusIndex = [&](int j) { return j; };

    // radii and size parameters per channel
    const double v = params.effectiveVariance, rEff = params.effectiveRadius;
    const auto [rLo, rHi] = radiusRange(rEff, v, params.tailCutoff);
    struct Channel {
        double x0 = 0.0, dx = 0.0, k = 0.0; ///< x_i = x0 + (i + 1/2) dx; k = 2 pi / lambda
        int sizes = 0;
    };
    std::array<Channel, 3> ch;
    int nMax = 1;
    for (int c = 0; c < 3; ++c) {
        ch[c].k = 2.0 * kPi / params.wavelength[c];
        const double xLo = ch[c].k * rLo, xHi = ch[c].k * rHi;
        // the step: sizeStep, or coarser for wide distributions of large droplets, keeping
        // samplesPerWidth samples per standard deviation of the area-weighted x
        const double width = ch[c].k * rEff * std::sqrt(v);
        const double step = std::max(params.sizeStep, width / params.samplesPerWidth);
        ch[c].sizes = std::max(1, int(std::ceil((xHi - xLo) / step)));
        ch[c].dx = (xHi - xLo) / ch[c].sizes;
        ch[c].x0 = xLo;
        nMax = std::max(nMax, seriesLength(xHi) + 1);
        t.stats_.sizes[c] = ch[c].sizes;
        t.stats_.maxSizeParameter[c] = xHi;
    }

    // angular functions pi_n(mu), tau_n(mu) on the half grid, n = 1..nMax (row n - 1); float
    // suffices for the sums (relative error ~1e-6 of |S| at every angle, far below the size
    // sampling noise) and doubles their speed
    std::vector<float> piT(size_t(nMax) * H), tauT(size_t(nMax) * H);
    for (int j = 0; j < H; ++j) {
        const double mu = muHalf[j];
        double pi0 = 0.0, pi1 = 1.0;
        for (int n = 1; n <= nMax; ++n) {
            piT[size_t(n - 1) * H + j] = float(pi1);
            tauT[size_t(n - 1) * H + j] = float(n * mu * pi1 - (n + 1.0) * pi0);
            const double next = ((2.0 * n + 1.0) * mu * pi1 - (n + 1.0) * pi0) / n;
            pi0 = pi1;
            pi1 = next;
        }
    }

    // work items: fixed chunks of sizes per channel; partial sums are added in a fixed order,
    // so the table does not depend on the thread count
    constexpr int kChunk = 16;
    struct Task {
        int channel, first, last;
        std::vector<double> intensity;              ///< sum of w (|S1|^2 + |S2|^2) at the M nodes
        double csca = 0.0, cext = 0.0, gcsca = 0.0; ///< sums of w x^2 Q (and w x^2 Q g)
    };
    std::vector<Task> tasks;
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < ch[c].sizes; i += kChunk)
            tasks.push_back({c, i, std::min(ch[c].sizes, i + kChunk), {}, 0.0, 0.0, 0.0});

    const double alphaGamma = (1.0 - 3.0 * v) / v; // n(r) ~ r^alpha exp(-r / (r_eff v))
    const double mode = std::max((1.0 / v - 1.0) * rEff * v, 1e-6);
    auto density = [&](double r) {
        return std::exp(alphaGamma * std::log(r / mode) - (r - mode) / (rEff * v));
    };
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, tasks.size(), 1),
        [&](const tbb::blocked_range<size_t>& range) {
            std::vector<cdouble> a, b;
            // per parity of n: sums of Re/Im of a pi, b tau, a tau, b pi (8 arrays of H)
            std::vector<float> acc(16 * size_t(H));
            for (size_t ti = range.begin(); ti != range.end(); ++ti) {
                Task& task = tasks[ti];
                const Channel& C = ch[task.channel];
                const cdouble m = params.refractiveIndex[task.channel];
                task.intensity.assign(M, 0.0);
                for (int i = task.first; i < task.last; ++i) {
                    const double x = C.x0 + (i + 0.5) * C.dx;
                    const double w = density(x / C.k);
                    if (!(w > 0.0)) continue;
                    mieCoefficients(m, x, a, b);
                    MieSphere eff;
                    efficiencies(x, a, b, eff);
                    task.csca += w * x * x * eff.qsca;
                    task.cext += w * x * x * eff.qext;
                    task.gcsca += w * x * x * eff.qsca * eff.g;
                    std::fill(acc.begin(), acc.end(), 0.0f);
                    for (int n = 1; n <= int(a.size()); ++n) {
                        const double c = (2.0 * n + 1.0) / (double(n) * (n + 1.0));
                        const float ar = float(c * a[n - 1].real()),
                                    ai = float(c * a[n - 1].imag());
                        const float br = float(c * b[n - 1].real()),
                                    bi = float(c * b[n - 1].imag());
                        float* A = &acc[size_t(n & 1) * 8 * H];
                        accumulateTerm(&piT[size_t(n - 1) * H], &tauT[size_t(n - 1) * H], A, A + H,
                                       A + 2 * H, A + 3 * H, A + 4 * H, A + 5 * H, A + 6 * H,
                                       A + 7 * H, H, ar, ai, br, bi);
                    }
                    // S1(+mu) = sum (a pi + b tau), S2(+mu) = sum (a tau + b pi); at -mu the odd-n
                    // terms keep the sign of pi and flip that of tau, the even-n terms the opposite
                    // (pi_n(-mu) = (-1)^{n-1} pi_n(mu), tau_n(-mu) = (-1)^n tau_n(mu))
                    const float* O = &acc[8 * size_t(H)]; // odd n
                    const float* E = &acc[0];             // even n
                    for (int j = 0; j < H; ++j) {
                        auto at = [&](const float* X, int k) {
                            return double(X[size_t(k) * H + j]);
                        };
                        const double s1pr = at(O, 0) + at(E, 0) + at(O, 2) + at(E, 2);
                        const double s1pi = at(O, 1) + at(E, 1) + at(O, 3) + at(E, 3);
                        const double s2pr = at(O, 4) + at(E, 4) + at(O, 6) + at(E, 6);
                        const double s2pi = at(O, 5) + at(E, 5) + at(O, 7) + at(E, 7);
                        const double s1mr = at(O, 0) - at(E, 0) - at(O, 2) + at(E, 2);
                        const double s1mi = at(O, 1) - at(E, 1) - at(O, 3) + at(E, 3);
                        const double s2mr = -at(O, 4) + at(E, 4) + at(O, 6) - at(E, 6);
                        const double s2mi = -at(O, 5) + at(E, 5) + at(O, 7) - at(E, 7);
                        const double ip = s1pr * s1pr + s1pi * s1pi + s2pr * s2pr + s2pi * s2pi;
                        const double im = s1mr * s1mr + s1mi * s1mi + s2mr * s2mr + s2mi * s2mi;
                        task.intensity[plusIndex(j)] += w * ip;
                        if (j != H - 1) task.intensity[minusIndex(j)] += w * im;
                    }
                }
            }
        });

    // reduce in task order; phase = sum w (|S1|^2 + |S2|^2) / (2 pi sum w x^2 Qsca)
    std::array<std::vector<double>, 3> phase;
    std::array<double, 3> csca{}, cext{}, gcsca{};
    for (int c = 0; c < 3; ++c) phase[c].assign(M, 0.0);
    for (const Task& task : tasks) {
        for (int k = 0; k < M; ++k) phase[task.channel][k] += task.intensity[k];
        csca[task.channel] += task.csca;
        cext[task.channel] += task.cext;
        gcsca[task.channel] += task.gcsca;
    }
    // the nodes as they will be stored (float): normalise against those, since near the
    // forward peak half an ulp of cos times the peak value adds up to ~1e-5 of the integral
    std::vector<double> mu(M);
    for (int k = 0; k < M; ++k) mu[k] = float(k < H - 1 ? -muHalf[k] : muHalf[M - 1 - k]);
    mu.front() = -1.0;
    mu.back() = 1.0;
    for (int c = 0; c < 3; ++c) {
        const Channel& C = ch[c];
        for (double& p : phase[c]) p /= 2.0 * kPi * csca[c];
        double integral = 0.0;
        for (int k = 0; k + 1 < M; ++k)
            integral += (mu[k + 1] - mu[k]) * 0.5 * (phase[c][k] + phase[c][k + 1]);
        integral *= 2.0 * kPi;
        t.stats_.rawNormalisation[c] = integral;
        for (double& p : phase[c]) p /= integral;
        t.stats_.asymmetry[c] = gcsca[c] / csca[c];
        // area-weighted efficiencies: sum w x^2 Q / sum w x^2
        double wsum = 0.0;
        for (int i = 0; i < C.sizes; ++i) {
            const double x = C.x0 + (i + 0.5) * C.dx;
            wsum += density(x / C.k) * x * x;
        }
        t.stats_.qsca[c] = csca[c] / wsum;
        t.stats_.qext[c] = cext[c] / wsum;
    }

    t.cos_.resize(M);
    for (int k = 0; k < M; ++k) t.cos_[k] = float(mu[k]);
    t.cos_.front() = -1.0f;
    t.cos_.back() = 1.0f;
    for (int c = 0; c < 3; ++c) {
        t.value_[c].resize(M);
        for (int k = 0; k < M; ++k) t.value_[c][k] = float(phase[c][k]);
    }
    t.value_[kSampling].resize(M);
    for (int k = 0; k < M; ++k)
        t.value_[kSampling][k] = float((phase[0][k] + phase[1][k] + phase[2][k]) / 3.0);
    t.finish();
    t.stats_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t.stats_.cpuSeconds = double(std::clock() - c0) / CLOCKS_PER_SEC;
    return t;
}

namespace {

constexpr int kGuideBins = 4096;

/// Monotone map of cos to [0, 2], close to linear in the angle at both ends (where the grid is
/// dense): sqrt(1 + mu) for mu < 0, 2 - sqrt(1 - mu) for mu >= 0.
inline float guideCoordinate(float mu) {
    return mu < 0.0f ? std::sqrt(std::max(0.0f, 1.0f + mu)) : 2.0f - std::sqrt(1.0f - mu);
}

} // namespace

void MieTable::finish() {
    const int M = int(cos_.size());
    // the cos lookup: guide_[b] = an interval at or before the first one of bin b
    guide_.resize(kGuideBins);
    for (int b = 0; b < kGuideBins; ++b) {
        const double m = 2.0 * b / kGuideBins;
        const double mu = m < 1.0 ? m * m - 1.0 : 1.0 - (2.0 - m) * (2.0 - m);
        int i = int(std::upper_bound(cos_.begin(), cos_.end(), float(mu)) - cos_.begin()) - 1;
        guide_[b] = std::uint16_t(std::clamp(i - 1, 0, M - 2));
    }
    // CDF of the sampling channel (piecewise-linear density in mu), and its guide table
    const std::vector<float>& p = value_[kSampling];
    cdf_.assign(M, 0.0);
    for (int k = 0; k + 1 < M; ++k)
        cdf_[k + 1] =
            cdf_[k] + 2.0 * kPi * (double(cos_[k + 1]) - cos_[k]) * 0.5 * (double(p[k]) + p[k + 1]);
    const double total = cdf_.back();
    for (double& c : cdf_) c /= total;
    cdf_.back() = 1.0;
    cdfGuide_.resize(M);
    int i = 0;
    for (int b = 0; b < M; ++b) {
        const double u = double(b) / M;
        while (i < M - 2 && cdf_[i + 1] <= u) ++i;
        cdfGuide_[b] = std::uint16_t(i);
    }
    // mean cosines, exact for the piecewise-linear functions
    for (int c = 0; c < 4; ++c) {
        double m1 = 0.0;
        for (int k = 0; k + 1 < M; ++k) {
            const double a = cos_[k], b = cos_[k + 1], pa = value_[c][k], pb = value_[c][k + 1];
            m1 += (b - a) * (pa * (2.0 * a + b) + pb * (a + 2.0 * b)) / 6.0;
        }
        meanCosine_[c] = float(2.0 * kPi * m1);
    }
}

int MieTable::interval(float mu) const {
    const int last = int(cos_.size()) - 2;
    mu = std::clamp(mu, -1.0f, 1.0f);
    const int b = std::min(kGuideBins - 1, int(guideCoordinate(mu) * (0.5f * kGuideBins)));
    int i = guide_[b];
    while (i > 0 && cos_[i] > mu) --i;
    while (i < last && cos_[i + 1] < mu) ++i;
    return i;
}

float MieTable::eval(int channel, float mu) const {
    const int i = interval(mu);
    const float a = cos_[i], b = cos_[i + 1];
    const float t = std::clamp((mu - a) / (b - a), 0.0f, 1.0f);
    const std::vector<float>& v = value_[channel];
    return v[i] + t * (v[i + 1] - v[i]);
}

vec3 MieTable::eval(float mu) const {
    const int i = interval(mu);
    const float a = cos_[i], b = cos_[i + 1];
    const float t = std::clamp((mu - a) / (b - a), 0.0f, 1.0f);
    const vec3 v0(value_[0][i], value_[1][i], value_[2][i]);
    const vec3 v1(value_[0][i + 1], value_[1][i + 1], value_[2][i + 1]);
    return v0 + t * (v1 - v0);
}

float MieTable::sample(float uf) const {
    const int M = int(cos_.size());
    const double u = std::clamp(double(uf), 0.0, 1.0);
    int i = cdfGuide_[std::min(M - 1, int(u * M))];
    while (i < M - 2 && cdf_[i + 1] <= u) ++i;
    // density p0 + (p1 - p0) t over mu = a + t h, t in [0, 1]: the mass below t, per unit of
    // t, is p0 t + (p1 - p0) t^2 / 2 =: R, which runs from 0 to (p0 + p1) / 2 over the interval
    const double a = cos_[i], h = double(cos_[i + 1]) - a;
    const double p0 = value_[kSampling][i], p1 = value_[kSampling][i + 1];
    const double mass = cdf_[i + 1] - cdf_[i];
    const double R = mass > 0.0 ? (u - cdf_[i]) / mass * 0.5 * (p0 + p1) : 0.0;
    const double d = p1 - p0;
    const double disc = std::max(0.0, p0 * p0 + 2.0 * d * R);
    const double den = p0 + std::sqrt(disc);
    double t = den > 0.0 ? 2.0 * R / den : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    return float(std::clamp(a + t * h, -1.0, 1.0));
}

// ------------------------------------------------------------------------------------------
// Process-wide cache
// ------------------------------------------------------------------------------------------

std::shared_ptr<const MieTable> sharedMieTable(const MieTableParams& p) {
    static std::mutex mutex;
    static std::map<std::vector<float>, std::shared_ptr<const MieTable>> cache;
    // compared in float precision: scene files give floats (0.1f is not 0.1)
    std::vector<float> key{float(p.effectiveRadius), float(p.effectiveVariance), float(p.sizeStep),
                           float(p.samplesPerWidth), float(p.tailCutoff)};
    for (int c = 0; c < 3; ++c) {
        key.push_back(float(p.wavelength[c]));
        key.push_back(float(p.refractiveIndex[c].real()));
        key.push_back(float(p.refractiveIndex[c].imag()));
    }
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
    // isolated: while it waits for its own tasks this thread must not pick up outer tasks
    // (e.g. other render tiles) that could ask for the lock it holds
    std::shared_ptr<const MieTable> table;
    tbb::this_task_arena::isolate(
        [&] { table = std::make_shared<const MieTable>(MieTable::compute(p)); });
    cache.emplace(std::move(key), table);
    return table;
}

} // namespace nimbus
