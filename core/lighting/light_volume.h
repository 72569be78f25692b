/// @file light_volume.h
/// @brief Precomputed sun attenuation: the density integral toward the sun, propagated slice
/// by slice through a grid along the dominant axis of the sun direction (Fizimayer 2008, after
/// the shear-warp light attenuation of Dobashi et al.), then read trilinearly while marching
/// instead of a shadow march per sample.
///
/// Each voxel stores tau(q) = integral of density from q toward the sun. Slice k is computed
/// from slice k-1 (one voxel closer to the sun): tau(q) = tau(q') + (rho(q) + rho(q')) / 2 * l,
/// with q' = q + sunDir * l the point where the light ray to q crosses the previous slice plane
/// (bilinear in that slice), l = voxel size along the axis / |sunDir[axis]|. Light entering
/// through a side face has crossed no density (none lies outside the field bounds). Storing the
/// density integral rather than a transmittance keeps it valid for RGB extinction, octaves and
/// the powder term.
#pragma once

#include <atomic>

#include <vector>

#include "core/fields/field.h"
#include "core/tracking/majorant.h"

namespace nimbus {

struct LightVolume {
    Box bounds;
    ivec3 res{0};
    vec3 voxel{0.0f};
    std::vector<float> tau; ///< density integral toward the sun at voxel centres, x fastest
    std::size_t densityLookups = 0;

    /// Trilinear lookup of the density integral toward the sun at world point p.
    float sample(vec3 p) const;
};

/// The densities of `field` at the centres of a grid of `res` voxels over `bounds` (x fastest);
/// voxels whose centre lies in a cell the majorant grid (if given) proves empty stay 0 and are
/// not evaluated. Adds the lookups made to `lookups`. TBB-parallel. Stops early (the rest left
/// 0) once `cancel` is set (core/cancel.h).
std::vector<float> densityAtCentres(const Field& field, const Box& bounds, ivec3 res,
                                    const MajorantGrid* grid, std::size_t& lookups,
                                    const std::atomic<bool>* cancel = nullptr);

/// Voxels per axis of a light volume over `bounds` with voxels of about `cell`: at least 2.
ivec3 lightVolumeResolution(const Box& bounds, float cell);

/// The voxel grid the light volumes of `field` use for voxels of about `cell` world units: the
/// field's bounds, at least 2 voxels per axis; `tau` left empty.
LightVolume lightVolumeGrid(const Field& field, float cell);

/// lightVolumeGrid(field, cell) with the densities at its voxel centres in `rho`
/// (densityAtCentres; its lookups counted in the grid's densityLookups).
LightVolume densityGrid(const Field& field, float cell, const MajorantGrid* grid,
                        std::vector<float>& rho, const std::atomic<bool>* cancel = nullptr);

/// densityGrid's voxels (the same lattice) cropped to those that meet `within`, with one more
/// on every side (within the field's bounds): a grid of fine voxels for a small cloud in wide
/// bounds (photons on their own grid) holds the cloud, not its bounds. The whole grid where
/// `within` is empty or does not overlap the bounds.
LightVolume densityGridWithin(const Field& field, float cell, const Box& within,
                              const MajorantGrid* grid, std::vector<float>& rho,
                              const std::atomic<bool>* cancel = nullptr);

/// Fills lv.tau with the density integral toward `direction` from the densities `rho` at its
/// voxel centres (the slice-by-slice propagation described above). Stops early once `cancel`
/// is set.
void propagateDensityIntegral(LightVolume& lv, const std::vector<float>& rho, vec3 direction,
                              const std::atomic<bool>* cancel = nullptr);

/// Builds the volume over field.bounds() with voxels of about `cell` world units. Cells the
/// majorant grid (if given) proves empty are not evaluated. TBB-parallel within each slice.
LightVolume buildLightVolume(const Field& field, vec3 sunDirection, float cell,
                             const MajorantGrid* grid = nullptr);

/// The same for several directions at once: the densities at the voxel centres are looked up
/// once and shared (densityLookups is counted on the first volume only). Stops early (the
/// volumes incomplete) once `cancel` is set.
std::vector<LightVolume> buildLightVolumes(const Field& field, const std::vector<vec3>& dirs,
                                           float cell, const MajorantGrid* grid = nullptr,
                                           std::vector<float>* rhoOut = nullptr,
                                           const std::atomic<bool>* cancel = nullptr);

} // namespace nimbus
