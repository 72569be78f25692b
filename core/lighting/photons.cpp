#include "core/lighting/photons.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/sampler.h"
#include "core/tracking/tracking.h"

namespace nimbus {

namespace {

constexpr double kFixed = 1048576.0; // 2^20: fixed-point scale of the sums
constexpr float kMaxDeposit = 1e12f; // one deposit at most (keeps the sums far from overflow)
/// A voxel's records are weighted by rho / rhoBar + this (tracePhotons): with the floor a voxel
/// holding a trace of density keeps about its plain volume mean. Measured on the validation
/// matrix's medium rows (docs/accuracy.md, "Photons weighted by the density"): 0.1 and 0.3 alike;
/// 0 lets edge voxels of wispy clouds blow up, a large floor is the plain volume mean.
constexpr float kDensityFloor = 0.3f;
/// Walking a grid of their own (PhotonParams::ownWalk), photons after their first scattering walk
/// their bounds raised to this times the mean density rhoBar in every cell with density
/// (tracePhotons): the rate at which the floor above is sampled where the density is sparse.
/// Measured on a thick smoke (one run each): 0.1, 0.5 and 100 alike in error and level, 0.1 and
/// 0.5 alike in time, 100 nineteen times slower (docs/accuracy.md, "Where the photons' time goes
/// on a thick cloud").
constexpr float kWalkFloor = 0.5f;

/// The voxel of a grid (corner lo, voxel size, res) that holds q, clamped to the grid.
inline ivec3 cellAt(vec3 lo, vec3 voxel, ivec3 res, vec3 q) {
    return glm::clamp(ivec3(glm::floor((q - lo) / voxel)), ivec3(0), res - ivec3(1));
}

constexpr double kFourPi = 4.0 * 3.14159265358979;

/// The rectangle that covers a box seen along -d (d: toward the light), on the plane through
/// `origin`: its axes u, v (an orthonormal frame with d) and its extent lo..hi along them,
/// relative to the origin.
struct Footprint {
    vec3 u{0.0f}, v{0.0f};
    vec2 lo{0.0f}, hi{0.0f};
    float area() const { return (hi.x - lo.x) * (hi.y - lo.y); }
};

Footprint footprint(const Box& b, vec3 d, vec3 origin) {
    Footprint f;
    f.u = kern::phaseDirection(d, 0.0f, 0.0f);
    f.v = glm::cross(d, f.u);
    f.lo = vec2(std::numeric_limits<float>::max());
    f.hi = vec2(-std::numeric_limits<float>::max());
    for (int c = 0; c < 8; ++c) {
        const vec3 q((c & 1) ? b.hi.x : b.lo.x, (c & 2) ? b.hi.y : b.lo.y,
                     (c & 4) ? b.hi.z : b.lo.z);
        const vec2 uv(glm::dot(q - origin, f.u), glm::dot(q - origin, f.v));
        f.lo = glm::min(f.lo, uv);
        f.hi = glm::max(f.hi, uv);
    }
    return f;
}

/// The majorant segments of a walk with every bound scaled (an instance's density scale).
struct ScaledSegments {
    MajorantIterator& walk;
    float scale;
    CancelPoll& poll; ///< read every CancelPoll::kEvery flights by sampleTmaj (core/cancel.h)
    bool cancelled() { return poll.now(); }
    bool next(MajorantSegment& seg) {
        if (!walk.next(seg)) return false;
        seg.sigma_maj *= scale;
        return true;
    }
};

/// A medium's coefficients per unit density as the photons' tracking uses them: scattering,
/// extinction, and the extinction's largest and mean channel (the tracking's rate and the share
/// of its events that are real).
struct Coefficients {
    vec3 s, t;
    float tMax, tMean;
    Coefficients(vec3 sigmaS, vec3 sigmaA)
        : s(sigmaS), t(sigmaS + sigmaA), tMax(maxComponent(t)), tMean((t.x + t.y + t.z) / 3.0f) {}
};

/// What one thread adds up: 3 channels per recording voxel, and its density lookups.
struct Tally {
    std::vector<std::int64_t> sum;
    std::uint64_t lookups = 0;
    std::uint64_t traced = 0;
    std::uint64_t skyTraced = 0;
    std::uint64_t scatterings = 0;
};

/// A photon's tentative collisions in one voxel along one straight flight, added up before they
/// go to the voxel's sum: the phase function toward the camera is evaluated once per run, and
/// the fixed-point rounding done once (the same for a seed whatever the thread count).
struct Run {
    int voxel = -1; ///< the recording voxel's index among those that record; -1 = none
    vec3 phase{0.0f};
    glm::dvec3 sum{0.0};
    void add(vec3 v) { sum += glm::dvec3(v); }
    void flush(Tally& t) {
        if (voxel >= 0) {
            const glm::dvec3 val =
                glm::min(sum * glm::dvec3(phase), glm::dvec3(double(kMaxDeposit)));
            std::int64_t* s = &t.sum[3 * size_t(voxel)];
            for (int ch = 0; ch < 3; ++ch) s[ch] += std::int64_t(std::llround(val[ch] * kFixed));
        }
        voxel = -1;
        sum = glm::dvec3(0.0);
    }
};

/// The photons' own density bounds (photonTrackingBounds) on the cells of the grid they walk.
struct TrackingBounds {
    const MajorantGrid* grid = nullptr;
    /// The bound of the cell holding q.
    float at(vec3 q) const {
        const ivec3 c = glm::clamp(ivec3(glm::floor((q - grid->bounds.lo) / grid->cellSize)),
                                   ivec3(0), grid->res - ivec3(1));
        return grid->maj[voxelIndex(grid->res, c.x, c.y, c.z)];
    }
};

} // namespace

std::vector<float> photonTrackingBounds(const MajorantGrid& mg, const std::vector<float>& fine,
                                        vec3 lo, ivec3 res, vec3 voxel) {
    std::vector<float> bound(mg.maj.size(), 0.0f);
    const vec3 pad = 0.05f * mg.cellSize;
    tbb::parallel_for(0, mg.res.z, [&](int z) {
        for (int y = 0; y < mg.res.y; ++y)
            for (int x = 0; x < mg.res.x; ++x) {
                const size_t c = voxelIndex(mg.res, x, y, z);
                if (!(mg.maj[c] > 0.0f)) continue;
                const vec3 cLo = mg.bounds.lo + vec3(x, y, z) * mg.cellSize - pad;
                const vec3 cHi = cLo + mg.cellSize + 2.0f * pad;
                // the centres a lookup in [cLo, cHi] interpolates (sampleVoxelCentres: i0 =
                // floor(u), i1 = i0 + 1, u = (p - lo) / voxel - 0.5 clamped to the grid)
                const ivec3 a = glm::clamp(ivec3(glm::floor((cLo - lo) / voxel - 0.5f)), ivec3(0),
                                           res - ivec3(1));
                const ivec3 b = glm::clamp(ivec3(glm::floor((cHi - lo) / voxel - 0.5f)) + 1,
                                           ivec3(0), res - ivec3(1));
                float m = 0.0f;
                for (int k = a.z; k <= b.z; ++k)
                    for (int j = a.y; j <= b.y; ++j)
                        for (int i = a.x; i <= b.x; ++i)
                            m = std::max(m, fine[voxelIndex(res, i, j, k)]);
                bound[c] = std::min(mg.maj[c], m);
            }
    });
    return bound;
}

vec3 PhotonVolume::sample(vec3 p) const {
    return sampleVoxelCentres(radiance, bounds.lo, res, voxel, p) * skin(p);
}

ivec3 photonTrackingResolution(const Box& bounds, float trackingCell) {
    return lightVolumeResolution(bounds, trackingCell);
}

float photonTrackingCell(const Box& bounds, float majorantCell, float photonCell) {
    // without a majorant grid: the photons' voxel, whose grid they record on already
    if (!(majorantCell > 0.0f)) return photonCell;
    const float coarsest = 0.5f * majorantCell;
    float cell = photonCell > 0.0f ? std::min(coarsest, photonCell) : coarsest;
    for (;;) {
        const ivec3 r = lightVolumeResolution(bounds, cell);
        if (cell >= coarsest || double(r.x) * r.y * r.z <= kMaxTrackingVoxels) return cell;
        cell = std::min(2.0f * cell, coarsest);
    }
}

double photonBytes(const Box& bounds, ivec3 res, float trackingCell, double majorantCells,
                   bool ownWalk, bool ownDensity, double handOffVoxels) {
    const ivec3 fine = photonTrackingResolution(bounds, trackingCell);
    const double fineCells = double(fine.x) * fine.y * fine.z;
    const double voxels = double(res.x) * res.y * res.z;
    // the walk's bounds: on march's grid, or (their own walk) two grids of tracking cells
    return voxels *
               (sizeof(int) + sizeof(float) + 2 * sizeof(vec3) + (ownDensity ? sizeof(float) : 0)) +
           fineCells * sizeof(float) + (ownWalk ? 2.0 * fineCells : majorantCells) * sizeof(float) +
           handOffVoxels * (3 * sizeof(std::int64_t) + sizeof(vec3));
}

PhotonVolume tracePhotons(const VolumeSet& vs, const PhaseFunction& phase, const LightVolume& geo,
                          const std::vector<float>& rho, const PhotonParams& p,
                          const SurfaceQuery* surfaces, const std::atomic<bool>* cancel) {
    PhotonVolume pv;
    pv.bounds = geo.bounds;
    pv.res = geo.res;
    pv.voxel = geo.voxel;
    pv.sunTau = p.sunTau;
    pv.skinK = p.skinK;
    pv.skinFloor = p.skinFloor;
    const ivec3 res = geo.res;
    const size_t n = size_t(res.x) * res.y * res.z;
    pv.radiance.assign(n, vec3(0.0f));
    const Coefficients real(p.sigma_s, p.sigma_a);
    // the similar medium (PhotonParams::similarAfter): isotropic at sigma_s (1 - g), where the
    // phase function scatters forward
    const float gMean = p.similarAfter > 0 ? phase.meanCosine() : 0.0f;
    const bool similarOn = p.similarAfter > 0 && gMean > 0.0f && gMean < 1.0f;
    const Coefficients similarMedium(p.sigma_s * (1.0f - gMean), p.sigma_a);
    if (p.photons <= 0 || real.tMax <= 0.0f ||
        (maxComponent(p.sunIrradiance) <= 0.0f && p.sky.kind == SkyKind::None) || rho.size() != n)
        return pv;

    // photons read the density from a grid of half the majorant cell, or of the recording voxel
    // where that is finer (photonTrackingCell), filled once where the majorant grid has cloud and
    // read trilinearly: a lookup there costs a few loads, not a field evaluation, and most of a
    // photon's time is lookups. Its values are the field's own samples, so they keep to the same
    // majorants (clamped where a trilinear footprint reaches over a cell's edge). (the majorant
    // grid whenever there is one: march may leave a mostly full grid unused, but tracking always
    // gains from the tighter bounds, as pathtrace does)
    const MajorantGrid* mg = vs.grids[0].cellCount() ? &vs.grids[0] : nullptr;
    // (the cell as the plan chose it over the field's bounds; the grid over the photons' grid,
    // which may cover only the cloud: densityGridWithin)
    const Box fieldBounds = vs.fields[0].bounds();
    const vec3 ext = geo.bounds.extent();
    const ivec3 fineRes = photonTrackingResolution(
        geo.bounds, photonTrackingCell(fieldBounds, mg ? minComponent(mg->cellSize) : 0.0f,
                                       minComponent(geo.voxel)));
    const vec3 fineVoxel = ext / vec3(fineRes);
    std::size_t fineLookups = 0;
    std::vector<float> fine =
        densityAtCentres(vs.fields[0], geo.bounds, fineRes, mg, fineLookups, cancel);
    pv.lookups += fineLookups;
    // the one untransformed placement may scale the volume's density
    const float placement = vs.instances[0].density;
    // Where photons walk. March's majorant grid bounds by tree nodes, often several times the
    // density; walking it, photons thin its events to bounds of their own (photonTrackingBounds
    // on its cells), so that only the events they keep cost a lookup, and take the floor of the
    // recording weight at every event. In a cloud whose voxels are optically deep the plan has
    // them walk a grid of their own instead (p.ownWalk), on the tracking grid's cells, at those
    // bounds (`first`): through march's grid a thick smoke took 19 events a collision. Where
    // voxels are shallower the walk's extra events lower the recording's noise more than they
    // cost (docs/accuracy.md, "Photons on a majorant grid of their own").
    // Before its first scattering a photon records nothing, so it walks the bounds the tracking
    // thins to (the cells where no lookup can find density skipped).
    // (on the tracking grid's cells, unbounded there, or on march's grid's)
    MajorantGrid first;
    if (p.ownWalk) {
        first.bounds = geo.bounds;
        first.res = fineRes;
        first.cellSize = fineVoxel;
        first.maj.assign(fine.size(), std::numeric_limits<float>::max());
    } else if (mg) {
        first = *mg;
    }
    if (!first.maj.empty()) {
        first.maj = photonTrackingBounds(first, fine, geo.bounds.lo, fineRes, fineVoxel);
        first.buildBlocks();
    }
    const TrackingBounds tracking{first.maj.empty() ? nullptr : &first};
    if (placement != 1.0f)
        for (float& v : fine) v *= placement;

    // Each voxel's mean density, as photons see it: the tracking grid read trilinearly at
    // 1.5 points per tracking cell and axis (2 to 32 a voxel's side)
    // (sampled only in voxels that a tracking cell with density reaches with its trilinear
    // footprint, one cell either side of its centre)
    std::vector<float> mean(n, 0.0f);
    {
        std::vector<std::uint8_t> reached(n, 0);
        for (int fz = 0; fz < fineRes.z; ++fz)
            for (int fy = 0; fy < fineRes.y; ++fy)
                for (int fx = 0; fx < fineRes.x; ++fx) {
                    if (!(fine[voxelIndex(fineRes, fx, fy, fz)] > 0.0f)) continue;
                    const vec3 c = (vec3(fx, fy, fz) + 0.5f) * fineVoxel;
                    const ivec3 a = glm::clamp(ivec3(glm::floor((c - fineVoxel) / geo.voxel)),
                                               ivec3(0), res - 1);
                    const ivec3 b = glm::clamp(ivec3(glm::floor((c + fineVoxel) / geo.voxel)),
                                               ivec3(0), res - 1);
                    for (int z = a.z; z <= b.z; ++z)
                        for (int y = a.y; y <= b.y; ++y)
                            for (int x = a.x; x <= b.x; ++x) reached[voxelIndex(res, x, y, z)] = 1;
                }
        const ivec3 sub =
            glm::clamp(ivec3(glm::ceil(1.5f * geo.voxel / fineVoxel)), ivec3(2), ivec3(32));
        const float invSub = 1.0f / float(sub.x * sub.y * sub.z);
        tbb::parallel_for(0, res.z, [&](int z) {
            for (int y = 0; y < res.y; ++y)
                for (int x = 0; x < res.x; ++x) {
                    if (!reached[voxelIndex(res, x, y, z)]) continue;
                    double acc = 0.0;
                    for (int c = 0; c < sub.z; ++c)
                        for (int b = 0; b < sub.y; ++b)
                            for (int a = 0; a < sub.x; ++a)
                                acc += sampleVoxelCentres(
                                    fine, geo.bounds.lo, fineRes, fineVoxel,
                                    geo.bounds.lo +
                                        (vec3(x, y, z) + (vec3(a, b, c) + 0.5f) / vec3(sub)) *
                                            geo.voxel);
                    mean[voxelIndex(res, x, y, z)] = float(acc) * invSub;
                }
        });
    }

    // the voxels that record: those with density in them, and the 26 neighbours of those with
    // density at their centre (the light-volume grid's density, trilinear between centres)
    std::vector<int> active(n, -1);
    std::vector<std::uint32_t> cells;
    for (int z = 0; z < res.z; ++z)
        for (int y = 0; y < res.y; ++y)
            for (int x = 0; x < res.x; ++x) {
                bool any = false;
                for (int dz = -1; dz <= 1 && !any; ++dz)
                    for (int dy = -1; dy <= 1 && !any; ++dy)
                        for (int dx = -1; dx <= 1 && !any; ++dx) {
                            const int xx = x + dx, yy = y + dy, zz = z + dz;
                            if (xx < 0 || yy < 0 || zz < 0 || xx >= res.x || yy >= res.y ||
                                zz >= res.z)
                                continue;
                            any = rho[voxelIndex(res, xx, yy, zz)] > 0.0f;
                        }
                if (!any && !(mean[voxelIndex(res, x, y, z)] > 0.0f)) continue;
                active[voxelIndex(res, x, y, z)] = int(cells.size());
                cells.push_back(std::uint32_t(voxelIndex(res, x, y, z)));
            }
    if (cells.empty()) return pv;

    // What a voxel records is weighted by the density where the light is, plus a floor: march
    // scatters rho(p) S(p) at its samples, so a voxel's mean S should weight its parts by their
    // density. Where a voxel holds a filament or a puff and much empty space, the scattered
    // light is brightest there and a plain volume mean dims it. The floor (kDensityFloor times
    // rhoBar, the mean density of the voxels with density at their centre, else of those with
    // density in them) keeps voxels with a trace of density from dividing by almost nothing.
    // norm[v]: the voxel's mean of rho / rhoBar + the floor, what its sums are divided by.
    double centred = 0.0, any = 0.0;
    size_t nCentred = 0, nAny = 0;
    for (const std::uint32_t i : cells) {
        if (!(mean[i] > 0.0f)) continue;
        any += mean[i];
        ++nAny;
        if (rho[i] > 0.0f) {
            centred += mean[i];
            ++nCentred;
        }
    }
    const float rhoBar = nCentred ? float(centred / double(nCentred))
                         : nAny   ? float(any / double(nAny))
                                  : 1.0f;
    const float invRhoBar = 1.0f / rhoBar;
    // the own walk after a first scattering: its bounds raised to kWalkFloor rhoBar where a cell
    // has density, so that the floor of the recording weight, taken at every event, is sampled
    // at a rate of its own where the density is sparse (the same cells are empty, so the copied
    // empty blocks still hold)
    MajorantGrid walkGrid;
    if (p.ownWalk) {
        walkGrid = first;
        const float floorRate = kWalkFloor * rhoBar / (placement > 0.0f ? placement : 1.0f);
        for (float& v : walkGrid.maj)
            if (v > 0.0f) v = std::max(v, floorRate);
    }
    std::vector<float>& norm = mean;
    for (float& v : norm) v = v * invRhoBar + kDensityFloor;

    // photons start on a plane on the light's side of the bounds (so that surfaces between the
    // light and the cloud still stop them), over the rectangle that covers the box holding
    // density (MajorantGrid::occupiedBounds) seen from there: only photons aimed at it can meet
    // the cloud, and a small cloud in wide bounds (daichi_smoke: 1% of the rays along the sun
    // over its bounds meet it) gets all of them. Each carries the power of its share of that
    // rectangle. The sun's and the sky's photons share p.photons in proportion to their power
    // (the sky's from its radiance over 256 directions); every photon's weight is relative to
    // the mean power per photon, flux0, so that the fixed-point sums see weights about 1.
    const vec3 sunTo = glm::normalize(p.sunDirection);
    const vec3 centre = 0.5f * (fieldBounds.lo + fieldBounds.hi);
    const float radius = 0.5f * glm::length(fieldBounds.extent());
    const Box occupied = mg ? mg->occupiedBounds() : Box{};
    const Box emit = occupied.empty() ? geo.bounds : occupied.within(geo.bounds);
    const Footprint sunRect = footprint(emit, sunTo, centre);
    const vec3 sunPower = p.sunIrradiance * sunRect.area();
    const bool skyOn = p.sky.kind != SkyKind::None && p.sky.ambient > 0.0f;
    const float skyGain = p.sky.ambient;
    double skyPower = 0.0;
    if (skyOn) {
        constexpr int kDirs = 256;
        for (int k = 0; k < kDirs; ++k) {
            const vec3 d = kern::fibonacciDirection(k, kDirs);
            skyPower += double(meanComponent(skyRadiance(p.sky, d)) * skyGain) *
                        footprint(emit, d, centre).area() * (kFourPi / kDirs);
        }
    }
    const double sunMean = double(meanComponent(sunPower));
    const double total = sunMean + skyPower;
    if (!(total > 0.0)) return pv;
    const std::int64_t nSky =
        skyOn ? std::clamp<std::int64_t>(
                    std::int64_t(std::llround(double(p.photons) * skyPower / total)),
                    sunMean > 0.0 ? 0 : p.photons, p.photons)
              : 0;
    const std::int64_t nSun = p.photons - nSky;
    const float flux0 = float(total / double(p.photons));
    const vec3 sunWeight = nSun > 0 ? sunPower / (float(nSun) * flux0) : vec3(0.0f);
    const float skyWeight = nSky > 0 ? float(kFourPi / double(nSky)) * skyGain / flux0 : 0.0f;
    // a photon's start: its ray and its weight (relative to flux0)
    auto start = [&](std::int64_t i, Sampler& rng, Ray& ray, vec3& w) {
        if (i < nSun) {
            const float a = sunRect.lo.x + (sunRect.hi.x - sunRect.lo.x) * rng.next();
            const float b = sunRect.lo.y + (sunRect.hi.y - sunRect.lo.y) * rng.next();
            ray = Ray{centre + sunTo * (radius + 1.0f) + a * sunRect.u + b * sunRect.v, -sunTo};
            w = sunWeight;
            return;
        }
        // the sky: a uniform direction toward it, then a point of the rectangle seen from it
        const float z = 1.0f - 2.0f * rng.next();
        const vec3 d = kern::phaseDirection(vec3(0.0f, 0.0f, 1.0f), z, rng.next());
        const Footprint f = footprint(emit, d, centre);
        const float a = f.lo.x + (f.hi.x - f.lo.x) * rng.next();
        const float b = f.lo.y + (f.hi.y - f.lo.y) * rng.next();
        ray = Ray{centre + d * (radius + 1.0f) + a * f.u + b * f.v, -d};
        w = skyRadiance(p.sky, d) * (skyWeight * f.area());
    };
    const vec3 cellCentre0 = geo.bounds.lo + 0.5f * geo.voxel;

    const float invVolume = 1.0f / (geo.voxel.x * geo.voxel.y * geo.voxel.z);

    tbb::enumerable_thread_specific<Tally> tallies([&] {
        Tally t;
        t.sum.assign(3 * cells.size(), 0);
        return t;
    });
    // the hand-off's sums: one shared array of 64-bit integers (a photon adds to it once, at
    // the end of its walk; integer sums are the same in any order)
    const LightVolume* hg = p.handOff > 0 ? p.handOffGrid : nullptr;
    const size_t nh = hg ? size_t(hg->res.x) * hg->res.y * hg->res.z : 0;
    std::vector<std::atomic<std::int64_t>> handOffSum(3 * nh);
    for (auto& v : handOffSum) v.store(0, std::memory_order_relaxed);
    std::atomic<std::uint64_t> handedOff{0};
    const std::uint32_t key = kern::pcg(p.seed ^ 0x7f4a7c15u);
    tbb::parallel_for(
        tbb::blocked_range<std::int64_t>(0, p.photons, 256),
        [&](const tbb::blocked_range<std::int64_t>& r) {
            if (cancel && cancel->load(std::memory_order_relaxed)) return;
            Tally& tally = tallies.local();
            CancelPoll poll{cancel};
            for (std::int64_t i = r.begin(); i != r.end(); ++i) {
                Sampler rng{kern::pcg(key ^ kern::pcg(std::uint32_t(i) ^
                                                      kern::pcg(std::uint32_t(i >> 32)))),
                            0};
                Ray ray;
                vec3 w;
                start(i, rng, ray, w);
                if (poll.stopped) return;
                ++tally.traced;
                if (i >= nSun) ++tally.skyTraced;
                for (int depth = 0; depth < p.maxDepth; ++depth) {
                    float tmax = std::numeric_limits<float>::max();
                    SurfaceHit hit;
                    if (surfaces && surfaces->intersect(ray, depth ? 1e-4f : 0.0f, tmax, hit))
                        tmax = hit.t;
                    // the one untransformed volume: its majorant walk directly (no per-ray
                    // span bookkeeping), the placement's density folded into the bounds
                    const MajorantGrid* walkOn = !tracking.grid ? nullptr
                                                 : depth == 0   ? &first
                                                 : p.ownWalk    ? &walkGrid
                                                                : mg;
                    MajorantIterator walk(walkOn, vs.fields[0].bounds(), ray, 0.0f, tmax,
                                          vs.wholeMajorant[0]);
                    // delta tracking; the mean channel chooses the events, every channel keeps
                    // its own weight (for grey media the weight changes only by the albedo).
                    // The walk's events come at the rate of its grid (march's, or after a first
                    // scattering the own walk's raised bounds); the tracking thins them to the
                    // photons' own bounds (TrackingBounds), so that only its share costs a
                    // lookup, while the floor of the recording weight is still taken at every
                    // event (the same image in expectation, measured: docs/accuracy.md, stop 63)
                    const bool similar = similarOn && depth >= p.similarAfter;
                    const Coefficients& mc = similar ? similarMedium : real;
                    ScaledSegments segments{walk, placement, poll};
                    Run run;
                    float segT0 = -1.0f, segBound = 0.0f;
                    bool collided = false;
                    float tHit = 0.0f;
                    sampleTmaj(
                        segments, mc.tMax, rng,
                        [&](float t, const MajorantSegment& seg, float sigmaMaj) {
                            // the photons' bound in this segment's cell (once a segment)
                            if (seg.t0 != segT0) {
                                segT0 = seg.t0;
                                segBound =
                                    tracking.grid
                                        ? placement * tracking.at(ray.at(0.5f * (seg.t0 + seg.t1)))
                                        : seg.sigma_maj;
                            }
                            // The walk's events come at sigmaMaj; the tracking takes a
                            // share segBound / seg.sigma_maj of them (a Poisson process at
                            // its own bound's rate sigmaTrack) and looks the density up
                            // only there. The others are null collisions for certain.
                            const bool tracked =
                                segBound >= seg.sigma_maj ||
                                (segBound > 0.0f && rng.next() * seg.sigma_maj < segBound);
                            const float sigmaTrack = mc.tMax * segBound;
                            float density = 0.0f;
                            if (tracked) {
                                const float lookup = sampleVoxelCentres(
                                    fine, geo.bounds.lo, fineRes, fineVoxel, ray.at(t));
                                density = std::min(segBound, lookup);
                                ++tally.lookups;
                            }
                            if (depth >= (i < nSun ? p.sunRecordFrom : 1)) {
                                // light scattered at least once: record it toward the camera
                                const vec3 q = ray.at(t);
                                const ivec3 c = cellAt(geo.bounds.lo, geo.voxel, res, q);
                                const int k = active[voxelIndex(res, c.x, c.y, c.z)];
                                if (k != run.voxel) run.flush(tally);
                                if (k >= 0) {
                                    if (run.voxel < 0) {
                                        // the direction to the camera, and so the phase
                                        // function's value, is the voxel's for the whole run
                                        const vec3 toEye = glm::normalize(
                                            p.eye - (cellCentre0 + vec3(c) * geo.voxel));
                                        run.voxel = k;
                                        run.phase = phase.eval(glm::dot(ray.d, toEye));
                                    }
                                    // weighted by the density here (at the tracking's
                                    // events) plus the floor (at every event): the voxel
                                    // keeps int (rho / rhoBar + floor) S dV
                                    run.add(w *
                                            (kDensityFloor / sigmaMaj +
                                             (tracked ? density * invRhoBar / sigmaTrack : 0.0f)) /
                                            pv.skin(q));
                                }
                            }
                            if (!tracked) return true;
                            const float pReal = mc.tMean * density / sigmaTrack;
                            if (rng.next() < pReal) {
                                w *= mc.s / mc.tMean; // scattering, with the albedo
                                tHit = t;
                                collided = true;
                                return false;
                            }
                            if (pReal < 1.0f)
                                w *= (vec3(sigmaTrack) - mc.t * density) /
                                     (sigmaTrack * (1.0f - pReal));
                            return true;
                        });
                    run.flush(tally);
                    if (!collided) break; // left the volume (or hit a surface)
                    ++tally.scatterings;
                    if (hg && depth == p.handOff) {
                        // its (handOff + 1)-th scattering: the light it sends on is the
                        // diffusion grid's from here
                        const ivec3 c = cellAt(hg->bounds.lo, hg->voxel, hg->res, ray.at(tHit));
                        const size_t k = voxelIndex(hg->res, c.x, c.y, c.z);
                        const vec3 val = glm::min(w, vec3(kMaxDeposit));
                        for (int ch = 0; ch < 3; ++ch)
                            handOffSum[3 * k + ch].fetch_add(
                                std::int64_t(std::llround(double(val[ch]) * kFixed)),
                                std::memory_order_relaxed);
                        handedOff.fetch_add(1, std::memory_order_relaxed);
                        break;
                    }
                    // Russian roulette once absorption has taken weight
                    const float m = maxComponent(w);
                    if (m < 1.0f) {
                        if (rng.next() >= m) break;
                        w /= m;
                    }
                    const float u0 = rng.next(), u1 = rng.next();
                    if (similar) {
                        // a scattering of the similar medium: isotropic (the first flight in
                        // it keeps the direction the real phase function gave: its mean length,
                        // 1 / (sigma_t (1 - g)), is the real walk's progress along it)
                        ray = Ray{ray.at(tHit), kern::phaseDirection(ray.d, 1.0f - 2.0f * u0, u1)};
                        continue;
                    }
                    const PhaseSample ps = phase.sample(vec2(u0, u1));
                    if (!(ps.pdf > 0.0f)) break;
                    w *= ps.weight;
                    ray = Ray{ray.at(tHit), kern::phaseDirection(ray.d, ps.cosTheta, rng.next())};
                }
            }
        });

    // add the threads' sums (integers: the same total in any order), then scale by each
    // photon's flux over the voxel volume
    std::vector<std::int64_t> sum(3 * cells.size(), 0);
    for (Tally& t : tallies) {
        for (size_t k = 0; k < sum.size(); ++k) sum[k] += t.sum[k];
        pv.lookups += t.lookups;
        pv.traced += t.traced;
        pv.skyTraced += t.skyTraced;
        pv.scatterings += t.scatterings;
    }
    const vec3 flux(flux0);
    for (size_t k = 0; k < cells.size(); ++k)
        pv.radiance[cells[k]] =
            flux * (invVolume / norm[cells[k]]) *
            vec3(float(double(sum[3 * k]) / kFixed), float(double(sum[3 * k + 1]) / kFixed),
                 float(double(sum[3 * k + 2]) / kFixed));

    if (hg) {
        const float invHandOffVolume = 1.0f / (hg->voxel.x * hg->voxel.y * hg->voxel.z);
        pv.source.assign(nh, vec3(0.0f));
        for (size_t k = 0; k < nh; ++k)
            for (int ch = 0; ch < 3; ++ch)
                pv.source[k][ch] =
                    flux[ch] * invHandOffVolume *
                    float(double(handOffSum[3 * k + ch].load(std::memory_order_relaxed)) / kFixed);
        pv.handedOff = handedOff.load();
    }

    // voxels that do not record take the mean of their recording face neighbours, so that
    // trilinear lookups near the edge of the cloud do not blend toward zero
    std::vector<vec3> filled = pv.radiance;
    // what this trace held at its peak beyond the light-volume grid (photonBytes' parts)
    pv.bytes = double(active.size() * sizeof(int) + norm.size() * sizeof(float) +
                      pv.radiance.size() * sizeof(vec3) + filled.size() * sizeof(vec3) +
                      fine.size() * sizeof(float) + first.maj.size() * sizeof(float) +
                      walkGrid.maj.size() * sizeof(float) +
                      handOffSum.size() * sizeof(std::int64_t) + pv.source.size() * sizeof(vec3));
    tbb::parallel_for(0, res.z, [&](int z) {
        for (int y = 0; y < res.y; ++y)
            for (int x = 0; x < res.x; ++x) {
                const size_t i = voxelIndex(res, x, y, z);
                if (active[i] >= 0) continue;
                vec3 acc(0.0f);
                int count = 0;
                const ivec3 q(x, y, z);
                for (int f = 0; f < 6; ++f) {
                    ivec3 qn;
                    if (!faceNeighbour(res, q, f, qn)) continue;
                    const size_t j = voxelIndex(res, qn.x, qn.y, qn.z);
                    if (active[j] < 0) continue;
                    acc += pv.radiance[j];
                    ++count;
                }
                if (count) filled[i] = acc / float(count);
            }
    });
    pv.radiance = std::move(filled);
    return pv;
}

} // namespace nimbus
