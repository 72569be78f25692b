/// @file params_homogeneous.cpp
/// @brief Scene-file parameter table: the rows of [field] with kind = "homogeneous" (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addHomogeneousParams(std::vector<Param>& t) {
    const Section<HomogeneousDesc> ho{
        "field", [](Staging& s) -> HomogeneousDesc& { return s.file.scene.field.homogeneous; },
        FieldKind::Homogeneous};
    t.push_back(
        ho.param("bounds_min", {}, "Lower corner of the box.", &HomogeneousDesc::box, &Box::lo));
    t.push_back(
        ho.param("bounds_max", {}, "Upper corner of the box.", &HomogeneousDesc::box, &Box::hi));
    t.push_back(
        ho.param("density", atLeast(0), "Density inside the box.", &HomogeneousDesc::density));
}

} // namespace nimbus::io::scene
