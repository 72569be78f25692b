/// @file mie.h
/// @brief Lorenz-Mie scattering by a homogeneous sphere (Bohren & Huffman 1983, BHMIE) and a
///        tabulated cloud phase function averaged over a droplet size distribution.
///
/// `mieSphere` is the BHMIE algorithm in double precision: the logarithmic derivative
/// D_n(mx) by downward recurrence, the Riccati-Bessel functions psi_n, chi_n by upward
/// recurrence, series truncated after x + 4 x^{1/3} + 2 terms (Wiscombe 1980). It is accurate
/// for size parameters up to ~10^4 (tests compare with published values at x = 5.2, 100, 1000
/// and 10^4).
///
/// `MieTable` integrates the scattered intensity over Hansen's (1971) gamma distribution of
/// droplet radii, n(r) ~ r^{(1 - 3 v)/v} exp(-r / (r_eff v)) (a modified gamma distribution
/// with effective radius r_eff and effective variance v), at three wavelengths (R, G, B). The
/// phase function is tabulated on an angle grid that is dense near 0 and 180 degrees (forward
/// diffraction peak, glory), normalised per channel, and interpolated LINEARLY IN cos(theta)
/// between the nodes: that piecewise-linear function is the phase function (eval), and the
/// average of the three channels is the sampling density (pdf), sampled exactly by inverting
/// its piecewise-quadratic CDF.
///
/// @note Conventions: refractive index m = n + i k with k >= 0 for an absorbing sphere (Bohren
///       & Huffman's, time dependence e^{-i omega t}); angles are scattering angles (0 = forward)
///       and cos(theta) = 1 is forward, as in core/kernels/phase.glsl.
/// @note No I/O and no caching on disk: a table takes about a second to compute (TBB over size
///       bins); sharedMieTable() keeps one per parameter set for the life of the process.
///
/// @code
///   MieTableParams p;           // r_eff = 10 um, v_eff = 0.1, water at 680/550/440 nm
///   MieTable t = MieTable::compute(p);
///   vec3 rgb = t.eval(cosTheta);   // 1/sr per channel
///   float mu = t.sample(u);        // distributed with density t.pdf(mu) over the sphere
/// @endcode
#pragma once

#include <array>
#include <complex>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/geometry.h"

namespace nimbus {

/// Scattering by one sphere of size parameter x = 2 pi r / lambda and relative refractive index m.
struct MieSphere {
    double qext = 0.0;  ///< extinction efficiency (from the series; equals 4/x^2 Re S(0))
    double qsca = 0.0;  ///< scattering efficiency
    double qback = 0.0; ///< backscattering efficiency |sum (2n+1)(-1)^n (a_n - b_n)|^2 / x^2
    double g = 0.0;     ///< asymmetry parameter <cos theta>
    int terms = 0;      ///< series length
    std::vector<std::complex<double>> s1, s2; ///< amplitudes S1, S2 at the requested cosines
};

/// BHMIE. @p cosTheta: cosines of the scattering angles at which S1, S2 are wanted (may be
/// empty). The phase function is (|S1|^2 + |S2|^2) / (2 pi x^2 qsca), normalised to 1 over the
/// sphere.
MieSphere mieSphere(std::complex<double> m, double x, std::span<const double> cosTheta = {});

/// Mie coefficients a_n, b_n, n = 1..terms (stored at index n - 1).
void mieCoefficients(std::complex<double> m, double x, std::vector<std::complex<double>>& a,
                     std::vector<std::complex<double>>& b);

/// What a MieTable is computed from.
struct MieTableParams {
    double effectiveRadius = 10.0;  ///< r_eff, micrometres (cumulus ~ 6-12)
    double effectiveVariance = 0.1; ///< v_eff, dimensionless, in (0, 0.5)
    /// Wavelengths (micrometres) of the R, G, B channels.
    std::array<double, 3> wavelength{0.680, 0.550, 0.440};
    /// Water at those wavelengths: real part from Hale & Querry 1973 (25 C), imaginary part
    /// from the absorption coefficient of Pope & Fry 1997 (k = a lambda / 4 pi).
    std::array<std::complex<double>, 3> refractiveIndex{std::complex<double>(1.331, 2.5e-8),
                                                        std::complex<double>(1.333, 2.5e-9),
                                                        std::complex<double>(1.338, 2.2e-10)};
    /// Size-parameter step of the integration over radii (midpoint rule in x per channel). The
    /// narrow Mie resonances make the integrand spiky; at 0.1 the defaults come within 2% of a
    /// step-0.025 reference at every angle (within 1e-4 in mean cosine). Cost ~ 1 / step.
    double sizeStep = 0.1;
    /// ... but no finer than this many steps per standard deviation of the (area-weighted) size
    /// parameter: keeps wide distributions of large droplets affordable (cost ~ x_max^2 / step).
    /// The defaults are not affected (step 0.1 at 680-440 nm).
    double samplesPerWidth = 500.0;
    /// Radii whose area-weighted density is below this fraction of its peak are left out.
    double tailCutoff = 1e-6;
};

/// A Lorenz-Mie phase function tabulated per RGB channel plus a sampling channel (their mean).
class MieTable {
  public:
    static constexpr int kSampling = 3; ///< channel index of the sampling density

    /// Computes the table (TBB over size bins; ~1 s for the defaults on 2 cores).
    static MieTable compute(const MieTableParams& params = {});

    /// Phase function per RGB channel at cos(theta) (1/sr, each channel normalised to 1).
    vec3 eval(float cosTheta) const;
    /// One channel: 0, 1, 2 = R, G, B; 3 = the sampling channel (mean of R, G, B).
    float eval(int channel, float cosTheta) const;
    /// Density over the sphere (1/sr) of sample(): the sampling channel.
    float pdf(float cosTheta) const { return eval(kSampling, cosTheta); }
    /// cos(theta) distributed with density pdf(); u in [0, 1). Inverse CDF: monotone in u.
    float sample(float u) const;
    /// Mean cosine of the sampling channel (exact for the interpolated table).
    float meanCosine() const { return meanCosine_[kSampling]; }
    /// Mean cosine per RGB channel (exact for the interpolated table).
    vec3 meanCosineRGB() const { return vec3(meanCosine_[0], meanCosine_[1], meanCosine_[2]); }

    const MieTableParams& params() const { return params_; }
    /// Table nodes: cos(theta) ascending from -1 to 1.
    const std::vector<float>& cosines() const { return cos_; }
    /// Node values of one channel (1/sr).
    const std::vector<float>& values(int channel) const { return value_[channel]; }

    /// Diagnostics of the computation.
    struct Stats {
        double seconds = 0.0;       ///< wall time of compute()
        double cpuSeconds = 0.0;    ///< process CPU time during compute() (all threads)
        std::array<int, 3> sizes{}; ///< radii integrated per channel
        std::array<double, 3> maxSizeParameter{}; ///< largest x per channel
        /// Integral over the sphere of the tabulated phase function before the table was
        /// rescaled to 1: how well the angle grid resolves it (should be 1 within ~1e-3).
        std::array<double, 3> rawNormalisation{};
        std::array<double, 3> asymmetry{};    ///< <cos> from the Mie series (size-averaged)
        std::array<double, 3> qext{}, qsca{}; ///< size-averaged (area-weighted) efficiencies
    };
    const Stats& stats() const { return stats_; }

  private:
    void finish(); ///< normalisation, CDF, lookup tables, mean cosines

    int interval(float cosTheta) const; ///< i with cos_[i] <= cosTheta <= cos_[i + 1]

    MieTableParams params_;
    std::vector<float> cos_;
    std::array<std::vector<float>, 4> value_;
    std::vector<double> cdf_;             ///< sampling channel, at the nodes; cdf_.back() == 1
    std::vector<std::uint16_t> guide_;    ///< first interval of each cos bin (see interval())
    std::vector<std::uint16_t> cdfGuide_; ///< first interval of each u bin (see sample())
    std::array<float, 4> meanCosine_{};
    Stats stats_;
};

/// The table for these parameters, computed on first use and kept for the life of the process
/// (thread-safe; concurrent callers wait for one computation). Parameters are compared in
/// float precision, so MediumDesc's float 0.1f finds the table of MieTableParams{}.
std::shared_ptr<const MieTable> sharedMieTable(const MieTableParams& params);

} // namespace nimbus
