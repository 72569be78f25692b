#include "plugin/io/scene_setup.h"

#include <algorithm>

namespace nimbus::io {

namespace {

std::string joined(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "\"" : ", \"") + x + "\"";
    return s;
}

} // namespace

std::string workingSpace(const ColorSystem& cs) {
    if (cs.hasColorSpace("ACEScg") && cs.isBuiltin()) return cs.canonicalName("ACEScg");
    return cs.sceneLinearSpace();
}

void resolveColours(SceneFile& f, const ColorSystem& cs) {
    const std::string where = f.path + ": ";
    if (!cs.hasColorSpace(f.inputColorSpace))
        throw SceneError(where + "color_space: unknown colour space \"" + f.inputColorSpace +
                         "\" in " + cs.description() + "; known: " + joined(cs.colorSpaceNames()));
    if (!cs.hasColorSpace(f.output.colorSpace))
        throw SceneError(where + "output.color_space: unknown colour space \"" +
                         f.output.colorSpace + "\" in " + cs.description() +
                         "; known: " + joined(cs.colorSpaceNames()));
    if (!f.output.preview.empty()) {
        const auto displays = cs.displays();
        if (std::find(displays.begin(), displays.end(), f.output.display) == displays.end())
            throw SceneError(where + "output.display: unknown display \"" + f.output.display +
                             "\"; known: " + joined(displays));
        const auto views = cs.views(f.output.display);
        if (std::find(views.begin(), views.end(), f.output.view) == views.end())
            throw SceneError(where + "output.view: display \"" + f.output.display +
                             "\" has no view \"" + f.output.view + "\"; known: " + joined(views));
    }
    const std::string ws = workingSpace(cs);
    if (ws.empty())
        throw SceneError(
            where + cs.description() +
            " has no scene_linear role: Nimbus renders in the config's "
            "scene-linear space; add one under `roles:` (e.g. `scene_linear: ACEScg`)");
    // every conversion a frame will make, tried now: a transform that needs a missing LUT file
    // is bad input found at load, not an I/O error after the first frame's render
    try {
        cs.convert(vec3(0.18f), f.inputColorSpace, ws);
        cs.convert(vec3(0.18f), ws, f.output.colorSpace);
    } catch (const std::exception& e) {
        throw SceneError(where + e.what());
    }
    SceneDesc& s = f.scene;
    s.sun.irradiance = cs.convert(s.sun.irradiance, f.inputColorSpace, ws);
    s.sky.zenith = cs.convert(s.sky.zenith, f.inputColorSpace, ws);
    s.sky.horizon = cs.convert(s.sky.horizon, f.inputColorSpace, ws);
    // a wide-gamut conversion can push a saturated colour slightly negative: light is >= 0
    for (vec3* c : {&s.sun.irradiance, &s.sky.zenith, &s.sky.horizon})
        *c = glm::max(*c, vec3(0.0f));
    // reflectances stay in [0, 1]: a surface never reflects more than it receives
    std::vector<vec3*> albedos{&s.ground.material.albedo};
    for (MeshDesc& m : s.meshes) albedos.push_back(&m.material.albedo);
    for (vec3* a : albedos)
        *a = glm::clamp(cs.convert(*a, f.inputColorSpace, ws), vec3(0.0f), vec3(1.0f));
}

} // namespace nimbus::io
