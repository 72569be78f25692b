#include "core/sim/automaton_wind.h"

#include <algorithm>
#include <cmath>

namespace nimbus::sim {

namespace {

/// 64 bits of a row starting at bit `sb` (bits outside [0, 64 words) read as 0).
std::uint64_t extract64(const std::uint64_t* in, int words, long long sb) {
    const long long q = sb >= 0 ? sb / 64 : -((-sb + 63) / 64);
    const int r = int(sb - q * 64);
    const std::uint64_t lo = q >= 0 && q < words ? in[q] : 0;
    const std::uint64_t hi = q + 1 >= 0 && q + 1 < words ? in[q + 1] : 0;
    return r == 0 ? lo : (lo >> r) | (hi << (64 - r));
}

std::int64_t floorCells(double x) {
    return std::int64_t(std::floor(x));
}

} // namespace

void stepOf(double t, float dt, std::uint64_t& n, float& s) {
    const double u = std::max(0.0, t) / double(dt);
    const double k = std::floor(u * (1.0 + 1e-6));
    n = std::uint64_t(k);
    s = float(std::clamp(u - k, 0.0, 1.0));
    if (s >= 1.0f) s = std::nextafter(1.0f, 0.0f);
}

void shiftRows(CellBits& b, const std::vector<glm::ivec2>& d, std::vector<std::uint64_t>& scratch) {
    const int W = b.wordsPerRow, ny = b.res.y, nz = b.res.z;
    bool any = false;
    for (int y = 0; y < ny; ++y) any = any || d[size_t(y)] != glm::ivec2(0);
    if (!any) return;
    const std::uint64_t lastMask = b.validMask(W - 1);
    for (std::vector<std::uint64_t>* f : {&b.hum, &b.act, &b.cld}) {
        scratch = *f;
        for (int z = 0; z < nz; ++z)
            for (int y = 0; y < ny; ++y) {
                const glm::ivec2 s = d[size_t(y)];
                std::uint64_t* out = &(*f)[b.rowWord(y, z)];
                const int zs = z - s.y;
                if (zs < 0 || zs >= nz) {
                    for (int w = 0; w < W; ++w) out[w] = 0;
                    continue;
                }
                const std::uint64_t* in = &scratch[b.rowWord(y, zs)];
                for (int w = 0; w < W; ++w) out[w] = extract64(in, W, 64LL * w - s.x);
                out[W - 1] &= lastMask;
            }
    }
}

const char* WindAutomaton::windProblem(const VelocityField& wind) {
    if (wind.kind != VelocityKind::Uniform && wind.kind != VelocityKind::Layered)
        return "the automaton's wind must be uniform or layered";
    if (const char* e = validate(wind); *e) return e;
    if (wind.kind == VelocityKind::Uniform && wind.uniform.y != 0.0f)
        return "the automaton's wind must be horizontal (y = 0)";
    for (const WindLayer& l : wind.layers)
        if (l.wind.y != 0.0f) return "the automaton's wind must be horizontal (y = 0)";
    return "";
}

WindAutomaton::WindAutomaton(const AutomatonParams& p, const VelocityField& wind,
                             std::uint64_t checkpointEvery)
    : p_(p), wind_(wind), checkpointEvery_(checkpointEvery) {
    ellipsoidWind_.field = &wind_;
    ellipsoidWind_.frame = GridFrame{vec3(0.0f), 1.0f};
    p_.motion = &ellipsoidMotion;
    p_.motionUser = &ellipsoidWind_;
    rowWind_.resize(size_t(p_.res.y));
    for (int y = 0; y < p_.res.y; ++y) {
        const vec3 w = velocityAt(wind_, vec3(0.5f, float(y) + 0.5f, 0.5f));
        rowWind_[size_t(y)] = glm::dvec2(w.x, w.z);
    }
    shifts_.resize(size_t(p_.res.y));
    state_ = initialState(p_);
    if (checkpointEvery_) checkpoints_.push_back(state_);
}

glm::dvec2 WindAutomaton::displacement(int y, double t) const {
    return t * rowWind_[size_t(y)];
}

void WindAutomaton::stepOnce() {
    const std::uint64_t n = state_.step;
    step(state_, p_, ws_);
    const double dt = double(p_.dt);
    for (int y = 0; y < p_.res.y; ++y) {
        const glm::dvec2 a = displacement(y, double(n) * dt),
                         b = displacement(y, double(n + 1) * dt);
        shifts_[size_t(y)] = glm::ivec2(int(floorCells(b.x) - floorCells(a.x)),
                                        int(floorCells(b.y) - floorCells(a.y)));
    }
    shiftRows(state_.bits, shifts_, shiftScratch_);
    state_.cover = columnCover(state_.bits);
    ++stepsComputed_;
    if (checkpointEvery_ && state_.step % checkpointEvery_ == 0 &&
        checkpoints_.size() == state_.step / checkpointEvery_)
        checkpoints_.push_back(state_);
}

void WindAutomaton::smoothInto(DensityGrid& g) {
    smoothDensity(state_.bits, g, smoothScratch_);
}

const AutomatonState& WindAutomaton::advanceTo(std::uint64_t n) {
    if (n < state_.step || (n == state_.step && n > 0 && prevStep_ != n - 1)) {
        // back in time: the nearest checkpoint at or before n - 1 (the loop below smooths step
        // n - 1 on its way), else the seed
        if (checkpointEvery_ && !checkpoints_.empty()) {
            const std::uint64_t before = n > 0 ? n - 1 : 0;
            const size_t k = std::min(size_t(before / checkpointEvery_), checkpoints_.size() - 1);
            state_ = checkpoints_[k];
        } else {
            state_ = initialState(p_);
        }
        prevStep_ = curStep_ = ~std::uint64_t(0);
    }
    while (state_.step < n) {
        if (state_.step + 1 == n) {
            // the grid of step n - 1 is kept beside step n's
            if (curStep_ == state_.step) {
                std::swap(prev_, cur_);
            } else {
                smoothInto(prev_);
            }
            prevStep_ = state_.step;
        }
        stepOnce();
    }
    if (curStep_ != n) {
        if (prevStep_ == n) {
            cur_ = prev_;
        } else {
            smoothInto(cur_);
        }
        curStep_ = n;
    }
    return state_;
}

void WindAutomaton::densityAt(double t, DensityGrid& out) {
    const double dt = double(p_.dt);
    std::uint64_t n = 0;
    float s = 0.0f;
    stepOf(t, p_.dt, n, s);
    advanceTo(n + 1);
    // prev_ is step n, cur_ step n + 1; move each to where the wind has carried it at t
    const int ny = p_.res.y;
    auto moved = [&](const DensityGrid& g, std::uint64_t step,
                     DensityGrid& dst) -> const DensityGrid& {
        std::vector<WindLayer> rows(static_cast<size_t>(ny));
        bool any = false;
        for (int y = 0; y < ny; ++y) {
            const glm::dvec2 x = displacement(y, t), at = displacement(y, double(step) * dt);
            const glm::dvec2 d = x - glm::dvec2(double(floorCells(at.x)), double(floorCells(at.y)));
            rows[size_t(y)] = WindLayer{float(y) + 0.5f, vec3(float(d.x), 0.0f, float(d.y))};
            any = any || d != glm::dvec2(0.0);
        }
        if (!any) return g;
        AdvectParams ap; // MacCormack, zero outside; one exact substep (no vertical wind)
        advect(g, GridFrame{vec3(0.0f), 1.0f}, layeredWind(std::move(rows)), 1.0f, ap, dst,
               advectWs_);
        return dst;
    };
    const DensityGrid& a = moved(prev_, n, movedA_);
    const DensityGrid& b = moved(cur_, n + 1, movedB_);
    lerpDensity(a, b, s, out);
}

} // namespace nimbus::sim
