/// @file params_cumulus.cpp
/// @brief Scene-file parameter table: the rows of [field] with kind = "cumulus" (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addCumulusParams(std::vector<Param>& t) {
    const Section<CumulusDesc> cu{
        "field", [](Staging& s) -> CumulusDesc& { return s.file.scene.field.cumulus; },
        FieldKind::Cumulus};
    t.push_back(cu.param("bounds_min", {},
                         "Lower corner of the cloud layer; its y is the cloud base altitude.",
                         &CumulusDesc::bounds, &Box::lo));
    t.push_back(cu.param("bounds_max", {},
                         "Upper corner of the cloud layer; its y is the highest cloud top.",
                         &CumulusDesc::bounds, &Box::hi));
    t.push_back(
        cu.param("density", atLeast(0), "Density in the cloud cores.", &CumulusDesc::density));
    t.push_back(cu.param("coverage", closed(0, 1),
                         "Fraction of the sky covered: the noise threshold is 1 - coverage.",
                         &CumulusDesc::coverage));
    t.push_back(cu.param("softness", openClosed(0, 1),
                         "Width of the soft density ramp above the threshold (cloud edges).",
                         &CumulusDesc::softness));
    t.push_back(cu.param("erosion", closed(0, 0.99),
                         "How much the detail noise eats into the edges.", &CumulusDesc::erosion));
    t.push_back(cu.param("height_a", above(0),
                         "Rise rate a of the height distribution (1 - e^-ah) e^-bh; large = "
                         "flat cloud bases.",
                         &CumulusDesc::heightA));
    t.push_back(cu.param("height_b", above(0),
                         "Decay rate b of the height distribution; large = thin tops.",
                         &CumulusDesc::heightB));
    t.push_back(cu.param("base_period", above(0),
                         "World size of one tile of the base (shape) noise.",
                         &CumulusDesc::basePeriod));
    t.push_back(cu.param("base_lattice", closed(1, 64),
                         "Lattice cells per base tile in the lowest octave.",
                         &CumulusDesc::baseLattice));
    t.push_back(cu.param("base_octaves", closed(1, 8), "Octaves of the base noise.",
                         &CumulusDesc::baseOctaves));
    t.push_back(cu.param("detail_period", above(0),
                         "World size of one tile of the detail (erosion) noise.",
                         &CumulusDesc::detailPeriod));
    t.push_back(cu.param("detail_lattice", closed(1, 64),
                         "Lattice cells per detail tile in the lowest octave.",
                         &CumulusDesc::detailLattice));
    t.push_back(cu.param("detail_octaves", closed(1, 8), "Octaves of the detail noise.",
                         &CumulusDesc::detailOctaves));
    t.push_back(cu.param("tower_spacing", above(0),
                         "Size of the square cells that hold at most one tower each.",
                         &CumulusDesc::towerSpacing));
    t.push_back(cu.pair("tower_radius", above(0),
                        "Range of tower footprint radii (3 sigma); max <= `tower_spacing`.",
                        &CumulusDesc::towerRadiusMin, &CumulusDesc::towerRadiusMax));
    t.push_back(cu.pair("tower_height", openClosed(0, 1),
                        "Range of tower (column) heights as fractions of the layer height.",
                        &CumulusDesc::towerHeightMin, &CumulusDesc::towerHeightMax));
    t.push_back(cu.param("tower_probability", closed(0, 1), "Chance that a cell holds a tower.",
                         &CumulusDesc::towerProbability));
    t.push_back(cu.param("tower_anisotropy", closed(0, 0.9),
                         "0: round footprints; up to 0.9: elongated ones.",
                         &CumulusDesc::towerAnisotropy));
    t.push_back(cu.param("wind", {},
                         "Drift of the whole field, world units per second (t = frame / fps).",
                         &CumulusDesc::wind));
    t.push_back(cu.param("detail_wind", {},
                         "Extra drift of the detail noise, world units per second: slowly "
                         "evolving edges.",
                         &CumulusDesc::detailWind));
    t.push_back(
        cu.param("seed", kUInt32, "Seed of the noise and tower placement.", &CumulusDesc::seed));
    auto notDirect = [](const SceneFile& f) {
        return f.scene.field.cumulus.eval != NoiseEval::Direct;
    };
    t.push_back(cu.param("evaluation",
                         WordTable<NoiseEval>{{"auto", NoiseEval::Auto},
                                              {"direct", NoiseEval::Direct},
                                              {"baked", NoiseEval::Baked},
                                              {"rgba", NoiseEval::Rgba}},
                         "Noise evaluation: direct (exact, slow), baked (tiled float volumes, "
                         "fast), rgba (Olajos' layout: tiled RGBA8 volumes, several frequencies "
                         "per texel combined after interpolation; on the GPU, 3D textures "
                         "filtered by the texture unit) or auto (chosen by the plan: direct or "
                         "baked).",
                         &CumulusDesc::eval));
    t.push_back(cu.param("base_bake_resolution", closed(8, 512),
                         "Voxels per base tile edge when baked.", &CumulusDesc::baseBakeResolution)
                    .usedWhen("field.evaluation != \"direct\"", notDirect));
    t.push_back(cu.param("detail_bake_resolution", closed(8, 512),
                         "Voxels per detail tile edge when baked.",
                         &CumulusDesc::detailBakeResolution)
                    .usedWhen("field.evaluation != \"direct\"", notDirect));
}

} // namespace nimbus::io::scene
