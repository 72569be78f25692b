/// @file rules.cpp
/// @brief The rules across keys of a scene file, each with its one-line doc for the reference
///        (see reader.h).
#include <cstdio>
#include <limits>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "plugin/io/frames.h"
#include "plugin/io/scene/reader.h"

namespace nimbus::io::scene {

namespace {

/// The location of the first of @p keys that the file or an override gave.
Where locate(const Staging& s, const Context& cx, std::initializer_list<std::string_view> keys) {
    for (std::string_view k : keys) {
        auto it = s.given.find(std::string(k));
        if (it != s.given.end()) return it->second;
    }
    return {cx.sourceName + ":1:1", 0, 1, 1};
}

std::string formatVec(const vec3& v) {
    return "[" + formatFloat(v.x) + ", " + formatFloat(v.y) + ", " + formatFloat(v.z) + "]";
}

} // namespace

const std::vector<Rule>& rules() {
    static const std::vector<Rule> table = {
        {"camera", "`look_at` must differ from `position`.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const CameraDesc& c = s.file.scene.camera;
             // in double: the difference of two finite floats, and its length, may overflow one
             const glm::dvec3 d = glm::dvec3(c.lookAt) - glm::dvec3(c.position);
             const double len = glm::length(d);
             if (!(len <= double(std::numeric_limits<float>::max()))) {
                 char buf[64];
                 std::snprintf(buf, sizeof buf, "%.3g", len);
                 pr.add(locate(s, cx, {"camera.look_at", "camera.position"}),
                        "camera.look_at " + formatVec(c.lookAt) + " lies " + buf +
                            " units from camera.position " + formatVec(c.position) +
                            ", more than a float holds (3.4e+38): bring them closer together");
                 return;
             }
             const double scale = std::max(1.0, glm::length(glm::dvec3(c.position)));
             if (len > 1e-6 * scale) return;
             pr.add(locate(s, cx, {"camera.look_at", "camera.position"}),
                    "camera.look_at " + formatVec(c.lookAt) +
                        " equals camera.position: the view direction is undefined");
         }},
        {"camera", "`up` must not be parallel to the view direction `look_at - position`.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const CameraDesc& c = s.file.scene.camera;
             const glm::dvec3 d = glm::dvec3(c.lookAt) - glm::dvec3(c.position);
             const double len = glm::length(d);
             // reported above: no direction, or one past a float
             if (len == 0.0 || !(len <= double(std::numeric_limits<float>::max())) ||
                 glm::length(glm::dvec3(c.up)) == 0.0)
                 return;
             const glm::dvec3 f = d / len;
             const double sine = glm::length(glm::cross(f, glm::normalize(glm::dvec3(c.up))));
             if (sine > 1e-3) return;
             pr.add(locate(s, cx, {"camera.up", "camera.look_at", "camera.position"}),
                    "camera.up " + formatVec(c.up) + " is parallel to the view direction " +
                        formatVec(vec3(f)) +
                        " (look_at - position); choose an up vector across it");
         }},
        {"sun",
         "Give the sun's position as `direction` or as `elevation` + `azimuth` (both), not "
         "both ways.",
         [](Staging& s, const Context& cx, Problems& pr) {
             bool hasDirection = s.given.count("sun.direction") > 0;
             bool hasEl = s.sunElevation.has_value(), hasAz = s.sunAzimuth.has_value();
             if (hasDirection && (hasEl || hasAz)) {
                 pr.add(locate(s, cx, {"sun.elevation", "sun.azimuth"}),
                        std::string(hasEl ? "sun.elevation" : "sun.azimuth") +
                            ": the sun is already placed by sun.direction (" +
                            locate(s, cx, {"sun.direction"}).prefix +
                            "); give either direction or elevation + azimuth");
                 return;
             }
             if (hasEl != hasAz) {
                 pr.add(locate(s, cx, {"sun.elevation", "sun.azimuth"}),
                        hasEl ? "sun.elevation needs sun.azimuth as well (degrees from +z "
                                "toward +x)"
                              : "sun.azimuth needs sun.elevation as well (degrees above the "
                                "horizon)");
                 return;
             }
             if (!hasEl) {
                 const vec3& d = s.file.scene.sun.direction; // non-zero: checked on reading
                 double x = d.x, y = d.y, z = d.z, len = std::sqrt(x * x + y * y + z * z);
                 s.file.scene.sun.direction = vec3(float(x / len), float(y / len), float(z / len));
                 return;
             }
             const double toRad = std::numbers::pi / 180.0;
             double el = *s.sunElevation * toRad, az = *s.sunAzimuth * toRad;
             s.file.scene.sun.direction =
                 glm::normalize(vec3(float(std::cos(el) * std::sin(az)), float(std::sin(el)),
                                     float(std::cos(el) * std::cos(az))));
         }},
        {"field", "`bounds_min` must be below `bounds_max` on every axis.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const FieldDesc& f = s.file.scene.field;
             const Box& b = f.kind == FieldKind::Cumulus     ? f.cumulus.bounds
                            : f.kind == FieldKind::Automaton ? f.automaton.bounds
                                                             : f.homogeneous.box;
             const char* axes = "xyz";
             for (int a = 0; a < 3; ++a) {
                 if (b.lo[a] < b.hi[a]) continue;
                 pr.add(locate(s, cx, {"field.bounds_min", "field.bounds_max"}),
                        "field.bounds_min " + formatVec(b.lo) + " must be below field.bounds_max " +
                            formatVec(b.hi) + " on every axis; on " + axes[a] + " " +
                            formatFloat(b.lo[a]) + " >= " + formatFloat(b.hi[a]));
                 return;
             }
         }},
        {"field",
         "Cumulus: the largest `tower_radius` may not exceed `tower_spacing`: each tower lives in "
         "one cell of a `tower_spacing` grid and only the 3 x 3 neighbouring cells are searched, "
         "so a wider footprint would be cut off at the cell borders.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const CumulusDesc& c = s.file.scene.field.cumulus;
             if (s.file.scene.field.kind != FieldKind::Cumulus) return;
             if (c.towerRadiusMax <= c.towerSpacing) return;
             pr.add(locate(s, cx, {"field.tower_radius", "field.tower_spacing"}),
                    "field.tower_radius max " + formatFloat(c.towerRadiusMax) +
                        " exceeds field.tower_spacing " + formatFloat(c.towerSpacing) +
                        ": footprints may not be wider than the spacing (each tower lives in one "
                        "cell and only the neighbouring cells are searched); lower the radius or "
                        "raise the spacing");
         }},
        {"field",
         "Automaton: `min_ellipsoids` may not exceed `max_ellipsoids`, and the `[[field.wind]]` "
         "rows must be given in strictly increasing `altitude`.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const AutomatonDesc& a = s.file.scene.field.automaton;
             if (s.file.scene.field.kind != FieldKind::Automaton) return;
             if (a.minEllipsoids > a.maxEllipsoids)
                 pr.add(locate(s, cx, {"field.min_ellipsoids", "field.max_ellipsoids"}),
                        "field.min_ellipsoids " + std::to_string(a.minEllipsoids) +
                            " exceeds field.max_ellipsoids " + std::to_string(a.maxEllipsoids) +
                            "; expected min <= max");
             for (size_t i = 1; i < a.wind.size(); ++i) {
                 if (a.wind[i].altitude > a.wind[i - 1].altitude) continue;
                 const std::string label = "field.wind[" + std::to_string(i) + "]";
                 auto it = s.given.find(label + ".altitude");
                 const Where w = it != s.given.end()      ? it->second
                                 : i < s.windWhere.size() ? s.windWhere[i]
                                                          : locate(s, cx, {"field.kind"});
                 pr.add(w, label + ".altitude " + formatFloat(a.wind[i].altitude) +
                               " is not above field.wind[" + std::to_string(i - 1) + "].altitude " +
                               formatFloat(a.wind[i - 1].altitude) +
                               "; give the rows in strictly increasing altitude");
                 return;
             }
         }},
        {"field",
         "Advection: `[[field.wind_layer]]` rows need a `[field.advect]` table; the wind is "
         "one of `wind`, the `[[field.wind_layer]]` rows (strictly increasing `altitude`) or "
         "`velocity`; `bounds_min` and `bounds_max` come together, min below max.",
         [](Staging& s, const Context& cx, Problems& pr) {
             AdvectDesc& a = s.file.scene.field.advect;
             const auto given = [&](const char* k) { return s.given.count(k) > 0; };
             if (!a.enabled) {
                 if (!a.layers.empty())
                     pr.add(s.windLayerWhere[0],
                            "[[field.wind_layer]] rows carry a field through [field.advect]; add "
                            "a [field.advect] table (or remove the rows)");
                 return;
             }
             const int sources = (given("field.advect.wind") ? 1 : 0) + (a.layers.empty() ? 0 : 1) +
                                 (given("field.advect.velocity") ? 1 : 0);
             if (sources > 1) {
                 pr.add(locate(s, cx, {"field.advect.velocity", "field.advect.wind"}),
                        "[field.advect] takes one wind: `wind` (uniform), [[field.wind_layer]] "
                        "rows (layered) or `velocity` (a VDB velocity grid); this one gives " +
                            std::to_string(sources));
                 return;
             }
             a.wind = given("field.advect.velocity") ? AdvectWind::Grid
                      : !a.layers.empty()            ? AdvectWind::Layered
                                                     : AdvectWind::Uniform;
             for (size_t i = 1; i < a.layers.size(); ++i) {
                 if (a.layers[i].altitude > a.layers[i - 1].altitude) continue;
                 const std::string label = "field.wind_layer[" + std::to_string(i) + "]";
                 auto it = s.given.find(label + ".altitude");
                 pr.add(it != s.given.end() ? it->second : s.windLayerWhere[i],
                        label + ".altitude " + formatFloat(a.layers[i].altitude) +
                            " is not above field.wind_layer[" + std::to_string(i - 1) +
                            "].altitude " + formatFloat(a.layers[i - 1].altitude) +
                            "; give the rows in strictly increasing altitude");
                 return;
             }
             const bool lo = given("field.advect.bounds_min"),
                        hi = given("field.advect.bounds_max");
             if (lo != hi) {
                 pr.add(locate(s, cx, {"field.advect.bounds_min", "field.advect.bounds_max"}),
                        std::string("field.advect.") + (lo ? "bounds_min" : "bounds_max") +
                            " needs field.advect." + (lo ? "bounds_max" : "bounds_min") +
                            " too (or neither: the default domain)");
                 return;
             }
             a.hasBounds = lo;
             if (a.hasBounds)
                 for (int k = 0; k < 3; ++k) {
                     if (a.bounds.lo[k] < a.bounds.hi[k]) continue;
                     pr.add(locate(s, cx, {"field.advect.bounds_min"}),
                            "field.advect.bounds_min " + formatVec(a.bounds.lo) +
                                " must be below field.advect.bounds_max " + formatVec(a.bounds.hi) +
                                " on every axis");
                     return;
                 }
             // the default domain holds the source carried until the scene's last frame (the
             // scene file's `frames`, not --frames: every frame sees the same domain)
             try {
                 const std::vector<int> frames = parseFrameSpec(s.file.frames);
                 a.until = float(std::max(0, frames.back())) / s.file.scene.render.fps;
             } catch (const std::exception&) {
                 a.until = 0.0f; // the spec's own problem is reported by its row
             }
         }},
        {"field",
         "Gardner: the cloud needs at least one `[[field.ellipsoid]]` table or a "
         "`[field.scatter]` table.",
         [](Staging& s, const Context& cx, Problems& pr) {
             const GardnerDesc& g = s.file.scene.field.gardner;
             if (s.file.scene.field.kind != FieldKind::Gardner) return;
             if (!g.ellipsoids.empty() || g.scatter.enabled) return;
             pr.add(locate(s, cx, {"field.kind"}),
                    "field.kind = \"gardner\" needs ellipsoids: add [[field.ellipsoid]] tables "
                    "(center, radii) or a [field.scatter] table (count, size, seed, extent)");
         }},
        {"field",
         "Gardner: `t2` may not be below `t1`, in [field] and in every `[[field.ellipsoid]]` "
         "(its own values, or those of [field] where it leaves them out).",
         [](Staging& s, const Context& cx, Problems& pr) {
             const GardnerDesc& g = s.file.scene.field.gardner;
             if (s.file.scene.field.kind != FieldKind::Gardner) return;
             auto problem = [](float t1, float t2) {
                 return "t2 " + formatFloat(t2) + " is below t1 " + formatFloat(t1) +
                        "; expected t2 >= t1 (the surface threshold at least the centre's)";
             };
             const GardnerShapeDesc& d = g.defaults;
             if (d.t2 < d.t1)
                 pr.add(locate(s, cx, {"field.t2", "field.t1"}), "field: " + problem(d.t1, d.t2));
             for (size_t i = 0; i < g.ellipsoids.size(); ++i) {
                 const GardnerEllipsoidDesc& e = g.ellipsoids[i];
                 if (!e.t1 && !e.t2) continue; // both from [field]: checked above
                 const float t1 = e.t1.value_or(d.t1), t2 = e.t2.value_or(d.t2);
                 if (t2 >= t1) continue;
                 const std::string label = "field.ellipsoid[" + std::to_string(i) + "]";
                 Where w = i < s.ellipsoidWhere.size() ? s.ellipsoidWhere[i] : Where{};
                 for (const char* k : {".t2", ".t1"}) {
                     auto it = s.given.find(label + k);
                     if (it != s.given.end()) {
                         w = it->second;
                         break;
                     }
                 }
                 pr.add(w, label + ": " + problem(t1, t2) +
                               (e.t1 && e.t2 ? "" : " (the other from [field])"));
             }
         }},
        {"render",
         "With `octaves` > 1, `octave_contribution` may not exceed `octave_extinction`: each "
         "octave would then add more light than the medium can scatter (Wrenninge 2015).",
         [](Staging& s, const Context& cx, Problems& pr) {
             const RenderDesc& r = s.file.scene.render;
             if (r.octaves <= 1 || r.octaveContribution <= r.octaveExtinction) return;
             pr.add(locate(s, cx,
                           {"render.octave_contribution", "render.octave_extinction",
                            "render.octaves"}),
                    "render.octave_contribution " + formatFloat(r.octaveContribution) +
                        " exceeds render.octave_extinction " + formatFloat(r.octaveExtinction) +
                        ": the octaves would not conserve energy; expected contribution <= "
                        "extinction");
         }},
        {"output",
         "When `frames` names more than one frame, `output.path` (and `output.preview`, if set) "
         "must contain a frame token, or every frame would overwrite the same file.",
         [](Staging& s, const Context& cx, Problems& pr) {
             size_t count = parseFrameSpec(s.file.frames).size();
             if (count <= 1) return;
             const OutputDesc& o = s.file.output;
             std::string frames =
                 "frames " + quote(s.file.frames) + " names " + std::to_string(count) + " frames";
             if (!patternHasFrameToken(o.path))
                 pr.add(locate(s, cx, {"output.path", "frames"}),
                        "output.path " + quote(o.path) + " has no frame token (#### or $F4) but " +
                            frames);
             if (!o.preview.empty() && !patternHasFrameToken(o.preview))
                 pr.add(locate(s, cx, {"output.preview", "frames"}),
                        "output.preview " + quote(o.preview) +
                            " has no frame token (#### or $F4) but " + frames);
         }},
    };
    return table;
}

} // namespace nimbus::io::scene
