/// @file params_ground.cpp
/// @brief Scene-file parameter table: the rows of [ground] (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addGroundParams(std::vector<Param>& t) {
    const Section<GroundDesc> gnd{"ground",
                                  [](Staging& s) -> GroundDesc& { return s.file.scene.ground; }};
    auto groundOn = [](const SceneFile& f) { return f.scene.ground.enabled; };
    t.push_back(gnd.param("enabled", {},
                          "An opaque diffuse ground plane (Embree): stops camera rays and "
                          "receives the clouds' shadows.",
                          &GroundDesc::enabled));
    t.push_back(gnd.param("height", {}, "Height (y) of the plane.", &GroundDesc::height)
                    .usedWhen("ground.enabled = true", groundOn));
    t.push_back(gnd.param("extent", above(0),
                          "Half the side of the square plane, centred under the camera.",
                          &GroundDesc::extent)
                    .usedWhen("ground.enabled = true", groundOn));
    t.push_back(gnd.rgb("albedo", closed(0, 1), "Diffuse reflectance.", &GroundDesc::material,
                        &SurfaceMaterialDesc::albedo)
                    .usedWhen("ground.enabled = true", groundOn));
    t.push_back(gnd.param("holdout", {},
                          "A matte: hides what is behind it with alpha 0 and no colour of its "
                          "own (for compositing over a plate).",
                          &GroundDesc::material, &SurfaceMaterialDesc::holdout)
                    .usedWhen("ground.enabled = true", groundOn));
}

} // namespace nimbus::io::scene
