/// @file params_medium.cpp
/// @brief Scene-file parameter table: the rows of [medium] (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addMediumParams(std::vector<Param>& t) {
    const Section<MediumDesc> med{"medium",
                                  [](Staging& s) -> MediumDesc& { return s.file.scene.medium; }};
    t.push_back(med.rgb("sigma_s", atLeast(0),
                        "Scattering coefficient per unit density (1/world unit).",
                        &MediumDesc::sigma_s));
    t.push_back(med.rgb("sigma_a", atLeast(0),
                        "Absorption coefficient per unit density (1/world unit).",
                        &MediumDesc::sigma_a));
    t.push_back(med.param("density_scale", atLeast(0), "Multiplies the field's density.",
                          &MediumDesc::densityScale));
    t.push_back(med.param("phase",
                          WordTable<PhaseKind>{{"isotropic", PhaseKind::Isotropic},
                                               {"hg", PhaseKind::HenyeyGreenstein},
                                               {"dual_hg", PhaseKind::DualHG},
                                               {"draine", PhaseKind::Draine},
                                               {"mie_approx", PhaseKind::MieApprox},
                                               {"mie_table", PhaseKind::MieTable}},
                          "Phase function: isotropic; hg (Henyey-Greenstein, `g`); dual_hg (two "
                          "HG lobes `g`, `g2` mixed by `blend`); draine (Draine 2003, `g`, "
                          "`alpha`); mie_approx (Jendersie & d'Eon 2023: HG + Draine fitted to "
                          "Lorenz-Mie by `droplet_diameter`); mie_table (a Lorenz-Mie table that "
                          "Nimbus computes for water droplets with `effective_radius` and "
                          "`effective_variance`, per RGB channel: fog bow and glory included).",
                          &MediumDesc::phase));
    auto phaseIs = [](std::initializer_list<PhaseKind> kinds) {
        return [kinds = std::vector<PhaseKind>(kinds)](const SceneFile& f) {
            return std::find(kinds.begin(), kinds.end(), f.scene.medium.phase) != kinds.end();
        };
    };
    t.push_back(med.param("g", open(-1, 1),
                          "Asymmetry: > 0 scatters forward, < 0 backward. The g of hg and draine; "
                          "the first lobe of dual_hg.",
                          &MediumDesc::g)
                    .usedWhen("medium.phase = \"hg\", \"dual_hg\" or \"draine\"",
                              phaseIs({PhaseKind::HenyeyGreenstein, PhaseKind::DualHG,
                                       PhaseKind::Draine})));
    t.push_back(med.param("g2", open(-1, 1),
                          "Asymmetry of the second dual_hg lobe (typically < 0: back "
                          "scattering).",
                          &MediumDesc::g2)
                    .usedWhen("medium.phase = \"dual_hg\"", phaseIs({PhaseKind::DualHG})));
    t.push_back(med.param("blend", closed(0, 1),
                          "Weight of the second dual_hg lobe: (1 - blend) HG(g) + blend HG(g2).",
                          &MediumDesc::blend)
                    .usedWhen("medium.phase = \"dual_hg\"", phaseIs({PhaseKind::DualHG})));
    t.push_back(med.param("alpha", closed(0, 1000),
                          "Draine's alpha: 0 is Henyey-Greenstein; with g = 0, alpha = 1 is "
                          "Rayleigh scattering.",
                          &MediumDesc::alpha)
                    .usedWhen("medium.phase = \"draine\"", phaseIs({PhaseKind::Draine})));
    t.push_back(med.param("droplet_diameter", closed(5, 50),
                          "Droplet diameter in micrometres for mie_approx; the fit of Jendersie "
                          "& d'Eon holds from 5 to 50 (cumulus ~ 10-20, fog ~ 10-40).",
                          &MediumDesc::dropletDiameter)
                    .usedWhen("medium.phase = \"mie_approx\"", phaseIs({PhaseKind::MieApprox})));
    t.push_back(med.param("effective_radius", closed(1, 20),
                          "Effective droplet radius in micrometres for mie_table (Hansen 1971 "
                          "gamma size distribution; cumulus ~ 6-12). The table is computed once "
                          "per process: ~1.3 s on 2 cores at the defaults, ~5 s at radius 20 "
                          "and variance 0.25.",
                          &MediumDesc::effectiveRadius)
                    .usedWhen("medium.phase = \"mie_table\"", phaseIs({PhaseKind::MieTable})));
    t.push_back(med.param("effective_variance", closed(0.01, 0.25),
                          "Effective variance of the droplet radii for mie_table (~0.1 in "
                          "cumulus; small values sharpen the bow and its supernumeraries).",
                          &MediumDesc::effectiveVariance)
                    .usedWhen("medium.phase = \"mie_table\"", phaseIs({PhaseKind::MieTable})));
}

} // namespace nimbus::io::scene
