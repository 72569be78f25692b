/// @file params_advect.cpp
/// @brief Scene-file parameter table: [field.advect] (wind advection of a homogeneous,
///        cumulus, VDB, Gardner or SDF field, core/fields/advected_field.h) and its
///        [[field.wind_layer]] rows (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

namespace {

AdvectDesc& advect(Staging& s) {
    return s.file.scene.field.advect;
}

const WordTable<VelocityLayout> kLayouts = {{"auto", VelocityLayout::Auto},
                                            {"centred", VelocityLayout::Centred},
                                            {"staggered", VelocityLayout::Staggered}};

const WordTable<bool> kSchemes = {{"maccormack", true}, {"semi_lagrangian", false}};

constexpr FieldKind kAdvectable[] = {FieldKind::Homogeneous, FieldKind::Cumulus, FieldKind::Vdb,
                                     FieldKind::Gardner, FieldKind::Sdf};

} // namespace

void addAdvectSubParams(std::vector<Param>& t) {
    const Section<AdvectDesc> ad{"field.advect", &advect};
    t.push_back(ad.param("wind", closed(-1e6, 1e6),
                         "A uniform wind (world units per second). Leave it out for a layered "
                         "wind ([[field.wind_layer]] rows) or a velocity grid (`velocity`).",
                         &AdvectDesc::uniform));
    t.push_back(ad.param("velocity", {},
                         "VDB file (or per-frame pattern) holding a vec3 velocity grid, relative "
                         "to the scene file (Mantaflow's cache: `velocity`, staggered). Read "
                         "only when given.",
                         &AdvectDesc::velocityPath)
                    .checkedBy(nonEmpty));
    t.push_back(ad.param("velocity_grid", {}, "Name of the velocity grid in that file.",
                         &AdvectDesc::velocityGrid)
                    .checkedBy(nonEmpty));
    t.push_back(ad.param("velocity_layout", kLayouts,
                         "Where the velocity's components sit: `centred` at cell centres, "
                         "`staggered` on the cells' lower faces (MAC, Mantaflow), `auto` from "
                         "the grid's class (staggered grids say so).",
                         &AdvectDesc::layout));
    t.push_back(ad.param("velocity_scale", closed(-1e6, 1e6),
                         "Multiplies the grid's velocities (e.g. to turn a simulation's units "
                         "into world units per second).",
                         &AdvectDesc::velocityScale));
    t.push_back(ad.param("velocity_extrapolate", {},
                         "Inactive voxels inside the velocity grid's active box (OpenVDB's "
                         "background, 0: Mantaflow stores velocity only where its fluid was) "
                         "take the mean of their neighbours, layer by layer outward; false "
                         "keeps them still, which stalls a cloud's front where it enters them.",
                         &AdvectDesc::velocityExtrapolate));
    t.push_back(ad.param("voxel", above(0),
                         "Cell size of the advection grid (world units). Default: the VDB "
                         "grid's voxel, else 1/128 of the domain's longest side; enlarged "
                         "(and said by --explain) when the domain would need more than 2^24 "
                         "cells.",
                         &AdvectDesc::voxel));
    t.push_back(ad.param("bounds_min", {},
                         "Lower corner of the simulation domain (with `bounds_max`). Default: "
                         "the source's bounds grown by where the wind carries them until the "
                         "scene's last frame. Matter leaving the domain is lost.",
                         &AdvectDesc::bounds, &Box::lo));
    t.push_back(ad.param("bounds_max", {}, "Upper corner of the simulation domain.",
                         &AdvectDesc::bounds, &Box::hi));
    t.push_back(ad.param("step", closed(1e-4, 1e3),
                         "Seconds per advection step. Default: one step per frame (1 / "
                         "render.fps). Semi-Lagrangian steps are stable at any CFL number; "
                         "fewer steps diffuse less (docs/advection.md).",
                         &AdvectDesc::step));
    t.push_back(ad.param("scheme", kSchemes,
                         "`maccormack`: semi-Lagrangian with Selle et al.'s correction, clamped "
                         "to the source cells (no new extrema; sharper); `semi_lagrangian`: "
                         "the plain scheme (diffuses more, changes mass less).",
                         &AdvectDesc::maccormack));
    t.push_back(ad.param("checkpoint_every", closed(0, 1e6),
                         "Steps between states kept in memory, so that frames rendered "
                         "backwards re-simulate from the nearest (0: only time 0).",
                         &AdvectDesc::checkpointEvery));

    const Section<AutomatonWindRow> wl{"field.wind_layer", [](Staging& s) -> AutomatonWindRow& {
                                           return advect(s).layers[s.element];
                                       }};
    t.push_back(wl.param("altitude", {},
                         "World altitude (y) of this row; rows must be given in strictly "
                         "increasing altitude.",
                         &AutomatonWindRow::altitude));
    t.push_back(wl.param("wind", closed(-1e6, 1e6),
                         "Wind at this altitude (world units per second; a vertical component "
                         "is allowed). Linear between rows, so layers shear; the nearest row's "
                         "below and above the table.",
                         &AutomatonWindRow::wind));
}

void addAdvectTables(std::vector<FieldSubTable>& t) {
    for (FieldKind k : kAdvectable) {
        t.push_back({k, "advect", false,
                     "Carries the field through a wind: the field at time 0 (a VDB sequence: "
                     "each frame's grid) is sampled on a dense grid and advected, "
                     "semi-Lagrangian with a bounded MacCormack correction, to each frame's "
                     "time. The wind is `wind` (uniform), the [[field.wind_layer]] rows "
                     "(layered, shearing) or `velocity` (a VDB velocity grid). A frame "
                     "rendered alone re-simulates from time 0 and equals the same frame of a "
                     "sequence.",
                     [](Staging& s, Where w) {
                         advect(s).enabled = true;
                         s.advectWhere = w;
                     }});
        t.push_back({k, "wind_layer", true,
                     "One row of the layered wind of [field.advect]: the wind at one altitude, "
                     "linear in altitude between rows (shear).",
                     [](Staging& s, Where w) {
                         advect(s).layers.push_back(AutomatonWindRow{});
                         s.windLayerWhere.push_back(w);
                     }});
    }
}

} // namespace nimbus::io::scene
