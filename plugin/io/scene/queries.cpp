/// @file queries.cpp
/// @brief What the rest of Nimbus asks of the parameter table: the effective settings of a
///        scene (EXR metadata), the step schedule and the knobs of `nimbus calibrate`.
#include <utility>

#include "core/plan.h"
#include "core/tracking/volumes.h"
#include "plugin/io/scene/table.h"

namespace nimbus::io {

using namespace scene;

namespace {

/// Runs @p fn on a staging that holds @p s (moved in and back out, not copied).
template <class F> auto withStaging(SceneDesc& s, F fn) {
    struct Back {
        Staging st;
        SceneDesc& s;
        ~Back() { s = std::move(st.file.scene); }
    } b{{}, s};
    b.st.file.scene = std::move(s);
    return fn(b.st);
}

/// Runs @p fn(param, value) on every key of the parameter table that applies to @p f's field
/// kind and has a value there.
template <class F> void forEachSetting(const SceneFile& f, Staging& st, F fn) {
    st.file = f;
    for (const Param& p : registry()) {
        if (p.kind && *p.kind != f.scene.field.kind) continue;
        if (std::optional<Value> v = p.get(st)) fn(p, *v);
    }
}

} // namespace

std::map<std::string, std::string> sceneSettings(const SceneFile& f) {
    std::map<std::string, std::string> out;
    Staging st;
    forEachSetting(f, st, [&](const Param& p, const Value& v) { out[p.full()] = toToml(p, v); });
    for (const ArraySection& a : arraySections()) {
        size_t count = a.name == "volume"  ? f.scene.volumes.size()
                       : a.name == "mesh"  ? f.scene.meshes.size()
                       : a.name == "solid" ? f.scene.solids.size()
                                           : 0; // instances: too many after [[scatter]]
        for (size_t i = 0; i < count; ++i) {
            st.element = i;
            for (const Param& p : arrayRegistry())
                if (p.section == a.name)
                    if (std::optional<Value> v = p.get(st))
                        out[a.name + "[" + std::to_string(i) + "]." + p.key] = toToml(p, *v);
        }
    }
    return out;
}

std::set<std::string> pixelNeutralSettings(const SceneFile& f) {
    std::set<std::string> out;
    Staging st;
    forEachSetting(f, st, [&](const Param& p, const Value&) {
        if (p.pixelNeutral || (p.used && !p.used(f))) out.insert(p.full());
    });
    return out;
}

std::vector<std::string> pixelNeutralKeys() {
    std::vector<std::string> out;
    for (const Param& p : registry())
        if (p.pixelNeutral) out.push_back(p.full());
    return out;
}

std::vector<std::string> stepScheduleKeys() {
    std::vector<std::string> out;
    for (const Param& p : registry())
        if (p.stepSchedule) out.push_back(p.full());
    return out;
}

void scaleSteps(SceneDesc& s, double f) {
    // a step of 0 is the plan's: from the voxel (step_voxels, scaled below) where the scene
    // places a VDB volume, else the procedural default, made explicit here so that it scales
    bool vdb = s.field.kind == FieldKind::Vdb && isPlaced(s, 0);
    for (size_t i = 0; i < s.volumes.size(); ++i) vdb = vdb || isPlaced(s, int(i) + 1);
    if (!vdb) {
        if (s.render.step == 0.0f) s.render.step = kDefaultStep;
        if (s.render.shadowStep == 0.0f) s.render.shadowStep = kDefaultStep;
    }
    withStaging(s, [f](Staging& st) {
        for (const Param& p : registry()) {
            if (!p.stepSchedule) continue;
            Value v = *p.get(st);
            v.x *= f;
            p.set(st, v);
        }
    });
}

std::vector<CalibrationKnob> calibrationKnobs() {
    std::vector<CalibrationKnob> out;
    for (const Param& p : registry()) {
        if (p.calibrationGrid.empty()) continue;
        CalibrationKnob k;
        k.key = p.full();
        k.lo = p.range.lo;
        k.hi = p.range.hi;
        k.allowed = allowedOf(p);
        Staging defaults;
        k.defaultValue = p.get(defaults)->x;
        for (double x : p.calibrationGrid) k.values.push_back(double(float(x))); // as stored
        k.applies = [&p](const SceneDesc& s) {
            SceneFile f;
            f.scene = s;
            return !p.used || p.used(f);
        };
        k.get = [&p](const SceneDesc& s) {
            SceneDesc copy = s;
            return withStaging(copy, [&p](Staging& st) { return p.get(st)->x; });
        };
        k.set = [&p](SceneDesc& s, double x) {
            withStaging(s, [&p, x](Staging& st) {
                Value v;
                v.x = x;
                p.set(st, v);
            });
        };
        out.push_back(std::move(k));
    }
    return out;
}

} // namespace nimbus::io
