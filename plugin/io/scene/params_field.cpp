/// @file params_field.cpp
/// @brief Scene-file parameter table: the rows of [field]: its kind, then the keys of each kind
/// (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addFieldParams(std::vector<Param>& t) {
    const Section<FieldDesc> fld{"field",
                                 [](Staging& s) -> FieldDesc& { return s.file.scene.field; }};
    t.push_back(fld.param("kind", kFieldKinds,
                          "Density field: a procedural cumulus layer (Olajos 2016), a box of "
                          "constant density, a grid from a VDB file, a cloud of Gardner's "
                          "textured ellipsoids (Gardner 1985), a cloud sculpted from signed "
                          "distance functions (the [[field.node]] tables), or clouds grown by "
                          "Dobashi's cellular automaton and carried by a layered wind (the "
                          "[[field.wind]] tables). The other keys of [field] depend on it.",
                          &FieldDesc::kind));
}

} // namespace nimbus::io::scene
