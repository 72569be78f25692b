/// @file volume_render_baseline.h
/// @brief OpenVDB's own volume renderer (`openvdb::tools::VolumeRender` from
/// openvdb/tools/RayTracer.h, the code behind `vdb_render`) run on the very grid Nimbus renders,
/// set up to solve the same problem as Nimbus `march` in single scattering: the baseline of
/// `nimbus bench-vdb-render`.
///
/// What VolumeRender computes (OpenVDB 10.0, RayTracer.h, VolumeRender::operator()), per camera
/// ray, at samples t = k * primaryStep (k integer, in INDEX space, i.e. voxel units) inside the
/// segments of active tree nodes that the VolumeRayIntersector yields, with density rho (trilinear,
/// tools::BoxSampler) and sigma_t = scattering + absorption PER VOXEL LENGTH:
///
///     dT    = exp(-sigma_t rho primaryStep)
///     T_sun = prod over shadow samples s = k * shadowStep of exp(-sigma_t rho_s shadowStep /
///                                                               (1 + s * lightGain))
///     L    += lightColor * (scattering / sigma_t) * T_sun * T * (1 - dT);   T *= dT
///
/// skipping samples with rho < cutoff, and ending a ray once |T|^2 (the squared length of the RGB
/// transmittance) < cutoff; alpha = 1 - mean(T). That is Hillaire's energy-conserving single-
/// scattering step with a phase function identically 1 (not 1/(4 pi)), no sky, no multiple
/// scattering; `lightGain` > 0 (vdb_render's default 0.2) thins the shadow extinction with
/// distance to imitate multiple scattering. So Nimbus `march` with an isotropic phase
/// (1/(4 pi)), one octave, no in-scatter term, no sky and a transparent background solves the
/// same problem when VolumeRender gets
///  - lightColor = sun irradiance / (4 pi) and lightGain = 0,
///  - scattering / absorption = medium sigma_s / sigma_a * density_scale * field.density *
///    voxel size (VolumeRender integrates over index-space lengths; this needs uniform voxels,
///    which VolumeRayIntersector requires anyway),
///  - lightDir = the sun direction (both point toward the light),
///  - a PerspectiveCamera at the camera position turned with lookAt(look_at, up), aperture
///    41.2136 mm (Houdini's default) and the focal length that gives the same vertical field of
///    view at the film's aspect ratio (checked: the rays of both cameras agree to 1e-5 rad),
///  - steps in voxels (Nimbus steps are world lengths: divide by the voxel size).
/// What still differs: VolumeRender samples a fixed lattice without jitter (banding, a bias
/// that vanishes with the step). Its shadow samples sit at whole shadow steps from the point,
/// the first one a full step away, each weighted by a whole step: the sun's optical depth misses
/// about sigma_t * rho * shadowStep / 2 at the start, a first-order bias toward too much light
/// that dominates its error on smoke1 (Nimbus samples the middle of each step, or a jittered
/// point in it, from the point on). It marches the active nodes its intersector finds (as in
/// vdb_render: HDDA over upper internal nodes, clipped to the bounding box of the active leaf
/// nodes), Nimbus the box of the active voxels padded by one voxel (the density between is 0 for
/// both); its cutoff ignores densities below it and ends shadow rays early (a light leak of up to
/// sqrt(cutoff / 3) in transmittance).
/// Both converge to the same image as the steps shrink and the cutoff goes to 0.
#pragma once

#include <memory>
#include <string>

#include "core/bindings.h"
#include "core/image.h"
#include "core/scene.h"

namespace nimbus::vdb {

/// VolumeRender's knobs (vdb_render's defaults except lightGain).
struct VolumeRenderSettings {
    double primaryStep = 1.0; ///< voxels
    double shadowStep = 3.0;  ///< voxels
    double cutoff = 0.005;    ///< density threshold and early exit on |T|^2
    double lightGain = 0.0;   ///< VolumeRender's imitation of multiple scattering; 0 = off
    int threads = 0;          ///< TBB worker threads, 0 = all cores
};

/// The inputs VolumeRender gets for a Nimbus scene (see the file comment).
struct VolumeRenderProblem {
    double voxelSize = 1.0;    ///< world length of one voxel
    double focalLength = 50.0; ///< mm
    double aperture = 41.2136; ///< mm, horizontal film width
    vec3 eye{0.0f}, lookAt{0.0f}, up{0.0f, 1.0f, 0.0f};
    vec3 lightDir{0.0f, 1.0f, 0.0f}; ///< toward the light
    vec3 lightColor{0.0f};           ///< sun irradiance / (4 pi)
    vec3 scattering{0.0f};           ///< per voxel length and unit grid value
    vec3 absorption{0.0f};
    std::string describe() const; ///< one line per input
};

/// Maps a scene (camera, sun, medium, field density) to VolumeRender's inputs for a grid of
/// the given (uniform) voxel size. Pure: no OpenVDB.
VolumeRenderProblem volumeRenderProblem(const SceneDesc& scene, double voxelSize);

struct VolumeRenderTimes {
    double setupSeconds = 0.0;  ///< VolumeRayIntersector (topology copy, bounding box)
    double renderSeconds = 0.0; ///< VolumeRender::render
    double total() const { return setupSeconds + renderSeconds; }
};

/// Holds an OpenVDB copy of a scene's NanoVDB grid (converted back once with
/// nanovdb::nanoToOpenVDB: the same voxel values, active states, tiles and transform that Nimbus
/// samples) and renders it with VolumeRender.
class VolumeRenderBaseline {
  public:
    /// @throws std::runtime_error when the field is not a loaded, non-empty VDB grid or its
    ///         voxels are not uniform (VolumeRender measures steps in voxels).
    VolumeRenderBaseline(const VdbFieldDesc& vdb, const GridBinding& grid);
    ~VolumeRenderBaseline();
    VolumeRenderBaseline(const VolumeRenderBaseline&) = delete;
    VolumeRenderBaseline& operator=(const VolumeRenderBaseline&) = delete;

    double voxelSize() const;
    /// Renders the scene's camera view into fb (RGBA, premultiplied, alpha = 1 - mean T; no
    /// AOVs) with volumeRenderProblem(scene, voxelSize()).
    /// @throws std::runtime_error if the two cameras' rays disagree (a mapping bug).
    VolumeRenderTimes render(const SceneDesc& scene, const VolumeRenderSettings& settings,
                             Framebuffer& fb) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace nimbus::vdb
