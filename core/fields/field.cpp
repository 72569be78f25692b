#include "core/fields/field.h"

#include <algorithm>

namespace nimbus {

namespace {

FieldMotion uniformMotion(vec3 wind) {
    FieldMotion m;
    m.velocity = sim::uniformWind(wind);
    m.moving = wind != vec3(0.0f);
    return m;
}

} // namespace

FieldMotion layeredMotion(const std::vector<AutomatonWindRow>& rows) {
    FieldMotion m;
    if (rows.empty()) return m;
    std::vector<sim::WindLayer> layers;
    bool moving = false;
    for (const AutomatonWindRow& r : rows) {
        layers.push_back({r.altitude, r.wind});
        moving = moving || r.wind != vec3(0.0f);
    }
    m.velocity = sim::layeredWind(std::move(layers));
    m.moving = moving;
    return m;
}

Field makeField(const FieldDesc& desc, float time, std::shared_ptr<const NoiseVolume> baseBake,
                std::shared_ptr<const NoiseVolume> detailBake) {
    return makeField(desc, time, GridBinding{}, std::move(baseBake), std::move(detailBake));
}

Field makeField(const FieldDesc& desc, float time, const GridBinding& grid,
                std::shared_ptr<const NoiseVolume> baseBake,
                std::shared_ptr<const NoiseVolume> detailBake) {
    Field f;
    f.kind = desc.kind;
    switch (desc.kind) {
    case FieldKind::Homogeneous:
        f.box = desc.homogeneous.box;
        f.data = HomogeneousField{desc.homogeneous.density};
        break;
    case FieldKind::Cumulus:
        f.box = desc.cumulus.bounds;
        f.data = CumulusField{cumulusParams(desc.cumulus, time), std::move(baseBake),
                              std::move(detailBake)};
        f.motion = uniformMotion(desc.cumulus.wind);
        break;
    case FieldKind::Vdb:
        f.box = grid.bounds;
        f.data = makeGridField(desc.vdb, grid);
        break;
    case FieldKind::Gardner: {
        GardnerField g{makeGardnerCloud(gardnerEllipsoids(desc.gardner))};
        f.box = g.cloud->bounds;
        f.data = std::move(g);
        break;
    }
    case FieldKind::Sdf:
        f.data = makeSdfCloudField(desc.sdf, f.box);
        break;
    case FieldKind::Automaton:
        f.box = desc.automaton.bounds;
        f.data = makeAutomatonField(desc.automaton, time);
        f.motion = layeredMotion(desc.automaton.wind);
        break;
    case FieldKind::Advected: // a frame's kind, made by makeAdvectedField
        return emptyField();
    }
    return f;
}

Field makeField(const FieldDesc& desc, float time, AutomatonSequence& sequence) {
    if (desc.kind != FieldKind::Automaton) return makeField(desc, time);
    Field f;
    f.kind = FieldKind::Automaton;
    f.box = desc.automaton.bounds;
    f.data = makeAutomatonField(desc.automaton, time, &sequence);
    f.motion = layeredMotion(desc.automaton.wind);
    return f;
}

Field makeAdvectedField(const AdvectDesc&, float time, AdvectedSequence& sequence,
                        const FieldMotion& wind, const std::atomic<bool>* cancel) {
    Field f;
    f.kind = FieldKind::Advected;
    auto frame = sequence.frameAt(time, cancel);
    f.box = frame->density.v.empty() ? Box{} : frame->bounds;
    f.data = AdvectedField{AutomatonField{std::move(frame)}};
    f.motion = wind;
    return f;
}

Field makeAdvectSource(const FieldDesc& desc, const GridBinding& grid) {
    FieldDesc src = desc;
    src.advect.enabled = false;
    return makeField(src, 0.0f, grid);
}

Field emptyField() {
    Field f;
    f.kind = FieldKind::Homogeneous;
    f.box = Box{};
    f.data = HomogeneousField{0.0f};
    return f;
}

float Field::density(vec3 p) const {
    if (!box.contains(p)) return 0.0f;
    switch (kind) {
    case FieldKind::Homogeneous:
        return as<HomogeneousField>().density(p);
    case FieldKind::Cumulus:
        return as<CumulusField>().density(p);
    case FieldKind::Vdb:
        return as<GridField>().density(p);
    case FieldKind::Gardner:
        return as<GardnerField>().density(p);
    case FieldKind::Sdf:
        return as<SdfCloudField>().density(p);
    case FieldKind::Automaton:
        return as<AutomatonField>().density(p);
    case FieldKind::Advected:
        return as<AdvectedField>().density(p);
    }
    return 0.0f;
}

float Field::majorant(const Box& b) const {
    const Box c = b.within(box);
    if (c.lo.x > c.hi.x || c.lo.y > c.hi.y || c.lo.z > c.hi.z) return 0.0f;
    switch (kind) {
    case FieldKind::Homogeneous:
        return as<HomogeneousField>().majorant(c);
    case FieldKind::Cumulus:
        return as<CumulusField>().majorant(c);
    case FieldKind::Vdb:
        return as<GridField>().majorant(c);
    case FieldKind::Gardner:
        return as<GardnerField>().majorant(c);
    case FieldKind::Sdf:
        return as<SdfCloudField>().majorant(c);
    case FieldKind::Automaton:
        return as<AutomatonField>().majorant(c);
    case FieldKind::Advected:
        return as<AdvectedField>().majorant(c);
    }
    return 0.0f;
}

bool Field::tightMajorant(const Box& b, float& m) const {
    if (kind != FieldKind::Vdb) return false;
    const Box c = b.within(box);
    if (c.lo.x > c.hi.x || c.lo.y > c.hi.y || c.lo.z > c.hi.z) {
        m = 0.0f;
        return true;
    }
    return as<GridField>().voxelMajorant(c, m);
}

} // namespace nimbus
