#include "core/fields/advected_field.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/cancel.h"
#include "core/fields/field.h"
#include "core/sim/automaton_wind.h"

namespace nimbus {

namespace {

constexpr int kBlock = 8;

std::string num(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

/// Per axis, the smallest and largest component the wind takes anywhere (a grid: +-max |v|).
void windRange(const sim::VelocityField& w, vec3& lo, vec3& hi) {
    lo = hi = vec3(0.0f);
    switch (w.kind) {
    case sim::VelocityKind::Uniform:
        lo = glm::min(lo, w.uniform);
        hi = glm::max(hi, w.uniform);
        break;
    case sim::VelocityKind::Layered:
        for (const sim::WindLayer& l : w.layers) {
            lo = glm::min(lo, l.wind);
            hi = glm::max(hi, l.wind);
        }
        break;
    case sim::VelocityKind::Centred:
    case sim::VelocityKind::Staggered:
        if (w.grid)
            for (const vec3& v : w.grid->v) {
                lo = glm::min(lo, -glm::abs(v));
                hi = glm::max(hi, glm::abs(v));
            }
        break;
    }
}

} // namespace

float advectStep(const AdvectDesc& d, float fps) {
    return d.step > 0.0f ? d.step : 1.0f / fps;
}

std::uint64_t advectStepsFor(const AdvectDesc& d, float fps, float time) {
    std::uint64_t n = 0;
    float s = 0.0f;
    sim::stepOf(double(time), advectStep(d, fps), n, s);
    return n;
}

AdvectDomain advectDomain(const AdvectDesc& d, const Box& source, float sourceVoxel,
                          const sim::VelocityField& wind) {
    AdvectDomain dom;
    Box b = d.bounds;
    if (!d.hasBounds) {
        if (source.empty()) {
            dom.bounds = Box{};
            return dom; // nothing to carry: an empty field
        }
        vec3 lo, hi;
        windRange(wind, lo, hi);
        const float T = std::max(0.0f, d.until);
        b = Box{source.lo + glm::min(vec3(0.0f), lo * T), source.hi + glm::max(vec3(0.0f), hi * T)};
    }
    const vec3 e = b.extent();
    if (!(e.x > 0.0f && e.y > 0.0f && e.z > 0.0f) || !std::isfinite(e.x + e.y + e.z)) {
        dom.problem = "the simulation domain (field.advect.bounds_min/max) is empty or not finite";
        return dom;
    }
    const float longest = std::max({e.x, e.y, e.z});
    float h = d.voxel > 0.0f       ? d.voxel
              : sourceVoxel > 0.0f ? sourceVoxel
                                   : longest / float(kDefaultAdvectCells);
    auto cellsAt = [&](float hh) {
        const glm::dvec3 n = glm::ceil(glm::dvec3(e) / double(hh) - 1e-6);
        return glm::max(n, glm::dvec3(1.0));
    };
    glm::dvec3 n = cellsAt(h);
    double cells = n.x * n.y * n.z;
    if (cells > kMaxAdvectCells) {
        if (d.voxel > 0.0f) {
            dom.problem = "field.advect.voxel = " + num(d.voxel) + " over a domain of " + num(e.x) +
                          " x " + num(e.y) + " x " + num(e.z) + " needs " + num(cells) +
                          " cells; the limit is 16777216 (2^24): use a voxel of " + "at least " +
                          num(std::cbrt(double(e.x) * e.y * e.z / kMaxAdvectCells)) +
                          " or smaller bounds";
            return dom;
        }
        for (int i = 0; i < 64 && cells > kMaxAdvectCells; ++i) {
            h *= float(std::cbrt(cells / kMaxAdvectCells)) * 1.0001f;
            n = cellsAt(h);
            cells = n.x * n.y * n.z;
        }
        dom.coarsened = true;
    }
    dom.res = ivec3(n);
    dom.frame = sim::GridFrame{b.lo, h};
    dom.bounds = Box{b.lo, b.lo + vec3(dom.res) * h};
    return dom;
}

FieldMotion advectWind(const AdvectDesc& d, std::shared_ptr<const sim::VelocityGrid> grid,
                       bool staggered, std::string* problem) {
    FieldMotion m;
    switch (d.wind) {
    case AdvectWind::Uniform:
        m.velocity = sim::uniformWind(d.uniform);
        m.moving = d.uniform != vec3(0.0f);
        break;
    case AdvectWind::Layered: {
        std::vector<sim::WindLayer> rows;
        for (const AutomatonWindRow& r : d.layers) {
            rows.push_back({r.altitude, r.wind});
            m.moving = m.moving || r.wind != vec3(0.0f);
        }
        m.velocity = sim::layeredWind(std::move(rows));
        break;
    }
    case AdvectWind::Grid:
        if (!grid) {
            if (problem)
                *problem = "field.advect.velocity = \"" + d.velocityPath +
                           "\": no velocity grid was loaded for this frame";
            return FieldMotion{};
        }
        m.velocity = staggered ? sim::staggeredGrid(*grid, false) : sim::centredGrid(*grid);
        m.grid = std::move(grid);
        m.moving = true;
        break;
    }
    if (const char* p = sim::validate(m.velocity); *p) {
        if (problem) *problem = std::string("field.advect: ") + p;
        return FieldMotion{};
    }
    if (problem) problem->clear();
    return m;
}

sim::AdvectParams advectParams(const AdvectDesc& d) {
    sim::AdvectParams p;
    p.scheme = d.maccormack ? sim::AdvectScheme::MacCormack : sim::AdvectScheme::SemiLagrangian;
    return p;
}

namespace {

double gridBytes(ivec3 r) {
    return r.x < 1 || r.y < 1 || r.z < 1 ? 0.0 : double(r.x) * r.y * r.z * sizeof(float);
}

/// A velocity grid (vec3 per voxel) and, staggered, the planes advect()'s blocks read.
double velocityBytes(const sim::VelocityField& wind) {
    if (!wind.grid) return 0.0;
    const double voxels = double(wind.grid->res.x) * wind.grid->res.y * wind.grid->res.z;
    return voxels * sizeof(vec3) * (wind.kind == sim::VelocityKind::Staggered ? 2.0 : 1.0);
}

} // namespace

AdvectMemory advectMemory(const AdvectDomain& dom, const AdvectDesc& d, float fps, float time,
                          const sim::VelocityField& wind) {
    AdvectMemory m;
    const ivec3 r = dom.res;
    const double grid = gridBytes(r);
    if (grid == 0.0) return m;
    const float dt = advectStep(d, fps);
    std::uint64_t n = 0;
    float s = 0.0f;
    if (time >= 0.0f) sim::stepOf(double(time), dt, n, s);
    const bool partial = time < 0.0f || s > 0.0f;
    m.state = grid;
    m.checkpointCount = 1 + (d.checkpointEvery > 0 ? n / std::uint64_t(d.checkpointEvery) : 0);
    m.checkpoints = grid * double(m.checkpointCount);
    m.frame = grid + gridBytes(sim::blockMaximaRes(r, kBlock));
    // full steps go from the state to the state (through AdvectWorkspace::tmp); the partial
    // step writes the frame
    if (n > 0 || partial) m.step = sim::stepMemory(r, wind, advectParams(d), n > 0);
    m.velocity = velocityBytes(wind);
    return m;
}

AdvectMemory AdvectedSequence::memory() const {
    auto bytes = [](const auto& v) { return double(v.capacity()) * sizeof(v[0]); };
    AdvectMemory m;
    m.state = bytes(state_.v);
    for (const auto& [step, g] : checkpoints_) m.checkpoints += bytes(g.v);
    m.checkpointCount = checkpoints_.size();
    m.step.grids = bytes(ws_.fwd.v) + bytes(ws_.tmp.v) + bytes(ws_.lo) + bytes(ws_.hi);
    m.step.rows = bytes(ws_.rowReach) + bytes(ws_.rowMassIn) + bytes(ws_.rowMassOut) +
                  bytes(ws_.rowClampMass) + bytes(ws_.rowCfl) + bytes(ws_.rowClamped) +
                  bytes(ws_.rowSubsteps);
    m.step.ring = m.step.ringMost = bytes(ws_.ring);
    if (windGrid_) m.velocity = bytes(windGrid_->v);
    if (wind_.planes) m.velocity += bytes(*wind_.planes);
    return m;
}

sim::DensityGrid sampleSource(const AdvectDomain& domain, const Field& source) {
    sim::DensityGrid g;
    const ivec3 r = domain.res;
    if (r.x < 1 || r.y < 1 || r.z < 1) return g;
    g.res = r;
    g.v.assign(size_t(r.x) * size_t(r.y) * size_t(r.z), 0.0f);
    const float h = domain.frame.voxelSize;
    const vec3 o = domain.frame.origin;
    tbb::parallel_for(tbb::blocked_range<int>(0, r.z), [&](const tbb::blocked_range<int>& zs) {
        for (int z = zs.begin(); z != zs.end(); ++z)
            for (int y = 0; y < r.y; ++y)
                for (int x = 0; x < r.x; ++x)
                    g.v[(size_t(z) * r.y + y) * r.x + x] =
                        source.density(o + (vec3(x, y, z) + 0.5f) * h);
    });
    return g;
}

bool AdvectedSequence::sameSource(const Field& source, const FieldMotion& wind) const {
    if (wind.velocity.kind != wind_.kind || wind.velocity.uniform != wind_.uniform) return false;
    if (bool(wind.grid) != bool(windGrid_)) return false;
    if (wind.grid && (wind.grid->res != windGrid_->res || wind.grid->v != windGrid_->v ||
                      wind.grid->frame.origin != windGrid_->frame.origin ||
                      wind.grid->frame.voxelSize != windGrid_->frame.voxelSize))
        return false;
    const auto it = checkpoints_.find(0);
    const sim::DensityGrid g = sampleSource(domain_, source);
    return it == checkpoints_.end() ? g.v.empty() : g.v == it->second.v;
}

AdvectedSequence::AdvectedSequence(const AdvectDesc& d, float fps, const AdvectDomain& domain,
                                   const Field& source, const FieldMotion& wind)
    : desc_(d), domain_(domain), wind_(sim::withPlanes(wind.velocity)), windGrid_(wind.grid),
      dt_(advectStep(d, fps)) {
    params_ = advectParams(d);
    sim::DensityGrid g = sampleSource(domain, source);
    if (g.v.empty()) return;
    sourceMax_ = g.v.empty() ? 0.0f : *std::max_element(g.v.begin(), g.v.end());
    state_ = g;
    checkpoints_.emplace(0, std::move(g));
}

void AdvectedSequence::advanceTo(std::uint64_t n, const std::atomic<bool>* cancel) {
    if (n < n_) {
        auto it = checkpoints_.upper_bound(n);
        --it; // step 0 is always kept
        state_ = it->second;
        n_ = it->first;
    }
    const std::uint64_t every = std::uint64_t(std::max(0, desc_.checkpointEvery));
    while (n_ < n) {
        if (cancelRequested(cancel)) return;
        last_ = sim::advect(state_, domain_.frame, wind_, dt_, params_, state_, ws_);
        ++n_;
        ++stepsComputed_;
        if (every > 0 && n_ % every == 0) checkpoints_.emplace(n_, state_);
    }
}

std::shared_ptr<const AutomatonFrame> AdvectedSequence::frameAt(float time,
                                                                const std::atomic<bool>* cancel) {
    auto f = std::make_shared<AutomatonFrame>();
    f->bounds = domain_.bounds;
    f->cellsPerUnit = vec3(1.0f / domain_.frame.voxelSize);
    if (state_.v.empty()) return f; // an empty source: nothing to carry
    if (time < 0.0f) {
        // before the source's time: one step back from step 0
        last_ =
            sim::advect(checkpoints_.at(0), domain_.frame, wind_, time, params_, f->density, ws_);
        ++stepsComputed_;
    } else {
        std::uint64_t n = 0;
        float s = 0.0f;
        sim::stepOf(double(time), dt_, n, s);
        advanceTo(n, cancel);
        if (s > 0.0f && n_ == n) {
            last_ = sim::advect(state_, domain_.frame, wind_, s * dt_, params_, f->density, ws_);
            ++stepsComputed_;
        } else {
            f->density = state_;
        }
    }
    // residue: MacCormack's correction leaves values far below anything visible around the
    // cloud (and its limiter lets them spread); they filled the majorant grid and made the
    // diffusion grid's system stiff, so they are cut (docs/advection.md)
    const float floor = kAdvectResidue * sourceMax_;
    std::uint64_t cut = 0;
    for (float& v : f->density.v)
        if (v < floor && v != 0.0f) {
            v = 0.0f;
            ++cut;
        }
    residueCells_ = cut;
    sim::blockMaxima(f->density, kBlock, 0, f->maxima);
    return f;
}

} // namespace nimbus
