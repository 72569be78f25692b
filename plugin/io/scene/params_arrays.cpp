/// @file params_arrays.cpp
/// @brief Scene-file parameter table: the arrays of tables [[volume]], [[instance]],
///        [[scatter]] and [[mesh]] (see table.h). Their rows reach element Staging::element.
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

const std::vector<ArraySection>& arraySections() {
    static const std::vector<ArraySection> table = {
        {"volume",
         "A further VDB volume beside `[field]`, referred to by its `name` from `[[instance]]` "
         "and `[[scatter]]` (the `[field]` volume is called \"field\"). Without any "
         "`[[instance]]` or `[[scatter]]`, `[field]` and every `[[volume]]` are placed once, "
         "untransformed. Only grids of volumes that are placed are read.",
         [](Staging& s, Where w) {
             NamedVolumeDesc v;
             v.field.kind = FieldKind::Vdb;
             s.file.scene.volumes.push_back(v);
             s.volumeWhere.push_back(w);
         }},
        {"instance",
         "One placement of a volume: world = translate + R (scale * p), R = Rz Ry Rx. Where "
         "instances overlap their densities add.",
         [](Staging& s, Where w) {
             s.file.scene.instances.push_back(InstanceDesc{});
             s.instanceVolumes.push_back({"field", w});
         }},
        {"scatter",
         "`count` instances of a volume at random positions in a box (a cloudscape), with "
         "random uniform scale, rotation about y and density in the given ranges; "
         "deterministic per `seed`.",
         [](Staging& s, Where w) {
             Staging::Scatter sc;
             sc.where = w;
             s.scatters.push_back(sc);
         }},
        {"mesh",
         "A triangle mesh from an OBJ file (Embree): opaque, diffuse, two-sided; stops camera "
         "rays, casts and receives shadows.",
         [](Staging& s, Where w) {
             s.file.scene.meshes.push_back(MeshDesc{});
             s.meshWhere.push_back(w);
         }},
        {"solid",
         "An opaque solid bounded by a tree of signed distance functions (its `[[solid.node]]` "
         "tables, as `[[field.node]]`): sphere traced (no Embree), Lambertian, with soft sun "
         "shadows (penumbra estimate k h / t), ambient occlusion from the distance field (march) "
         "and the clouds' shadows; it shadows the clouds.",
         [](Staging& s, Where w) {
             s.file.scene.solids.push_back(SolidDesc{});
             s.solidWhere.push_back(w);
         }},
    };
    return table;
}

const std::vector<Param>& arrayRegistry() {
    static const std::vector<Param> table = [] {
        const Section<NamedVolumeDesc> vol{"volume", [](Staging& s) -> NamedVolumeDesc& {
                                               return s.file.scene.volumes[s.element];
                                           }};
        const Section<Staging::Placement> insVol{"instance", [](Staging& s) -> Staging::Placement& {
                                                     return s.instanceVolumes[s.element];
                                                 }};
        const Section<InstanceDesc> ins{"instance", [](Staging& s) -> InstanceDesc& {
                                            return s.file.scene.instances[s.element];
                                        }};
        const Section<Staging::Scatter> sct{
            "scatter", [](Staging& s) -> Staging::Scatter& { return s.scatters[s.element]; }};
        const Section<MeshDesc> msh{
            "mesh", [](Staging& s) -> MeshDesc& { return s.file.scene.meshes[s.element]; }};
        std::vector<Param> t;
        t.push_back(vol.param("name", {},
                              "Name the instances use. Required, unique, not \"field\".",
                              &NamedVolumeDesc::name)
                        .checkedBy(nonEmpty));
        t.push_back(
            vol.param("path", {},
                      "VDB file, or a per-frame pattern (`smoke.####.vdb`, `$F4`); relative "
                      "to the scene file. Required.",
                      &NamedVolumeDesc::field, &FieldDesc::vdb, &VdbFieldDesc::path)
                .checkedBy(nonEmpty));
        t.push_back(vol.param("grid", {}, "Name of the density grid; only this grid is read.",
                              &NamedVolumeDesc::field, &FieldDesc::vdb, &VdbFieldDesc::grid)
                        .checkedBy(nonEmpty));
        t.push_back(vol.param(
            "levelset_to_fog", {}, "Convert a level set to a fog volume instead of refusing it.",
            &NamedVolumeDesc::field, &FieldDesc::vdb, &VdbFieldDesc::levelsetToFog));
        t.push_back(vol.param("hold", {}, "A missing frame repeats the last existing one.",
                              &NamedVolumeDesc::field, &FieldDesc::vdb, &VdbFieldDesc::hold));
        t.push_back(vol.param("density", atLeast(0), "Multiplier of the grid values.",
                              &NamedVolumeDesc::field, &FieldDesc::vdb, &VdbFieldDesc::density));

        t.push_back(insVol
                        .param("volume", {}, "The volume placed: \"field\" or a `[[volume]]` name.",
                               &Staging::Placement::volume)
                        .checkedBy(nonEmpty));
        t.push_back(
            ins.param("translate", {}, "Translation (world units).", &InstanceDesc::translate));
        t.push_back(ins.param("rotate", {}, "Rotation in degrees about x, then y, then z.",
                              &InstanceDesc::rotate));
        t.push_back(ins.param("scale", above(0), "Scale along x, y and z.", &InstanceDesc::scale));
        t.push_back(ins.param("density", atLeast(0), "Multiplier of the volume's density.",
                              &InstanceDesc::density));

        t.push_back(sct.param("volume", {}, "The volume placed: \"field\" or a `[[volume]]` name.",
                              &Staging::Scatter::volume)
                        .checkedBy(nonEmpty));
        t.push_back(sct.param("count", closed(1, 1000000), "Number of instances.",
                              &Staging::Scatter::count));
        t.push_back(
            sct.param("seed", kUInt32, "Random seed of the placement.", &Staging::Scatter::seed));
        t.push_back(sct.param("region_min", {},
                              "Lower corner of the box the instance origins are drawn from.",
                              &Staging::Scatter::regionMin));
        t.push_back(
            sct.param("region_max", {}, "Upper corner of that box.", &Staging::Scatter::regionMax));
        t.push_back(sct.pair("scale", above(0), "Uniform scale range.", &Staging::Scatter::scaleMin,
                             &Staging::Scatter::scaleMax));
        t.push_back(sct.pair("rotate_y", {}, "Rotation about y range, degrees.",
                             &Staging::Scatter::yawMin, &Staging::Scatter::yawMax));
        t.push_back(sct.pair("density", atLeast(0), "Density multiplier range.",
                             &Staging::Scatter::densityMin, &Staging::Scatter::densityMax));

        t.push_back(msh.param("path", {}, "OBJ file, relative to the scene file. Required.",
                              &MeshDesc::path)
                        .checkedBy(nonEmpty));
        t.push_back(msh.param("translate", {}, "Translation (world units).", &MeshDesc::translate));
        t.push_back(msh.param("rotate", {}, "Rotation in degrees about x, then y, then z.",
                              &MeshDesc::rotate));
        t.push_back(msh.param("scale", above(0), "Scale along x, y and z.", &MeshDesc::scale));
        t.push_back(msh.rgb("albedo", closed(0, 1), "Diffuse reflectance.", &MeshDesc::material,
                            &SurfaceMaterialDesc::albedo));
        t.push_back(
            msh.param("holdout", {},
                      "A matte: hides what is behind it with alpha 0 and no colour of its own.",
                      &MeshDesc::material, &SurfaceMaterialDesc::holdout));

        const Section<SolidShading> sol{"solid", [](Staging& s) -> SolidShading& {
                                            return s.file.scene.solids[s.element].shading;
                                        }};
        static const WordTable<Penumbra> kPenumbras = {{"classic", Penumbra::Classic},
                                                       {"improved", Penumbra::Improved}};
        t.push_back(sol.rgb("albedo", closed(0, 1), "Diffuse reflectance.", &SolidShading::albedo));
        t.push_back(sol.param("softness", atLeast(0),
                              "k of the soft-shadow estimate min k h / t over the shadow ray "
                              "(h: distance to the solid at ray parameter t): larger is sharper; "
                              "about 1 / sin(sun's angular radius) for a physical sun; 0: hard "
                              "shadows (docs/sdf_solids.md).",
                              &SolidShading::softness));
        t.push_back(sol.param("penumbra", kPenumbras,
                              "\"classic\": k h / t; \"improved\": Quilez's estimate of the "
                              "closest approach between two samples (fewer bands at sharp "
                              "edges).",
                              &SolidShading::penumbra));
        t.push_back(sol.param("ao_samples", closed(0, 32),
                              "Samples of the ambient occlusion along the normal; 0: none.",
                              &SolidShading::aoSamples));
        t.push_back(sol.param("ao_step", above(0),
                              "Spacing of the AO samples (world units): sample i at (i + 1) "
                              "ao_step, AO = 1 - sum 2^-(i+1) / ao_step * (delta_i - d).",
                              &SolidShading::aoStep));
        t.push_back(sol.param("ao_strength", atLeast(0), "Multiplier of the occlusion sum.",
                              &SolidShading::aoStrength));
        t.push_back(sol.param("step_scale", closed(0.05, 1),
                              "Sphere-tracing step as a fraction of the distance where the "
                              "provably safe step is smaller (inside a noise displacement's "
                              "amplitude); lower it if a strongly displaced solid shows holes.",
                              &SolidShading::stepScale));
        t.push_back(sol.param("max_distance", above(0),
                              "Camera and shadow rays look for the solid up to this far.",
                              &SolidShading::maxDistance));
        t.push_back(sol.param("max_steps", closed(1, 100000),
                              "Sphere-tracing steps per ray before it counts as a miss.",
                              &SolidShading::maxSteps));
        return t;
    }();
    return table;
}

} // namespace nimbus::io::scene
