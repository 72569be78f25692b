/// @file phase.h
/// @brief Phase functions on the host: `eval(cos)`, `sample(u) -> {cos, pdf}`, `pdf(cos)` over
///        the kernels of core/kernels/phase.glsl plus the Lorenz-Mie table of core/media/mie.h.
///
/// Convention (as in the kernels): cosTheta is the cosine between the propagation directions
/// before and after scattering, 1 = forward. eval and pdf are densities over the sphere (1/sr);
/// eval is RGB because a Mie table differs per channel (every other kind is grey). For the
/// analytic kinds pdf == eval; for the table pdf is the mean of the three channels and
/// sample() returns the weight eval / pdf per channel.
///
/// @code
///   PhaseFunction phase = PhaseFunction::fromMedium(scene.medium);
///   vec3 f = phase.eval(dot(wi, wo));
///   PhaseSample s = phase.sample(vec2(u1, u2));  // s.cosTheta, s.pdf, s.weight
///   vec3 wo = kern::phaseDirection(wi, s.cosTheta, u3);
/// @endcode
#pragma once

#include <memory>

#include "core/kernels/kernels.h"
#include "core/media/mie.h"
#include "core/scene.h"

namespace nimbus {

struct PhaseSample {
    float cosTheta = 1.0f;
    float pdf = 0.0f;  ///< density (1/sr) of the sampled direction
    vec3 weight{1.0f}; ///< eval / pdf: 1 except for the per-channel table
};

/// The kernel parameters of a medium's phase function (the table kind carries the table's mean
/// cosine as its HG stand-in, see phase.glsl; @p table may be null for the other kinds).
inline kern::PhaseParams phaseParams(const MediumDesc& m, const MieTable* table = nullptr) {
    switch (m.phase) {
    case PhaseKind::Isotropic:
        return kern::phaseParamsIsotropic();
    case PhaseKind::HenyeyGreenstein:
        return kern::phaseParamsHG(m.g);
    case PhaseKind::DualHG:
        return kern::phaseParamsDualHG(m.g, m.g2, m.blend);
    case PhaseKind::Draine:
        return kern::phaseParamsDraine(m.g, m.alpha);
    case PhaseKind::MieApprox:
        return kern::phaseParamsMieApprox(m.dropletDiameter);
    case PhaseKind::MieTable: {
        kern::PhaseParams p = kern::phaseParamsHG(table ? table->meanCosine() : 0.0f);
        p.kind = kern::PHASE_MIE_TABLE;
        return p;
    }
    }
    return kern::phaseParamsIsotropic();
}

/// A medium's phase function. Small and cheap to copy; the table is not owned (it must outlive
/// the PhaseFunction: MediumDesc::mieTable or sharedMieTable keep it).
class PhaseFunction {
  public:
    PhaseFunction() : params_(kern::phaseParamsIsotropic()) {}
    explicit PhaseFunction(const kern::PhaseParams& p) : params_(p) {}
    /// A Mie table (weight 1); @p table must not be null.
    explicit PhaseFunction(const MieTable* table) : table_(table) {
        params_ = kern::phaseParamsHG(table->meanCosine());
        params_.kind = kern::PHASE_MIE_TABLE;
    }

    /// The medium's phase function. For PhaseKind::MieTable: medium.mieTable if set, else the
    /// process-wide table for (effectiveRadius, effectiveVariance), computed on first use.
    static PhaseFunction fromMedium(const MediumDesc& m) {
        if (m.phase != PhaseKind::MieTable) return PhaseFunction(phaseParams(m));
        if (m.mieTable) return PhaseFunction(m.mieTable.get());
        MieTableParams p;
        p.effectiveRadius = m.effectiveRadius;
        p.effectiveVariance = m.effectiveVariance;
        return PhaseFunction(sharedMieTable(p).get());
    }

    vec3 eval(float cosTheta) const {
        if (table_) return tableWeight_ * table_->eval(cosTheta) + vec3(isoPart());
        return vec3(kern::phaseEval(params_, cosTheta));
    }

    float pdf(float cosTheta) const {
        if (table_) return tableWeight_ * table_->pdf(cosTheta) + isoPart();
        return kern::phasePdf(params_, cosTheta);
    }

    /// u.x drives the inverse CDF, u.y picks a lobe (two-lobe kinds, table octaves).
    PhaseSample sample(vec2 u) const {
        PhaseSample s;
        if (table_) {
            s.cosTheta = u.y < tableWeight_ ? table_->sample(u.x) : 2.0f * u.x - 1.0f;
            s.pdf = pdf(s.cosTheta);
            s.weight = s.pdf > 0.0f ? eval(s.cosTheta) / s.pdf : vec3(0.0f);
            return s;
        }
        s.cosTheta = kern::phaseSample(params_, u);
        s.pdf = kern::phasePdf(params_, s.cosTheta);
        return s;
    }

    /// The phase function of a multiple-scattering octave (Wrenninge 2015): asymmetry scaled by
    /// @p eccentricity. Analytic kinds scale g (and g2); a table is blended toward isotropic,
    /// w table + (1 - w) / 4 pi with w scaled by @p eccentricity, which scales its mean cosine
    /// by the same factor and keeps the table's features.
    PhaseFunction octave(float eccentricity) const {
        PhaseFunction f = *this;
        f.params_ = kern::phaseOctave(params_, eccentricity);
        f.tableWeight_ = tableWeight_ * eccentricity;
        return f;
    }

    /// Mean cosine <cos theta> of eval (sampling channel for the table).
    float meanCosine() const;

    const kern::PhaseParams& params() const { return params_; }
    const MieTable* table() const { return table_; }

  private:
    float isoPart() const { return (1.0f - tableWeight_) * kern::NB_INV_4PI; }

    kern::PhaseParams params_;
    const MieTable* table_ = nullptr;
    float tableWeight_ = 1.0f;
};

inline float PhaseFunction::meanCosine() const {
    if (table_) return tableWeight_ * table_->meanCosine();
    const kern::PhaseParams& p = params_;
    // Draine: <cos> = g (1 + alpha (3 + 2 g^2) / 5) / (1 + alpha (1 + 2 g^2) / 3)
    auto draine = [](float g, float a) {
        return g * (1.0f + a * (3.0f + 2.0f * g * g) / 5.0f) /
               (1.0f + a * (1.0f + 2.0f * g * g) / 3.0f);
    };
    switch (p.kind) {
    case kern::PHASE_HG:
    case kern::PHASE_MIE_TABLE:
        return p.g;
    case kern::PHASE_DUAL_HG:
        return (1.0f - p.blend) * p.g + p.blend * p.g2;
    case kern::PHASE_DRAINE:
        return draine(p.g, p.alpha);
    case kern::PHASE_MIE_APPROX:
        return (1.0f - p.blend) * p.g + p.blend * draine(p.g2, p.alpha);
    default:
        return 0.0f;
    }
}

} // namespace nimbus
