/// @file params_sky.cpp
/// @brief Scene-file parameter table: the rows of [sky] (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addSkyParams(std::vector<Param>& t) {
    const Section<SkyDesc> sky{"sky", [](Staging& s) -> SkyDesc& { return s.file.scene.sky; }};
    auto skyOn = [](const SceneFile& f) { return f.scene.sky.kind != SkyKind::None; };
    t.push_back(sky.param("kind",
                          WordTable<SkyKind>{{"none", SkyKind::None},
                                             {"uniform", SkyKind::Uniform},
                                             {"gradient", SkyKind::Gradient}},
                          "Sky light: none (black), uniform (`zenith` in every direction) or "
                          "gradient (`zenith` overhead blending to `horizon` at the horizon).",
                          &SkyDesc::kind));
    t.push_back(sky.rgb("zenith", atLeast(0),
                        "Sky radiance straight up (uniform sky: everywhere), in `color_space`.",
                        &SkyDesc::zenith)
                    .usedWhen("sky.kind != \"none\"", skyOn));
    t.push_back(
        sky.rgb("horizon", atLeast(0), "Sky radiance at the horizon and below, in `color_space`.",
                &SkyDesc::horizon)
            .usedWhen("sky.kind = \"gradient\"",
                      [](const SceneFile& f) { return f.scene.sky.kind == SkyKind::Gradient; }));
    t.push_back(sky.param("ambient", atLeast(0), "Scale of the sky light inside the medium.",
                          &SkyDesc::ambient)
                    .calibratedOver({0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 3.0})
                    .usedWhen("sky.kind != \"none\"", skyOn)
                    .marchOnly());
}

} // namespace nimbus::io::scene
