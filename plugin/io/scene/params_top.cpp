/// @file params_top.cpp
/// @brief Scene-file parameter table: the top-level keys (no section) (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addTopLevelParams(std::vector<Param>& t) {
    const Section<SceneFile> top{"", [](Staging& s) -> SceneFile& { return s.file; }};
    t.push_back(top.param("color_space", {},
                          "Colour space of the light and medium colours in this file (an OCIO "
                          "colour-space name, checked against the OCIO config by `nimbus`).",
                          &SceneFile::inputColorSpace)
                    .checkedBy(nonEmpty));
    t.push_back(top.param("frames", {},
                          "Frames to render (a frame spec, see below); `--frames` on the "
                          "command line replaces it.",
                          &SceneFile::frames)
                    .as(Type::Frames)
                    .neutralToPixels());
}

} // namespace nimbus::io::scene
