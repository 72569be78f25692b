#include "core/fields/automaton_field.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

namespace {

constexpr int kBlock = 8;

} // namespace

float AutomatonField::density(vec3 p) const {
    const AutomatonFrame& f = *frame;
    return sim::sampleDensity(f.density, (p - f.bounds.lo) * f.cellsPerUnit, sim::Boundary::Zero);
}

float AutomatonField::majorant(const Box& b) const {
    const AutomatonFrame& f = *frame;
    const ivec3 res = f.density.res;
    // index coordinates of the box; a lookup at u reads cells floor(u - 1/2) and the next
    const vec3 lo = (b.lo - f.bounds.lo) * f.cellsPerUnit - 0.5f;
    const vec3 hi = (b.hi - f.bounds.lo) * f.cellsPerUnit - 0.5f;
    ivec3 c0, c1;
    for (int a = 0; a < 3; ++a) {
        const float l = std::clamp(lo[a], -2.0f, float(res[a]) + 1.0f);
        const float h = std::clamp(hi[a], -2.0f, float(res[a]) + 1.0f);
        c0[a] = std::max(0, int(std::floor(l)) - 1);
        c1[a] = std::min(res[a] - 1, int(std::floor(h)) + 2);
        if (c0[a] > c1[a]) return 0.0f;
    }
    const ivec3 b0 = c0 / kBlock, b1 = c1 / kBlock;
    float m = 0.0f;
    for (int z = b0.z; z <= b1.z; ++z)
        for (int y = b0.y; y <= b1.y; ++y)
            for (int x = b0.x; x <= b1.x; ++x) m = std::max(m, f.maxima.at(x, y, z));
    return m > 0.0f ? m * (1.0f + 0x1p-20f) : 0.0f;
}

sim::AutomatonParams automatonParams(const AutomatonDesc& d) {
    sim::AutomatonParams p;
    p.res = d.res;
    p.seed = d.seed;
    p.dt = d.simStep;
    p.wind = vec3(0.0f); // replaced by the motion hook (sim::WindAutomaton)
    p.pHum = d.pHum;
    p.pAct = d.pAct;
    p.pExt = d.pExt;
    p.cloudDensity = d.ellipsoids;
    p.minEllipsoids = d.minEllipsoids;
    p.maxEllipsoids = d.maxEllipsoids;
    p.targetCover = d.targetCover;
    p.coverTolerance = d.coverTolerance;
    p.adaptPeriod = d.adaptPeriod;
    p.sizeMean = d.sizeMean;
    p.sizeVar = d.sizeVar;
    p.heightRatio = d.heightRatio;
    p.lifeMean = d.lifeMean;
    p.lifeVar = d.lifeVar;
    p.shrinkTime = d.shrinkTime;
    p.regionMargin = d.regionMargin;
    p.layerLo = d.layerLo;
    p.layerHi = d.layerHi;
    p.initial = d.startFull ? sim::InitialCells::Full : sim::InitialCells::Empty;
    return p;
}

sim::VelocityField automatonIndexWind(const AutomatonDesc& d) {
    if (d.wind.empty()) return sim::uniformWind(vec3(0.0f));
    const vec3 cellsPerUnit = vec3(d.res) / d.bounds.extent();
    std::vector<sim::WindLayer> rows;
    for (const AutomatonWindRow& r : d.wind)
        rows.push_back(
            sim::WindLayer{(r.altitude - d.bounds.lo.y) * cellsPerUnit.y, r.wind * cellsPerUnit});
    return sim::layeredWind(std::move(rows));
}

std::string automatonProblem(const AutomatonDesc& d) {
    const double cells = double(d.res.x) * d.res.y * d.res.z;
    if (d.res.x < 1 || d.res.y < 1 || d.res.z < 1) return "the resolution must be at least 1";
    if (cells > kMaxAutomatonCells)
        return "a resolution of " + std::to_string(d.res.x) + " x " + std::to_string(d.res.y) +
               " x " + std::to_string(d.res.z) + " needs " + std::to_string(std::int64_t(cells)) +
               " cells; the limit is " + std::to_string(std::int64_t(kMaxAutomatonCells)) +
               " (2^24)";
    const vec3 e = d.bounds.extent();
    if (!(e.x > 0.0f && e.y > 0.0f && e.z > 0.0f)) return "the bounds are empty";
    if (const char* p = sim::validate(automatonParams(d)); *p) return p;
    for (size_t i = 1; i < d.wind.size(); ++i)
        if (!(d.wind[i].altitude > d.wind[i - 1].altitude))
            return "the wind rows' altitudes must increase strictly";
    for (const AutomatonWindRow& r : d.wind)
        if (r.wind.y != 0.0f) return "the wind must be horizontal (y = 0)";
    if (const char* p = sim::WindAutomaton::windProblem(automatonIndexWind(d)); *p) return p;
    return "";
}

double automatonSimTime(const AutomatonDesc& d, float time) {
    return double(d.warmup) + double(time);
}

std::uint64_t automatonStepsFor(const AutomatonDesc& d, float time) {
    std::uint64_t n = 0;
    float s = 0.0f;
    sim::stepOf(automatonSimTime(d, time), d.simStep, n, s);
    return n + 1;
}

double automatonBytes(const AutomatonDesc& d) {
    const double cells = double(d.res.x) * d.res.y * d.res.z;
    // bits: hum, act, cld, the growth scratch, the shift scratch, the region flags (1 bit each);
    // region weights 2 bytes; floats: two smoothed steps, two advected, the frame, the
    // advection's forward grid and its lo/hi bounds (4 bytes each)
    return cells * (6.0 / 8.0 + 2.0 + 8.0 * 4.0);
}

AutomatonSequence::AutomatonSequence(const AutomatonDesc& d)
    : desc_(d), sim_(automatonParams(d), automatonIndexWind(d),
                     std::uint64_t(std::max(0, d.checkpointEvery))) {}

std::shared_ptr<const AutomatonFrame> AutomatonSequence::frameAt(float time) {
    auto f = std::make_shared<AutomatonFrame>();
    sim_.densityAt(automatonSimTime(desc_, time), f->density);
    if (desc_.density != 1.0f)
        for (float& v : f->density.v) v *= desc_.density;
    sim::blockMaxima(f->density, kBlock, 0, f->maxima);
    f->bounds = desc_.bounds;
    f->cellsPerUnit = vec3(desc_.res) / desc_.bounds.extent();
    return f;
}

AutomatonField makeAutomatonField(const AutomatonDesc& d, float time, AutomatonSequence* sequence) {
    if (sequence) return AutomatonField{sequence->frameAt(time)};
    AutomatonSequence alone(d);
    return AutomatonField{alone.frameAt(time)};
}

} // namespace nimbus
