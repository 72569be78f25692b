/// @file photons.h
/// @brief The sun's (and with render.photon_sky the sky's) multiply scattered light for
/// `march`, by tracing photons: once per frame, photons leave the sun (and the sky), are tracked
/// through the real density field (delta tracking on the majorant segments, the same machinery as
/// pathtrace) and scatter by the phase function until they leave the volume; everything they travel
/// after their first scattering is recorded on a voxel grid as the light scattered toward the
/// camera.
///
/// Estimator (track length by null collisions): along a photon's path the tentative collisions
/// of delta tracking fall at rate sigma_maj, so summing w / sigma_maj at each of them estimates
/// the path's length through a voxel. A voxel thus collects
///   S(x) = 1/V sum_i Phi w_i p(omega_i . omega_cam) / sigma_maj,i,
/// the cell average of the in-scattered radiance int p(omega . omega_o) L_ms(x, omega) d omega
/// of the light that has scattered at least once, omega_o the direction from the voxel centre to
/// the camera (fixed per voxel: the camera is far from most voxels, and a voxel sees it under a
/// small angle). Phi = E_sun A / N is each photon's flux through A, the area of the rectangle
/// that covers the box holding density (the majorant grid's cells above 0) seen from the sun.
/// No spherical-harmonic truncation: the phase function is evaluated exactly, so forward
/// peaks and the Mie table's features are kept. The first scattering is left to march, which
/// integrates single scattering exactly; march adds sigma_s rho S(x) to it.
///
/// Skin profile: most of the error of a voxel average is near sunlit surfaces, where the light
/// scattered more than once is brightest within a few mean free paths and a voxel (0.23 km in
/// the default scene, 3 mean free paths) averages it with the darker inside. Photons record
/// their deposits divided by f(x) = max(exp(-k tau_sun(x)), floor), tau_sun the optical depth
/// toward the sun from the light volume, and the lookup multiplies f back: exact where the light
/// follows f inside a voxel, and close to the flat voxel's mean elsewhere (a ratio estimator). k
/// (`render.photon_skin` times sigma_t) is a model parameter, off by default: 0.2 sigma_t
/// measured best on the default scene (0.15-0.25 within 0.2% of it); on a homogeneous box with
/// voxels of two mean free paths it did not help.
///
/// Sums are kept in 64-bit fixed point per thread and added in any order to the same result:
/// the volume, and the frame, are bit-identical for a seed whatever the thread count.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/accel.h"
#include "core/geometry.h"
#include "core/lighting/light_volume.h"
#include "core/media/phase.h"
#include "core/media/sky.h"
#include "core/tracking/volumes.h"

namespace nimbus {

struct PhotonParams {
    vec3 sigma_s{1.0f}, sigma_a{0.0f}; ///< per unit density, density scale folded in
    vec3 sunDirection{0.0f, 1.0f, 0.0f};
    vec3 sunIrradiance{0.0f};
    vec3 eye{0.0f};           ///< camera position
    std::int64_t photons = 0; ///< photons leaving the sun
    int maxDepth = 1 << 20;   ///< scattering events per photon at most (pathtrace's max_depth)
    std::uint32_t seed = 0;
    /// Skin profile (see above): the density integral toward the sun, and the extinction per
    /// unit of it (0 = flat voxels)
    const LightVolume* sunTau = nullptr;
    float skinK = 0.0f;
    float skinFloor = 0.1f; ///< the profile's lower bound
    /// Hand-off to the diffusion grid (render.photon_bounces): a photon is traced through this
    /// many scatterings and recorded; at its next scattering the light it carries is added to
    /// `handOffGrid`'s voxel as emitted power (PhotonVolume::source) and its walk ends. 0 = none.
    int handOff = 0;
    const LightVolume* handOffGrid = nullptr;
    /// Sky photons (render.photon_sky): photons also leave the sky, from uniformly sampled
    /// directions over the rectangle that covers the bounds seen from there, each carrying
    /// skyRadiance times sky.ambient (not scaled by render.ms_strength, as the grid's sky is
    /// not); `photons` is shared between the sun and the sky in proportion to the power each
    /// sends through its rectangles. kind None = none.
    SkyDesc sky{SkyKind::None};
    /// Photons walk a majorant grid of their own, on the cells of the density grid they are
    /// tracked through (photonTrackingBounds), instead of march's (FramePlan::photonOwnWalk).
    /// March's grid bounds the density by tree nodes, often several times it; walking it,
    /// photons look the density up at the share of its events their own bounds keep, but every
    /// event records, which lowers the noise of a voxel's light where voxels are optically
    /// shallow. In a thick smoke walking it took 19 events a collision.
    bool ownWalk = false;
    /// After this many scatterings a photon walks the similar medium (0 = never; the plan asks
    /// it where photons walk a grid of their own, FramePlan::photonSimilarity): isotropic
    /// scattering at sigma_s (1 - g), sigma_a as it is, g the phase function's mean cosine (the
    /// similarity relation; nothing changes where g <= 0). Its first flight keeps the direction
    /// the real phase function gave, its mean length 1 / (sigma_t (1 - g)) the real walk's mean
    /// progress along it; after that each scattering turns it isotropically. The diffusion is
    /// the same (the transport mean free path and the absorption per unit length are kept) at
    /// 1 - g times the scatterings, and with them the tentative collisions and lookups. What a
    /// voxel records keeps the real phase function toward the camera: for radiance that has
    /// diffused (isotropic plus a current) that is the same in-scattered light. What changes is
    /// the light within a few mean free paths of a surface, below a voxel that is several mean
    /// free paths deep (docs/accuracy.md, "Photons in the similar medium").
    int similarAfter = 0;
    /// The sun's photons record from this scattering on (1: all the light they carry after
    /// their first; FramePlan::secondDepth where march's paths take the orders up to it,
    /// FramePlan::secondShare). The sky's photons always record from their first.
    int sunRecordFrom = 1;
};

struct PhotonVolume {
    Box bounds;
    ivec3 res{0};
    vec3 voxel{0.0f};
    /// In-scattered radiance toward the camera per unit phase-normalised scattering, at voxel
    /// centres: the voxel's mean weighted by the density (plus a floor of 0.3 times the mean
    /// density of the voxels with density at their centre), what march's samples scatter
    /// (voxels that do not record: the mean of their recorded neighbours)
    std::vector<vec3> radiance;
    const LightVolume* sunTau = nullptr; ///< skin profile (may be null: flat)
    float skinK = 0.0f, skinFloor = 0.1f;
    /// The skin profile at p: max(exp(-skinK tau_sun(p)), skinFloor), or 1.
    float skin(vec3 p) const {
        return sunTau && skinK > 0.0f ? std::max(std::exp(-skinK * sunTau->sample(p)), skinFloor)
                                      : 1.0f;
    }
    /// With a hand-off: the power the photons' next scatterings emit per unit volume, at the
    /// voxels of PhotonParams::handOffGrid (the diffusion grid's source); else empty
    std::vector<vec3> source;
    std::uint64_t handedOff = 0; ///< photons whose walk went on in the diffusion grid
    std::uint64_t lookups = 0;   ///< density lookups spent (filling its density grid, tracking)
    std::uint64_t traced = 0;    ///< photons that left a light (fewer than asked when cancelled)
    std::uint64_t skyTraced = 0; ///< of them, those that left the sky (PhotonParams::sky)
    /// scatterings of their walks (each of the similar medium's counting one)
    std::uint64_t scatterings = 0;
    /// Bytes the trace held beyond the light-volume grid's (photonBytes' parts, from the arrays'
    /// sizes; the sums of the voxels that record excepted); the caller adds a density grid of
    /// their own. 0 when it returned before tracking (nothing to trace).
    double bytes = 0.0;

    /// Trilinear lookup at world point p, times the skin profile there.
    vec3 sample(vec3 p) const;
};

/// The voxels per axis of the density grid photons are tracked through over `bounds`, cells of
/// `trackingCell` (photonTrackingCell chooses it).
ivec3 photonTrackingResolution(const Box& bounds, float trackingCell);

/// The cell of the density grid photons are tracked through: half the majorant grid's smallest
/// cell `majorantCell` (the photon grid's voxel `photonCell` without a majorant grid, 0), or the
/// photon voxel where that is finer, so that photons see the density at the resolution they
/// record the light at; coarser again (by 2) while the grid over `bounds` would exceed
/// kMaxTrackingVoxels. On the validation matrix's medium backlit rows, photons on voxels of
/// half a VDB voxel tracked through cells of one VDB voxel were 16.1% and 12.8% off
/// (blender_mantaflow, gaffer_fogsphere_small), through cells of their own voxel 10.4% and 9.0%
/// (docs/accuracy.md, "The photons' voxel and the density they are tracked through").
constexpr double kMaxTrackingVoxels = 33554432.0; // 2^25: 128 MiB of floats
float photonTrackingCell(const Box& bounds, float majorantCell, float photonCell);

/// The photons' own density bounds, one per cell of the majorant grid `mg` they walk: each the
/// largest of the tracking grid's values (`fine`: `res` centres lo + (i + 0.5) voxel) that a
/// trilinear lookup (sampleVoxelCentres) anywhere in the cell, grown by 5% of it, can read, and
/// at most the cell's own bound (0 where that is 0). `mg` bounds the field by its tree nodes'
/// maxima where `march` builds it (it only skips empty space with it), often several times the
/// density; tracePhotons walks `mg` and thins its events to these bounds, so that only the
/// events it keeps cost a lookup. On the tracking grid's own cells (`mg`'s bounds unlimited)
/// they are the grid of their own walk (PhotonParams::ownWalk).
std::vector<float> photonTrackingBounds(const MajorantGrid& mg, const std::vector<float>& fine,
                                        vec3 lo, ivec3 res, vec3 voxel);

/// What FramePlan::photonGridBytes counts for photons on a grid of `res` voxels over `bounds`,
/// tracked through cells of `trackingCell` under a majorant grid of `majorantCells` cells (0:
/// none), with a density grid of their own or not and a hand-off grid of `handOffVoxels` voxels
/// (0: none): per photon-grid voxel an index, its density weight, the radiance and its filled
/// copy (and a density), per tracking cell a density, per majorant cell the photons' own bound
/// or, walking a grid of their own (`ownWalk`), two bounds per tracking cell, per hand-off voxel
/// its sums (three 64-bit integers) and its source (RGB). The sums of the voxels that record
/// (three 64-bit integers each, per thread and merged) come on top.
double photonBytes(const Box& bounds, ivec3 res, float trackingCell, double majorantCells,
                   bool ownWalk, bool ownDensity, double handOffVoxels);

/// Traces p.photons photons through `volumes` (one untransformed volume: its grid is `geometry`,
/// the light-volume grid, with densities rho at its voxel centres, which mark the voxels that
/// record). Surfaces (may be null) stop photons. Returns early (volume left partial) when
/// `cancel` becomes true.
PhotonVolume tracePhotons(const VolumeSet& volumes, const PhaseFunction& phase,
                          const LightVolume& geometry, const std::vector<float>& rho,
                          const PhotonParams& p, const SurfaceQuery* surfaces = nullptr,
                          const std::atomic<bool>* cancel = nullptr);

} // namespace nimbus
