/// @file params_vdb.cpp
/// @brief Scene-file parameter table: the rows of [field] with kind = "vdb" (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addVdbParams(std::vector<Param>& t) {
    const Section<VdbFieldDesc> vd{
        "field", [](Staging& s) -> VdbFieldDesc& { return s.file.scene.field.vdb; },
        FieldKind::Vdb};
    t.push_back(vd.param("path", {},
                         "VDB file, or a per-frame pattern (`smoke.####.vdb`, `$F4`); relative "
                         "to the scene file. Required.",
                         &VdbFieldDesc::path));
    t.push_back(vd.param("grid", {}, "Name of the density grid; only this grid is read.",
                         &VdbFieldDesc::grid));
    t.push_back(vd.param("levelset_to_fog", {},
                         "Convert a level set to a fog volume instead of refusing it.",
                         &VdbFieldDesc::levelsetToFog));
    t.push_back(vd.param("hold", {},
                         "A missing frame of a sequence repeats the last existing one (with a "
                         "warning) instead of failing.",
                         &VdbFieldDesc::hold));
    t.push_back(
        vd.param("density", atLeast(0), "Multiplier of the grid values.", &VdbFieldDesc::density));
}

} // namespace nimbus::io::scene
