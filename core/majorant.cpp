#include "core/majorant.h"

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

MajorantGrid buildMajorantGrid(const Field& field, float cell, float padding) {
    MajorantGrid g;
    g.bounds = field.bounds();
    const vec3 ext = g.bounds.extent();
    for (int a = 0; a < 3; ++a) g.res[a] = std::max(1, int(std::ceil(ext[a] / cell)));
    g.cellSize = ext / vec3(g.res);
    g.maj.assign(size_t(g.res.x) * g.res.y * g.res.z, 0.0f);
    const vec3 pad = g.cellSize * padding;
    // grid fields: every tree node writes its maximum into the cells its support overlaps
    // (one pass over the nodes instead of one tree query per cell)
    if (field.forEachDensityNode([&](const Box& n, float v) {
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
        }))
        return g;
    tbb::parallel_for(0, g.res.z, [&](int z) {
        for (int y = 0; y < g.res.y; ++y)
            for (int x = 0; x < g.res.x; ++x) {
                vec3 lo = g.bounds.lo + vec3(x, y, z) * g.cellSize;
                Box b{lo - pad, lo + g.cellSize + pad};
                g.maj[(size_t(z) * g.res.y + y) * g.res.x + x] = field.majorant(b);
            }
    });
    return g;
}

MajorantIterator::MajorantIterator(const MajorantGrid* grid, const Box& bounds, const Ray& ray,
                                   float tmin, float tmax, float wholeMajorant)
    : grid_(grid), whole_(wholeMajorant) {
    float t0, t1;
    if (!intersectBox(ray, grid ? grid->bounds : bounds, tmin, tmax, t0, t1)) return;
    done_ = false;
    t_ = t0;
    tEnd_ = t1;
    if (!grid_) return;
    const float inf = std::numeric_limits<float>::infinity();
    const vec3 p = ray.at(t0);
    for (int a = 0; a < 3; ++a) {
        int c = int(std::floor((p[a] - grid_->bounds.lo[a]) / grid_->cellSize[a]));
        cell_[a] = std::clamp(c, 0, grid_->res[a] - 1);
        if (ray.d[a] > 0.0f) {
            step_[a] = 1;
            float edge = grid_->bounds.lo[a] + float(cell_[a] + 1) * grid_->cellSize[a];
            tNext_[a] = (edge - ray.o[a]) / ray.d[a];
            tDelta_[a] = grid_->cellSize[a] / ray.d[a];
        } else if (ray.d[a] < 0.0f) {
            step_[a] = -1;
            float edge = grid_->bounds.lo[a] + float(cell_[a]) * grid_->cellSize[a];
            tNext_[a] = (edge - ray.o[a]) / ray.d[a];
            tDelta_[a] = -grid_->cellSize[a] / ray.d[a];
        } else {
            step_[a] = 0;
            tNext_[a] = inf;
            tDelta_[a] = inf;
        }
    }
}

bool MajorantIterator::next(MajorantSegment& seg) {
    if (done_) return false;
    if (!grid_) {
        done_ = true;
        seg = {t_, tEnd_, whole_};
        return whole_ > 0.0f;
    }
    while (t_ < tEnd_) {
        int axis =
            tNext_.x < tNext_.y ? (tNext_.x < tNext_.z ? 0 : 2) : (tNext_.y < tNext_.z ? 1 : 2);
        float tExit = std::min(tNext_[axis], tEnd_);
        float m = grid_->at(cell_);
        float tEnter = t_;
        t_ = tExit;
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

} // namespace nimbus
