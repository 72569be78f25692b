/// @file params_sun.cpp
/// @brief Scene-file parameter table: the rows of [sun] (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addSunParams(std::vector<Param>& t) {
    const Section<SunDesc> sun{"sun", [](Staging& s) -> SunDesc& { return s.file.scene.sun; }};
    const Section<Staging> staged{"sun", [](Staging& s) -> Staging& { return s; }};
    auto sunOn = [](const SceneFile& f) { return f.scene.sun.enabled; };
    t.push_back(sun.param("enabled", {}, "Light the scene with the sun.", &SunDesc::enabled));
    t.push_back(sun.param("direction", {},
                          "Direction toward the sun, normalised on load. Give either `direction` "
                          "or `elevation` and `azimuth`.",
                          &SunDesc::direction)
                    .checkedBy(nonZero)
                    .usedWhen("sun.enabled = true", sunOn));
    t.push_back(staged
                    .param("elevation", closed(-90, 90),
                           "Sun elevation in degrees: 0 = horizon, 90 = zenith. Needs `azimuth`; "
                           "replaces `direction`.",
                           &Staging::sunElevation)
                    .usedWhen("sun.enabled = true", sunOn));
    t.push_back(staged
                    .param("azimuth", closed(-360, 360),
                           "Sun azimuth in degrees, measured from +z toward +x (90 = +x). Needs "
                           "`elevation`.",
                           &Staging::sunAzimuth)
                    .usedWhen("sun.enabled = true", sunOn));
    t.push_back(
        sun.rgb("irradiance", atLeast(0), "Sun irradiance, in `color_space`.", &SunDesc::irradiance)
            .usedWhen("sun.enabled = true", sunOn));
    t.push_back(sun.param("angular_diameter", closed(0, 30),
                          "Angular diameter of the sun's disc in degrees (the Sun: 0.53); 0 = a "
                          "point. `pathtrace` samples the disc, so its shadows have exact "
                          "penumbrae; `march`, the light volumes and photons use the disc's "
                          "centre (SDF solids approximate the penumbra with `softness`).",
                          &SunDesc::angularDiameter)
                    .usedWhen("sun.enabled = true", sunOn));
    t.push_back(staged
                    .param("intensity", atLeast(0), "Scalar multiplier of `irradiance`.",
                           &Staging::sunIntensity)
                    .usedWhen("sun.enabled = true", sunOn));
}

} // namespace nimbus::io::scene
