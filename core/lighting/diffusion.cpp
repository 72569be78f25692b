#include "core/lighting/diffusion.h"

#include "core/cancel.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>

namespace nimbus {

namespace {

constexpr float kFourPi = 12.5663706144f;

/// One voxel with density: its neighbours (-1 = empty space, folded into rhs and diagonal),
/// the conductances to them, 1 / diagonal and the constant part of its balance.
struct Cell {
    std::uint32_t idx;
    int nb[6];
    vec3 G[6];
    vec3 invDiag, rhs;
};

} // namespace

vec3 DiffusionVolume::sample(vec3 p) const {
    return sampleVoxelCentres(phi, bounds.lo, res, voxel, p);
}

vec3 DiffusionVolume::sample(vec3 p, vec3 grad[3]) const {
    vec3 u = (p - bounds.lo) / voxel - vec3(0.5f);
    u = glm::clamp(u, vec3(0.0f), vec3(res - ivec3(1)));
    const ivec3 i0 = glm::min(ivec3(u), res - ivec3(1));
    const ivec3 i1 = glm::min(i0 + ivec3(1), res - ivec3(1));
    const vec3 f = u - vec3(i0);
    auto at = [&](int x, int y, int z) { return phi[voxelIndex(res, x, y, z)]; };
    const vec3 c000 = at(i0.x, i0.y, i0.z), c100 = at(i1.x, i0.y, i0.z);
    const vec3 c010 = at(i0.x, i1.y, i0.z), c110 = at(i1.x, i1.y, i0.z);
    const vec3 c001 = at(i0.x, i0.y, i1.z), c101 = at(i1.x, i0.y, i1.z);
    const vec3 c011 = at(i0.x, i1.y, i1.z), c111 = at(i1.x, i1.y, i1.z);
    const vec3 c00 = glm::mix(c000, c100, f.x), c10 = glm::mix(c010, c110, f.x);
    const vec3 c01 = glm::mix(c001, c101, f.x), c11 = glm::mix(c011, c111, f.x);
    const vec3 c0 = glm::mix(c00, c10, f.y), c1 = glm::mix(c01, c11, f.y);
    // a clamped axis (one voxel, or outside the outer centres) has no slope
    const vec3 dx = glm::mix(glm::mix(c100 - c000, c110 - c010, f.y),
                             glm::mix(c101 - c001, c111 - c011, f.y), f.z) /
                    voxel.x;
    const vec3 dy = glm::mix(c10 - c00, c11 - c01, f.z) / voxel.y;
    const vec3 dz = (c1 - c0) / voxel.z;
    for (int c = 0; c < 3; ++c) grad[c] = vec3(dx[c], dy[c], dz[c]);
    return glm::mix(c0, c1, f.z);
}

/// The power the sun's beam leaves in voxel q (index i) per unit irradiance: the beam's net
/// flux through the voxel's six faces, (w . n) A T summed with its sign: in through the faces
/// toward the sun, out through the others. A face's transmittance T = e^{-sigma* tau} is that of
/// the voxel on its sun side, the density integral at that voxel's centre plus its density over
/// the half step l / 2 along the sun's path to the face, so that two neighbours read the same
/// value for the face they share and the sources of all voxels add up to what the beam loses in
/// the grid (a face of the grid's box toward the sun lets in the whole beam: no density lies
/// outside it; a voxel that takes no part in the solve counts as empty space, its density
/// integral aside). sigmaStar is the beam's extinction per unit density (the forward peak kept
/// in it taken out).
static vec3 sunFaceFlux(const LightVolume& geo, ivec3 q, size_t i, const std::vector<float>& rho,
                        const std::vector<int>& active, const std::vector<float>& tauSun,
                        vec3 sunDir, vec3 sigmaStar, float halfPath) {
    vec3 net(0.0f);
    for (int f = 0; f < 6; ++f) {
        const int a = f / 2;
        const float wn = ((f & 1) ? 1.0f : -1.0f) * sunDir[a]; // w . n, n the face's outward normal
        if (wn == 0.0f) continue;
        float tau = tauSun[i] + rho[i] * halfPath; // leaving: this voxel is on the sun side
        if (wn > 0.0f) {
            ivec3 qn;
            tau = 0.0f; // the face of the grid's box toward the sun
            if (faceNeighbour(geo.res, q, f, qn)) {
                const size_t j = voxelIndex(geo.res, qn.x, qn.y, qn.z);
                tau = tauSun[j] + (active[j] >= 0 ? rho[j] * halfPath : 0.0f);
            }
        }
        const float A = geo.voxel[(a + 1) % 3] * geo.voxel[(a + 2) % 3];
        net += wn * A * glm::exp(-sigmaStar * tau);
    }
    return glm::max(net, vec3(0.0f));
}

static vec3 boundaryResistance(vec3 r) {
    return glm::min(r, vec3(kDiffusionMaxBoundaryResistance));
}

/// A voxel's first-scattered sun light Q V raises its own fluence by Q V / (sum of its face
/// conductances): at most (kDiffusionMaxBoundaryResistance + 2) E in a voxel lit through a face
/// toward empty space. A voxel whose neighbours on all six faces hold density can still see the sun
/// through an edge or a corner of the light volume's interpolation (its tau toward the sun that of
/// its own half path); many mean free paths thick, its faces' conductances vanish and its fluence
/// grew with sigma_t (4e5 E at density x1e6). Its source is limited to what would raise its
/// fluence to that of a sunlit boundary voxel; where conductances are large (voxels of a few mean
/// free paths or thinner) the limit is never reached.
constexpr float kSunFluenceLimit = kDiffusionMaxBoundaryResistance + 2.0f;

/// The vectors of one value per voxel with density that the solve holds: the fluence, the
/// residual, the search direction and the operator applied to it.
constexpr int kSolveVectors = 4;

using dvec3 = glm::dvec3;

/// Sums f(k) over [0, n) in a fixed order of fixed blocks, whatever the number of threads, so
/// that a solve gives the same bits every time. T: dvec3, or Sums for two at once.
template <class T = dvec3, class F> T sumCells(size_t n, F f) {
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<size_t>(0, n, 4096), T{},
        [&](const tbb::blocked_range<size_t>& br, T acc) {
            for (size_t k = br.begin(); k != br.end(); ++k) acc = acc + f(k);
            return acc;
        },
        [](const T& a, const T& b) { return a + b; }, tbb::simple_partitioner());
}

/// Two per-channel sums taken in one pass: r . z (z the preconditioned residual) and r . r.
struct Sums {
    dvec3 rz{0.0}, rr{0.0};
    Sums operator+(const Sums& o) const { return {rz + o.rz, rr + o.rr}; }
};

/// The balance of cell k for the fluence x: diagonal x_k - sum of G x_neighbour.
static vec3 applyCell(const std::vector<Cell>& cells, const std::vector<vec3>& x, size_t k) {
    const Cell& c = cells[k];
    vec3 y = x[k] / c.invDiag;
    for (int f = 0; f < 6; ++f)
        if (c.nb[f] >= 0) y -= c.G[f] * x[size_t(c.nb[f])];
    return y;
}

/// Conjugate gradients preconditioned by the diagonal, one system per channel: the matrix is
/// symmetric (a face's conductance is the same seen from both sides) and positive definite
/// (every connected part of the medium touches empty space or absorbs), so the iteration
/// converges; it stops when the residual's norm has fallen below `tolerance` of the
/// right-hand side's in every channel. Red-black SOR with a stop on the relative change of an
/// iteration, used before, stopped far from the answer on fine grids of thin clouds, where the
/// fluence is nearly uniform and its level, set by the little the boundary lets out, is the
/// slowest mode to settle (docs/accuracy.md); conjugate gradients finds that mode in a few
/// iterations, and the residual says how far from the answer the iteration still is.
static void solveCells(const std::vector<Cell>& cells, std::vector<vec3>& x,
                       const DiffusionParams& p, DiffusionVolume& dv) {
    const size_t n = cells.size();
    if (n == 0) return;
    std::vector<vec3> r(n), d(n), q(n);
    auto dot = [](vec3 a, vec3 b) { return dvec3(a) * dvec3(b); };
    const dvec3 bb = sumCells(n, [&](size_t k) { return dot(cells[k].rhs, cells[k].rhs); });
    dvec3 rz = sumCells(n, [&](size_t k) {
        r[k] = cells[k].rhs - applyCell(cells, x, k);
        d[k] = r[k] * cells[k].invDiag;
        return dot(r[k], d[k]);
    });
    const double tol2 = double(p.tolerance) * double(p.tolerance);
    auto residual = [&](dvec3 rr) {
        double worst = 0.0;
        for (int c = 0; c < 3; ++c)
            if (bb[c] > 0.0)
                worst = std::max(worst, rr[c] / bb[c]);
            else if (rr[c] > 0.0)
                worst = std::max(worst, 1.0);
        return worst;
    };
    dvec3 rr = sumCells(n, [&](size_t k) { return dot(r[k], r[k]); });
    dv.residual = float(std::sqrt(residual(rr)));
    for (int it = 0; it < p.maxIterations && residual(rr) > tol2; ++it) {
        if (cancelRequested(p.cancel)) break;
        const dvec3 dq = sumCells(n, [&](size_t k) {
            q[k] = applyCell(cells, d, k);
            return dot(d[k], q[k]);
        });
        vec3 alpha(0.0f);
        for (int c = 0; c < 3; ++c) alpha[c] = dq[c] > 0.0 ? float(rz[c] / dq[c]) : 0.0f;
        const Sums next = sumCells<Sums>(n, [&](size_t k) {
            x[k] += alpha * d[k];
            r[k] -= alpha * q[k];
            return Sums{dot(r[k], r[k] * cells[k].invDiag), dot(r[k], r[k])};
        });
        rr = next.rr;
        vec3 beta(0.0f);
        for (int c = 0; c < 3; ++c) beta[c] = rz[c] > 0.0 ? float(next.rz[c] / rz[c]) : 0.0f;
        rz = next.rz;
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096),
                          [&](const tbb::blocked_range<size_t>& br) {
                              for (size_t k = br.begin(); k != br.end(); ++k)
                                  d[k] = r[k] * cells[k].invDiag + beta * d[k];
                          });
        dv.iterations = it + 1;
        dv.residual = float(std::sqrt(residual(rr)));
    }
    dv.converged = residual(rr) <= tol2;
    // the answer of an M-matrix with a right-hand side >= 0 is >= 0; the iterate, short of it,
    // may dip below in a voxel
    tbb::parallel_for(size_t(0), n, [&](size_t k) { x[k] = glm::max(x[k], vec3(0.0f)); });
}

double diffusionBytes(ivec3 res, double activeVoxels, bool source) {
    const double n = double(res.x) * res.y * res.z;
    return n * (sizeof(int) + sizeof(vec3)) +
           activeVoxels *
               (sizeof(Cell) + kSolveVectors * sizeof(vec3) + (source ? sizeof(vec3) : 0));
}

DiffusionVolume solveDiffusion(const LightVolume& geo, const std::vector<float>& rho,
                               const std::vector<float>& tauSun, const DiffusionParams& p) {
    DiffusionVolume dv;
    dv.bounds = geo.bounds;
    dv.res = geo.res;
    dv.voxel = geo.voxel;
    const ivec3 res = geo.res;
    const size_t n = size_t(res.x) * res.y * res.z;
    const vec3 sigmaTr = p.sigma_a + p.sigma_s * (1.0f - p.g); // transport extinction
    const vec3 sigmaT = p.sigma_a + p.sigma_s;
    const bool sun = maxComponent(p.sunIrradiance) > 0.0f && tauSun.size() == n;
    // sky fluence 4 pi L seen through a face, by outward normal: -x +x -y +y -z +z
    const vec3 skyFace[6] = {kFourPi * p.skySide, kFourPi * p.skySide, kFourPi * p.skyDown,
                             kFourPi * p.skyUp,   kFourPi * p.skySide, kFourPi * p.skySide};
    const vec3 skyMean = kFourPi * 0.5f * (p.skyUp + p.skyDown);
    const float V = geo.voxel.x * geo.voxel.y * geo.voxel.z;
    // the length of the sun's path across a voxel (along the dominant axis, as the light volume
    // propagates it: its centres hold the density integral to half of it)
    const vec3 ad = glm::abs(p.sunDirection);
    const int sa = ad.x >= ad.y && ad.x >= ad.z ? 0 : (ad.y >= ad.z ? 1 : 2);
    const float sunPath = geo.voxel[sa] / std::max(ad[sa], 1e-6f);
    // the sun's beam: its extinction with the forward peak kept in it, and the share of what it
    // loses that scatters into the diffuse field
    const vec3 sigmaStar = sigmaT - p.forwardFraction * p.sigma_s;
    const vec3 albedoStar =
        p.sigma_s * (1.0f - p.forwardFraction) / glm::max(sigmaStar, vec3(1e-30f));

    // the voxels with density, coloured red/black by the parity of x + y + z; a voxel whose
    // diffusion resistance is below kDiffusionMinResistance along every axis and in every
    // channel counts as empty space (see diffusion.h)
    const float thinRho = kDiffusionMinResistance / (1.5f * maxComponent(geo.voxel) *
                                                     std::max(maxComponent(sigmaTr), 1e-30f));
    std::vector<int> active(n, -1);
    std::vector<Cell> cells;
    for (int z = 0; z < res.z; ++z)
        for (int y = 0; y < res.y; ++y)
            for (int x = 0; x < res.x; ++x) {
                const size_t i = voxelIndex(res, x, y, z);
                if (rho[i] > 0.0f && rho[i] >= thinRho) {
                    active[i] = int(cells.size());
                    cells.push_back(Cell{std::uint32_t(i), {}, {}, vec3(0.0f), vec3(0.0f)});
                }
            }
    dv.activeVoxels = cells.size();
    // an external source (the photons' hand-off) per active voxel, the share of an inactive
    // voxel split among its active face neighbours (lost where it has none)
    std::vector<vec3> extra;
    if (p.source && p.source->size() == n) {
        extra.assign(cells.size(), vec3(0.0f));
        for (size_t i = 0; i < n; ++i) {
            const vec3 q = (*p.source)[i];
            if (maxComponent(q) <= 0.0f) continue;
            if (active[i] >= 0) {
                extra[size_t(active[i])] += q * V;
                continue;
            }
            const ivec3 c(int(i % res.x), int((i / res.x) % res.y),
                          int(i / (size_t(res.x) * res.y)));
            int nb[6], count = 0;
            for (int f = 0; f < 6; ++f) {
                ivec3 qn;
                if (!faceNeighbour(res, c, f, qn)) continue;
                const int j = active[voxelIndex(res, qn.x, qn.y, qn.z)];
                if (j >= 0) nb[count++] = j;
            }
            for (int m = 0; m < count; ++m) extra[size_t(nb[m])] += q * V / float(count);
        }
    }
    tbb::parallel_for(size_t(0), cells.size(), [&](size_t k) {
        Cell& c = cells[k];
        const size_t i = c.idx;
        const int x = int(i % res.x), y = int((i / res.x) % res.y),
                  z = int(i / (size_t(res.x) * res.y));
        // h / 2D = 1.5 h sigma_t' per axis
        const vec3 sTr = sigmaTr * rho[i];
        vec3 diag = p.sigma_a * rho[i] * V, rhs(0.0f), sunQ(0.0f);
        const ivec3 q(x, y, z);
        if (sun) {
            sunQ = p.sunIrradiance * albedoStar *
                   sunFaceFlux(geo, q, i, rho, active, tauSun, p.sunDirection, sigmaStar,
                               0.5f * sunPath);
            rhs += sunQ;
        }
        for (int f = 0; f < 6; ++f) {
            const int a = f / 2, b = (a + 1) % 3, cc = (a + 2) % 3;
            const float h = geo.voxel[a], A = geo.voxel[b] * geo.voxel[cc];
            ivec3 qn;
            const bool inside = faceNeighbour(res, q, f, qn);
            const int j = inside ? active[voxelIndex(res, qn.x, qn.y, qn.z)] : -1;
            const vec3 ri = 1.5f * h * sTr;
            if (j >= 0) {
                const vec3 rj = 1.5f * h * sigmaTr * rho[cells[j].idx];
                c.nb[f] = j;
                c.G[f] = A / (ri + rj + vec3(1e-30f));
                diag += c.G[f];
            } else {
                // Marshak: no light comes back from empty space but the sky's
                c.nb[f] = -1;
                const vec3 Gb = A / (boundaryResistance(ri) + vec3(2.0f));
                diag += Gb;
                rhs += Gb * skyFace[f];
                c.G[f] = vec3(0.0f);
            }
        }
        // the first-scattered sun light, limited to what raises the voxel's own fluence by
        // kSunFluenceLimit E (subtracting 0 where the limit is not reached keeps rhs exact)
        if (sun) rhs -= glm::max(vec3(0.0f), sunQ - kSunFluenceLimit * p.sunIrradiance * diag);
        if (!extra.empty()) rhs += extra[k];
        c.invDiag = 1.0f / diag;
        c.rhs = rhs;
    });

    std::vector<vec3> phi(cells.size(), skyMean);
    solveCells(cells, phi, p, dv);

    // fluence at every voxel centre: solved where there is density; in empty voxels next to
    // the medium the mean of the Marshak face values phi_f = 4 pi L + 2 (phi - 4 pi L) / (r + 2)
    // of their neighbours, elsewhere the sky's mean fluence
    dv.phi.assign(n, skyMean);
    tbb::parallel_for(0, res.z, [&](int z) {
        for (int y = 0; y < res.y; ++y)
            for (int x = 0; x < res.x; ++x) {
                const size_t i = voxelIndex(res, x, y, z);
                if (active[i] >= 0) {
                    dv.phi[i] = phi[active[i]];
                    continue;
                }
                vec3 sum(0.0f);
                int count = 0;
                const ivec3 q(x, y, z);
                for (int f = 0; f < 6; ++f) {
                    const int a = f / 2;
                    ivec3 qn;
                    if (!faceNeighbour(res, q, f, qn)) continue;
                    const int j = active[voxelIndex(res, qn.x, qn.y, qn.z)];
                    if (j < 0) continue;
                    // the neighbour's face toward this voxel has the opposite normal
                    const vec3 L = skyFace[f ^ 1];
                    const vec3 r =
                        boundaryResistance(1.5f * geo.voxel[a] * sigmaTr * rho[cells[j].idx]);
                    sum += L + 2.0f * (phi[j] - L) / (r + vec3(2.0f));
                    ++count;
                }
                if (count) dv.phi[i] = sum / float(count);
            }
    });
    dv.bytes = double(active.size() * sizeof(int) + cells.size() * sizeof(Cell) +
                      extra.size() * sizeof(vec3) + kSolveVectors * phi.size() * sizeof(vec3) +
                      dv.phi.size() * sizeof(vec3));
    return dv;
}

} // namespace nimbus
