#include "core/tracking/majorant.h"

#include "core/cancel.h"

#include <cmath>
#include <limits>

#include <tbb/parallel_for.h>

namespace nimbus {

double MajorantGrid::emptyFraction() const {
    if (maj.empty()) return 0.0;
    size_t n = 0;
    for (float m : maj) n += m <= 0.0f;
    return double(n) / double(maj.size());
}

Box MajorantGrid::occupiedBounds() const {
    ivec3 lo(std::numeric_limits<int>::max()), hi(-1);
    for (int z = 0; z < res.z; ++z)
        for (int y = 0; y < res.y; ++y)
            for (int x = 0; x < res.x; ++x)
                if (at(ivec3(x, y, z)) > 0.0f) {
                    lo = glm::min(lo, ivec3(x, y, z));
                    hi = glm::max(hi, ivec3(x, y, z));
                }
    if (hi.x < 0) return Box{};
    return Box{bounds.lo + vec3(lo) * cellSize, bounds.lo + vec3(hi + 1) * cellSize};
}

void MajorantGrid::buildBlocks() {
    blockRes = (res + ivec3(kBlock - 1)) / kBlock;
    const size_t n = size_t(blockRes.x) * blockRes.y * blockRes.z;
    std::vector<int> dist(n, 1 << 20);
    auto at3 = [&](int x, int y, int z) -> int& {
        return dist[(size_t(z) * blockRes.y + y) * blockRes.x + x];
    };
    for (int z = 0; z < res.z; ++z)
        for (int y = 0; y < res.y; ++y)
            for (int x = 0; x < res.x; ++x)
                if (at(ivec3(x, y, z)) > 0.0f) at3(x / kBlock, y / kBlock, z / kBlock) = 0;
    // Chebyshev distance transform: a forward and a backward sweep over the 26 neighbours
    // (exact for this metric); the space outside the grid counts as empty
    for (int pass = 0; pass < 2; ++pass) {
        const int s = pass == 0 ? 1 : -1;
        const ivec3 from = pass == 0 ? ivec3(0) : blockRes - 1;
        for (int z = from.z; z >= 0 && z < blockRes.z; z += s)
            for (int y = from.y; y >= 0 && y < blockRes.y; y += s)
                for (int x = from.x; x >= 0 && x < blockRes.x; x += s) {
                    int& d = at3(x, y, z);
                    for (int dz = -1; dz <= 1; ++dz)
                        for (int dy = -1; dy <= 1; ++dy)
                            for (int dx = -1; dx <= 1; ++dx) {
                                // only neighbours already visited in this sweep's order
                                const int order = (dz * s) * 9 + (dy * s) * 3 + dx * s;
                                if (order >= 0) continue;
                                const int xx = x + dx, yy = y + dy, zz = z + dz;
                                if (xx < 0 || yy < 0 || zz < 0 || xx >= blockRes.x ||
                                    yy >= blockRes.y || zz >= blockRes.z)
                                    continue;
                                d = std::min(d, at3(xx, yy, zz) + 1);
                            }
                }
    }
    blockDistance.resize(n);
    for (size_t i = 0; i < n; ++i) blockDistance[i] = std::uint8_t(std::min(dist[i], 255));
}

ivec3 majorantResolution(vec3 ext, float cell) {
    ivec3 res;
    for (int a = 0; a < 3; ++a) res[a] = std::max(1, int(std::ceil(ext[a] / cell)));
    return res;
}

MajorantGrid buildMajorantGrid(const Field& field, float cell, float padding,
                               const std::atomic<bool>* cancel, const Shutter& shutter,
                               bool tight) {
    MajorantGrid g;
    const MotionSweep sweep(field, shutter);
    g.bounds = sweep.bounds();
    const vec3 ext = g.bounds.extent();
    g.res = majorantResolution(ext, cell);
    g.cellSize = ext / vec3(g.res);
    g.maj.assign(size_t(g.res.x) * g.res.y * g.res.z, 0.0f);
    const vec3 pad = g.cellSize * padding;
    // tight: each cell bounded from the voxels it reads, in the per-cell loop below
    const bool voxels = tight && !shutter.open() && field.hasTightMajorant();
    // grid fields: every tree node writes its maximum into the cells its support overlaps
    // (one pass over the nodes instead of one tree query per cell)
    if (!voxels && field.forEachDensityNode([&](const Box& node, float v) {
            const Box n = sweep.node(node);
            const ivec3 a = glm::clamp(ivec3(glm::floor((n.lo - pad - g.bounds.lo) / g.cellSize)),
                                       ivec3(0), g.res - ivec3(1));
            const ivec3 b = glm::clamp(ivec3(glm::floor((n.hi + pad - g.bounds.lo) / g.cellSize)),
                                       ivec3(0), g.res - ivec3(1));
            for (int z = a.z; z <= b.z; ++z)
                for (int y = a.y; y <= b.y; ++y)
                    for (int x = a.x; x <= b.x; ++x) {
                        float& m = g.maj[(size_t(z) * g.res.y + y) * g.res.x + x];
                        m = std::max(m, v);
                    }
        })) {
        g.buildBlocks();
        return g;
    }
    tbb::parallel_for(0, g.res.z, [&](int z) {
        for (int y = 0; y < g.res.y; ++y) {
            if (cancelRequested(cancel)) return;
            for (int x = 0; x < g.res.x; ++x) {
                vec3 lo = g.bounds.lo + vec3(x, y, z) * g.cellSize;
                Box b{lo - pad, lo + g.cellSize + pad};
                float& m = g.maj[(size_t(z) * g.res.y + y) * g.res.x + x];
                if (!voxels || !field.tightMajorant(b, m)) m = sweep.majorant(b);
            }
        }
    });
    g.buildBlocks();
    return g;
}

MajorantIterator::MajorantIterator(const MajorantGrid* grid, const Box& bounds, const Ray& ray,
                                   float tmin, float tmax, float wholeMajorant)
    : grid_(grid), ray_(ray), whole_(wholeMajorant) {
    float t0, t1;
    if (!intersectBox(ray, grid ? grid->bounds : bounds, tmin, tmax, t0, t1)) return;
    done_ = false;
    t_ = t0;
    tEnd_ = t1;
    if (!grid_) return;
    const float inf = std::numeric_limits<float>::infinity();
    const vec3 p = ray.at(t0);
    for (int a = 0; a < 3; ++a) {
        step_[a] = ray.d[a] > 0.0f ? 1 : ray.d[a] < 0.0f ? -1 : 0;
        tDelta_[a] = step_[a] ? float(step_[a]) * grid_->cellSize[a] / ray.d[a] : inf;
        tNext_[a] = inf;
        enterCell(a, std::clamp(cellOf(a, p[a]), 0, grid_->res[a] - 1));
    }
}

MajorantIterator::MajorantIterator(const SdfCloudField& sdf, const Box& bounds, const Ray& ray,
                                   float tmin, float tmax)
    : grid_(nullptr), ray_(ray), sdf_(&sdf) {
    float t0, t1;
    if (!intersectBox(ray, bounds, tmin, tmax, t0, t1)) return;
    done_ = false;
    t_ = t0;
    tEnd_ = t1;
    dirLength_ = glm::length(ray.d);
    // about half the shell where the density varies; a hundredth of the box for hard surfaces
    const float shell = sdf.falloff + sdf.tree->displacementBound;
    minSegment_ = shell > 0.0f ? 0.5f * shell : 0.01f * glm::length(bounds.extent());
    minSegment_ = std::max(minSegment_, 4.0f * sdf.margin);
}

bool MajorantIterator::nextTraced(MajorantSegment& seg) {
    while (t_ < tEnd_) {
        float u;
        const float s = sdf_->skip(ray_.at(t_), u);
        ++steps_;
        if (s > 0.25f * minSegment_) { // empty space: leap
            t_ += s / dirLength_;
            continue;
        }
        // at the support: the support certainly continues for -(u + A) (1-Lipschitz bound)
        const float L = std::max(minSegment_, -(u + sdf_->tree->displacementBound) - sdf_->margin);
        const float t0 = t_;
        const float t1 = std::min(t_ + L / dirLength_, tEnd_);
        t_ = t1 > t0 ? t1 : std::nextafter(t0, tEnd_);
        const float m = sdf_->majorantBall(u, L);
        if (m > 0.0f && t1 > t0) {
            seg = {t0, t1, m};
            return true;
        }
    }
    done_ = true;
    return false;
}

int MajorantIterator::cellOf(int a, float x) const {
    return kern::ddaCell(x, grid_->bounds.lo[a], grid_->cellSize[a]);
}

float MajorantIterator::edgeT(int a, int edge) const {
    return kern::ddaEdgeT(grid_->bounds.lo[a], edge, grid_->cellSize[a], ray_.o[a], ray_.d[a]);
}

void MajorantIterator::enterCell(int a, int c) {
    cell_[a] = c;
    if (step_[a] != 0) tNext_[a] = edgeT(a, step_[a] > 0 ? c + 1 : c);
}

bool MajorantIterator::next(MajorantSegment& seg) {
    if (done_) return false;
    if (sdf_) return nextTraced(seg);
    if (!grid_) {
        done_ = true;
        seg = {t_, tEnd_, whole_};
        return whole_ > 0.0f;
    }
    const bool skip = !grid_->blockDistance.empty();
    while (t_ < tEnd_) {
        if (skip) {
            const int d = grid_->blockDistanceAt(cell_);
            if (d > 0) {
                leap(d);
                continue;
            }
        }
        const int axis = kern::ddaAxis(tNext_);
        float tExit = std::min(tNext_[axis], tEnd_);
        float m = grid_->at(cell_);
        float tEnter = t_;
        t_ = std::max(t_, tExit);
        cell_[axis] += step_[axis];
        tNext_[axis] += tDelta_[axis];
        if (cell_[axis] < 0 || cell_[axis] >= grid_->res[axis]) t_ = tEnd_; // left the grid
        if (m > 0.0f && tExit > tEnter) {
            seg = {tEnter, tExit, m};
            return true;
        }
    }
    done_ = true;
    return false;
}

void MajorantIterator::leap(int d) {
    // where the ray leaves the empty cube: the nearest of its exit faces (the same edge formula
    // the cell walk uses, so the two agree at the faces)
    const int B = MajorantGrid::kBlock;
    const ivec3 block = cell_ / B;
    const ivec3 b0 = glm::max(block - (d - 1), ivec3(0)) * B;
    const ivec3 b1 = glm::min((block + d) * B, grid_->res); // one past the cube's last cell
    int axis = -1;
    float tExit = std::numeric_limits<float>::infinity();
    for (int a = 0; a < 3; ++a) {
        if (step_[a] == 0) continue;
        const float t = edgeT(a, step_[a] > 0 ? b1[a] : b0[a]);
        if (t < tExit) {
            tExit = t;
            axis = a;
        }
    }
    if (axis < 0 || tExit >= tEnd_) {
        t_ = tEnd_;
        return;
    }
    t_ = std::max(t_, tExit);
    // the exit axis moves past the cube; the others stay within the cube's range
    // (the ray left through the exit face), which rounding cannot undo
    const int past = step_[axis] > 0 ? b1[axis] : b0[axis] - 1;
    if (past < 0 || past >= grid_->res[axis]) {
        t_ = tEnd_; // left the grid
        return;
    }
    const vec3 p = ray_.at(t_);
    for (int a = 0; a < 3; ++a)
        enterCell(a, a == axis ? past : std::clamp(cellOf(a, p[a]), b0[a], b1[a] - 1));
}

} // namespace nimbus
