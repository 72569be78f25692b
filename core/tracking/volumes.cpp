#include "core/tracking/volumes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <glm/gtc/matrix_transform.hpp>
#include <tbb/parallel_for.h>

namespace nimbus {

namespace {

constexpr float kInf = std::numeric_limits<float>::max();

/// World AABB of a local box through an affine map.
Box transformBox(const glm::mat4& m, const Box& b) {
    Box r{vec3(kInf), vec3(-kInf)};
    for (int k = 0; k < 8; ++k) {
        const vec3 c(k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y, k & 4 ? b.hi.z : b.lo.z);
        const vec3 w = vec3(m * vec4(c, 1.0f));
        r.lo = glm::min(r.lo, w);
        r.hi = glm::max(r.hi, w);
    }
    return r;
}

bool overlaps(const Box& a, const Box& b) {
    return a.lo.x <= b.hi.x && a.hi.x >= b.lo.x && a.lo.y <= b.hi.y && a.hi.y >= b.lo.y &&
           a.lo.z <= b.hi.z && a.hi.z >= b.lo.z;
}

Ray toLocal(const VolumeInstance& in, const Ray& r) {
    if (in.identity) return r;
    // the direction is not renormalised: t keeps its world meaning
    return Ray{vec3(in.localFromWorld * vec4(r.o, 1.0f)),
               vec3(in.localFromWorld * vec4(r.d, 0.0f))};
}

} // namespace

glm::mat4 instanceTransform(const InstanceDesc& d) {
    glm::mat4 m = glm::translate(glm::mat4(1.0f), d.translate);
    m = glm::rotate(m, glm::radians(d.rotate.z), vec3(0.0f, 0.0f, 1.0f));
    m = glm::rotate(m, glm::radians(d.rotate.y), vec3(0.0f, 1.0f, 0.0f));
    m = glm::rotate(m, glm::radians(d.rotate.x), vec3(1.0f, 0.0f, 0.0f));
    return glm::scale(m, d.scale);
}

bool isInstanced(const SceneDesc& s) {
    return s.instances.size() > 1 ||
           (s.instances.size() == 1 && instanceTransform(s.instances[0]) != glm::mat4(1.0f));
}

bool isPlaced(const SceneDesc& s, int v) {
    if (s.instances.empty()) return v == 0;
    return std::any_of(s.instances.begin(), s.instances.end(),
                       [v](const InstanceDesc& d) { return d.volume == v; });
}

std::vector<VolumeInstance> makeInstances(const std::vector<Field>& fields,
                                          const std::vector<InstanceDesc>& descs) {
    std::vector<InstanceDesc> all = descs;
    if (all.empty()) all.push_back(InstanceDesc{});
    std::vector<VolumeInstance> out;
    out.reserve(all.size());
    for (const InstanceDesc& d : all) {
        if (d.volume < 0 || d.volume >= int(fields.size()))
            throw std::invalid_argument("instance of volume " + std::to_string(d.volume) +
                                        ", but the scene has " + std::to_string(fields.size()));
        const Field& f = fields[size_t(d.volume)];
        if (f.bounds().empty() || d.density <= 0.0f) continue;
        VolumeInstance in;
        in.volume = d.volume;
        in.density = d.density;
        in.worldFromLocal = instanceTransform(d);
        in.identity = in.worldFromLocal == glm::mat4(1.0f);
        in.localFromWorld = glm::inverse(in.worldFromLocal);
        in.worldBounds = in.identity ? f.bounds() : transformBox(in.worldFromLocal, f.bounds());
        out.push_back(in);
    }
    return out;
}

void setShutter(VolumeSet& vs, const Shutter& shutter) {
    vs.shutter = shutter;
    vs.sweptBounds.clear();
    if (!shutter.open()) return;
    for (const Field& f : vs.fields) vs.sweptBounds.push_back(sweptBounds(f, shutter));
    for (VolumeInstance& in : vs.instances) {
        const Box& b = vs.sweptBounds[size_t(in.volume)];
        in.worldBounds = in.identity ? b : transformBox(in.worldFromLocal, b);
    }
}

float VolumeSet::densityAt(vec3 p) const {
    float sum = 0.0f;
    for (const VolumeInstance& in : instances) {
        if (!in.worldBounds.contains(p)) continue;
        const vec3 q = in.identity ? p : vec3(in.localFromWorld * vec4(p, 1.0f));
        sum += in.density * fields[size_t(in.volume)].density(q);
    }
    return sum;
}

float VolumeSet::majorantOver(const Box& b) const {
    float sum = 0.0f;
    for (const VolumeInstance& in : instances) {
        if (!overlaps(in.worldBounds, b)) continue;
        const Box local = in.identity ? b : transformBox(in.localFromWorld, b);
        sum += in.density * fields[size_t(in.volume)].majorant(local);
    }
    return sum;
}

MajorantGrid buildCoarseMajorantGrid(const VolumeSet& vs, float cell, float padding) {
    MajorantGrid g;
    g.bounds = vs.bounds;
    if (vs.bounds.empty()) return g;
    const vec3 e = g.bounds.extent();
    g.res = glm::max(ivec3(1), ivec3(glm::ceil(e / cell)));
    g.cellSize = e / vec3(g.res);
    g.maj.assign(size_t(g.res.x) * g.res.y * g.res.z, 0.0f);
    const vec3 pad = g.cellSize * padding;
    for (const VolumeInstance& in : vs.instances) {
        const Field& f = vs.fields[size_t(in.volume)];
        const MotionSweep sweep(f, vs.shutter);
        const ivec3 c0 = glm::clamp(
            ivec3(glm::floor((in.worldBounds.lo - g.bounds.lo) / g.cellSize)), ivec3(0), g.res - 1);
        const ivec3 c1 = glm::clamp(
            ivec3(glm::floor((in.worldBounds.hi - g.bounds.lo) / g.cellSize)), ivec3(0), g.res - 1);
        const ivec3 n = c1 - c0 + 1;
        std::vector<float> local(size_t(n.x) * n.y * n.z, 0.0f);
        auto at = [&](ivec3 c) -> float& {
            return local[(size_t(c.z - c0.z) * n.y + (c.y - c0.y)) * n.x + (c.x - c0.x)];
        };
        // grids: scatter the tree's node maxima (cost per node, not per cell x node)
        const bool grid = f.forEachDensityNode([&](const Box& nodeLocal, float m) {
            const Box w = transformBox(in.worldFromLocal, sweep.node(nodeLocal));
            const ivec3 a =
                glm::clamp(ivec3(glm::floor((w.lo - pad - g.bounds.lo) / g.cellSize)), c0, c1);
            const ivec3 b =
                glm::clamp(ivec3(glm::floor((w.hi + pad - g.bounds.lo) / g.cellSize)), c0, c1);
            for (int z = a.z; z <= b.z; ++z)
                for (int y = a.y; y <= b.y; ++y)
                    for (int x = a.x; x <= b.x; ++x) {
                        float& v = at(ivec3(x, y, z));
                        v = std::max(v, m);
                    }
        });
        if (!grid) {
            tbb::parallel_for(c0.z, c1.z + 1, [&](int z) {
                for (int y = c0.y; y <= c1.y; ++y)
                    for (int x = c0.x; x <= c1.x; ++x) {
                        const vec3 lo = g.bounds.lo + vec3(x, y, z) * g.cellSize;
                        const Box cellBox{lo - pad, lo + g.cellSize + pad};
                        at(ivec3(x, y, z)) = sweep.majorant(
                            in.identity ? cellBox : transformBox(in.localFromWorld, cellBox));
                    }
            });
        }
        for (int z = c0.z; z <= c1.z; ++z)
            for (int y = c0.y; y <= c1.y; ++y)
                for (int x = c0.x; x <= c1.x; ++x)
                    g.maj[(size_t(z) * g.res.y + y) * g.res.x + x] +=
                        in.density * at(ivec3(x, y, z));
    }
    g.buildBlocks();
    return g;
}

bool RayVolumes::begin(const VolumeSet& vs, const Ray& ray, float tmin, float tmax) {
    vs_ = &vs;
    ray_ = ray;
    if (poll_.flag != vs.cancel) poll_ = CancelPoll{vs.cancel};
    spans_.clear();
    densityActive_.clear();
    walkers_.clear();
    densityNext_ = segNext_ = 0;
    coarseStarted_ = false;
    hits_.clear();
    single_ = false;
    if (poll_()) return false;
    if (vs.single() && !vs.useCoarse) {
        const VolumeInstance& in = vs.instances[0];
        float t0, t1;
        if (!intersectBox(ray, vs.boundsOf(size_t(in.volume)), tmin, tmax, t0, t1)) return false;
        single_ = true;
        oneStarted_ = false;
        oneField_ = &vs.fields[size_t(in.volume)];
        tIn_ = cur_ = t0;
        tOut_ = t1;
        return true;
    }
    if (vs.single()) {
        hits_.push_back({0, tmin, tmax});
    } else if (vs.query) {
        vs.query->find(ray, tmin, tmax, hits_);
    } else {
        for (size_t i = 0; i < vs.instances.size(); ++i) hits_.push_back({int(i), tmin, tmax});
    }
    tIn_ = kInf;
    tOut_ = -kInf;
    for (const InstanceHit& h : hits_) {
        const VolumeInstance& in = vs.instances[size_t(h.instance)];
        Span s;
        s.instance = h.instance;
        s.local = toLocal(in, ray);
        // the exact span in the volume's own box (tighter than the world box of a rotated one)
        if (!intersectBox(s.local, vs.boundsOf(size_t(in.volume)), std::max(tmin, h.t0),
                          std::min(tmax, h.t1), s.t0, s.t1))
            continue;
        spans_.push_back(s);
        tIn_ = std::min(tIn_, s.t0);
        tOut_ = std::max(tOut_, s.t1);
    }
    if (spans_.empty()) return false;
    if (spans_.size() > 1)
        std::sort(spans_.begin(), spans_.end(),
                  [](const Span& a, const Span& b) { return a.t0 < b.t0; });
    cur_ = tIn_;
    return true;
}

float RayVolumes::cellMajorant(float t) const {
    if (single_) {
        const VolumeInstance& in = vs_->instances[0];
        const size_t v = size_t(in.volume);
        return v < vs_->grids.size() ? in.density * vs_->grids[v].boundAt(ray_.at(t)) : 0.0f;
    }
    float sum = 0.0f;
    for (const Span& s : spans_) {
        if (t < s.t0 || t > s.t1) continue;
        const VolumeInstance& in = vs_->instances[size_t(s.instance)];
        const size_t v = size_t(in.volume);
        if (v < vs_->grids.size()) sum += in.density * vs_->grids[v].boundAt(s.local.at(t));
    }
    return sum;
}

// the queries move forward: the spans ended before t are done
float RayVolumes::density(float t) {
    return densityAhead(t, t);
}

float RayVolumes::densityAhead(float t, float from) {
    if (single_) {
        if (t < tIn_ || t > tOut_) return 0.0f;
        const VolumeInstance& in = vs_->instances[0];
        return in.density * (time_ == 0.0f ? oneField_->density(ray_.at(t))
                                           : nimbus::densityAt(*oneField_, ray_.at(t), time_));
    }
    // the spans begun by t join the active ones (passed over before their start); those ended
    // before `from` leave
    while (densityNext_ < spans_.size() && spans_[densityNext_].t0 <= t)
        densityActive_.push_back(int(densityNext_++));
    float sum = 0.0f;
    for (size_t k = 0; k < densityActive_.size();) {
        const Span& s = spans_[size_t(densityActive_[k])];
        if (from > s.t1) {
            densityActive_[k] = densityActive_.back();
            densityActive_.pop_back();
            continue;
        }
        ++k;
        if (t < s.t0 || t > s.t1) continue;
        const VolumeInstance& in = vs_->instances[size_t(s.instance)];
        const Field& f = vs_->fields[size_t(in.volume)];
        sum += in.density * (time_ == 0.0f ? f.density(s.local.at(t))
                                           : nimbus::densityAt(f, s.local.at(t), time_));
    }
    return sum;
}

bool RayVolumes::nextSingle(MajorantSegment& out) {
    if (!oneStarted_) {
        oneStarted_ = true;
        const VolumeInstance& in = vs_->instances[0];
        const size_t v = size_t(in.volume);
        const bool traced = v < vs_->traceSdf.size() && vs_->traceSdf[v];
        one_.it =
            traced ? MajorantIterator(oneField_->as<SdfCloudField>(), oneField_->bounds(), ray_,
                                      tIn_, tOut_)
                   : MajorantIterator(vs_->useGrid[v] ? &vs_->grids[v] : nullptr, vs_->boundsOf(v),
                                      ray_, tIn_, tOut_, vs_->wholeMajorant[v]);
        one_.scale = in.density;
    }
    while (one_.it.next(one_.seg)) {
        const float sigma = one_.scale * one_.seg.sigma_maj;
        if (sigma > 0.0f && one_.seg.t1 > one_.seg.t0) {
            out = {one_.seg.t0, one_.seg.t1, sigma};
            return true;
        }
    }
    return false;
}

bool RayVolumes::nextSegment(MajorantSegment& out) {
    if (single_) return nextSingle(out);
    if (spans_.empty()) return false;
    if (vs_->useCoarse) {
        if (!coarseStarted_) {
            coarse_ = MajorantIterator(&vs_->coarse, vs_->bounds, ray_, tIn_, tOut_, 0.0f);
            coarseStarted_ = true;
        }
        return coarse_.next(out);
    }
    for (;;) {
        // start walking the spans the position has reached; with none active, jump to the next
        if (walkers_.empty() && segNext_ < spans_.size())
            cur_ = std::max(cur_, spans_[segNext_].t0);
        while (segNext_ < spans_.size() && spans_[segNext_].t0 <= cur_) {
            const Span& s = spans_[segNext_++];
            const VolumeInstance& in = vs_->instances[size_t(s.instance)];
            const size_t v = size_t(in.volume);
            const Field& f = vs_->fields[v];
            const bool traced = v < vs_->traceSdf.size() && vs_->traceSdf[v];
            Walker w{traced
                         ? MajorantIterator(f.as<SdfCloudField>(), f.bounds(), s.local, s.t0, s.t1)
                         : MajorantIterator(vs_->useGrid[v] ? &vs_->grids[v] : nullptr,
                                            vs_->boundsOf(v), s.local, s.t0, s.t1,
                                            vs_->wholeMajorant[v]),
                     MajorantSegment{}, in.density};
            if (w.it.next(w.seg)) walkers_.push_back(w);
        }
        // drop the segments the position has passed
        for (size_t k = 0; k < walkers_.size();) {
            Walker& w = walkers_[k];
            bool alive = true;
            while (w.seg.t1 <= cur_)
                if (!w.it.next(w.seg)) {
                    alive = false;
                    break;
                }
            if (!alive) {
                walkers_[k] = walkers_.back();
                walkers_.pop_back();
                continue;
            }
            ++k;
        }
        if (walkers_.empty()) {
            if (segNext_ >= spans_.size()) return false;
            continue;
        }
        float sigma = 0.0f, end = segNext_ < spans_.size() ? spans_[segNext_].t0 : kInf;
        for (const Walker& w : walkers_) {
            if (w.seg.t0 <= cur_) {
                sigma += w.scale * w.seg.sigma_maj;
                end = std::min(end, w.seg.t1);
            } else {
                end = std::min(end, w.seg.t0);
            }
        }
        const float start = cur_;
        cur_ = end;
        if (sigma > 0.0f && end > start) {
            out = {start, end, sigma};
            return true;
        }
    }
}

} // namespace nimbus
