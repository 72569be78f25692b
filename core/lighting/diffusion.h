/// @file diffusion.h
/// @brief Multiple scattering as a diffusion process on a grid (Stam 1995, "Multiple scattering
/// as a diffusion process", EGWR), for `march`: the fluence of the light that has scattered at
/// least once, from the sun and the sky, solved once per frame and read trilinearly.
///
/// Unknown: the fluence phi (RGB) at the centres of the light-attenuation volume's voxels that
/// hold density. Equation (diffusion approximation of the radiative transfer equation, with the
/// similarity relation sigma_s' = sigma_s (1 - g) of van de Hulst for anisotropic scattering):
///   -div(D grad phi) + sigma_a phi = Q,   D = 1 / (3 sigma_t'),   sigma_t' = sigma_a + sigma_s',
/// Q = sigma_s E_sun e^{-sigma_t tau_sun}, the sun light scattered for the first time (the
/// single scattering itself is integrated exactly by march). A voxel's source is what the sun's
/// beam loses in it, taken from the beam's net flux through its six faces (in through those
/// toward the sun, out through the others), a face's transmittance that of the voxel on its sun
/// side: neighbours read the same value for the face they share, so the sources add up to the
/// power the beam loses in the grid, whichever faces the light comes in through. A voxel many
/// mean free paths thick holds the light its lit faces let in, where a value at its centre
/// (e^{-sigma_t tau}, the sun's light scatters in its first mean free path) held almost none,
/// and a source along the light volume's dominant axis alone missed the light entering through
/// the faces beside it (29-66% of the power kept on the matrix's thick front-lit clouds,
/// docs/accuracy.md). Finite volumes on the voxel grid; between two voxels the
/// flux is (phi_i - phi_j) / (h / 2D_i + h / 2D_j); a face toward empty space takes Marshak's
/// boundary condition with the sky's radiance L_sky seen through that face as the incoming partial
/// current, which gives the flux (phi_i - 4 pi L_sky) / (h / 2D_i + 2). An albedo-1 medium under a
/// uniform sky thus solves to phi = 4 pi L_sky everywhere: the white furnace holds exactly. Solved
/// by conjugate gradients with a diagonal preconditioner, stopped on the residual.
///
/// march then adds phi / 4 pi (isotropic in-scattered radiance) to the exact single scattering
/// of the sun; the sky needs no separate ambient term.
#pragma once

#include <atomic>

#include <vector>

#include "core/geometry.h"
#include "core/lighting/light_volume.h"

namespace nimbus {

/// The diffusion resistance h / 2D = 1.5 h sigma_t' between a voxel's centre and a face toward
/// empty space is taken at most this: that of two transport mean free paths. The sun's first
/// scattering, which the voxel's unknown stands for, happens within a mean free path or so of the
/// lit surface, and so does the escape of the light scattered there; half a voxel many mean free
/// paths thick held that light behind a resistance growing with sigma_t h, and the fluence with it
/// (radiance 6,490 for a sun of irradiance 3 at density x1e6, docs/stress.md). Voxels thinner
/// than two transport mean free paths, the usual case, are unchanged.
constexpr float kDiffusionMaxBoundaryResistance = 3.0f;

/// A voxel whose diffusion resistance 1.5 h sigma_t' rho is below this along every axis and in
/// every channel (an optical thickness under 1/1500 of a transport mean free path) takes no
/// part in the solve: it counts as empty space. Between two such voxels the conductance
/// A / (r_i + r_j) grows without bound as the density falls, so a faint halo of them around a
/// cloud (the residue of advection, a VDB's long tail) conducted light around the cloud's
/// surface and out through the halo's larger outer area, and made the system so stiff that the
/// SOR used then stopped on its relative-change test far from the answer (docs/accuracy.md, "A
/// near-empty halo"). Their own scattering is still integrated by march; their multiple scattering
/// is a second-order effect of a density this thin.
constexpr float kDiffusionMinResistance = 1e-3f;

struct DiffusionParams {
    vec3 sigma_s{1.0f}, sigma_a{0.0f}; ///< per unit density, density scale folded in
    float g = 0.0f;                    ///< mean cosine of the phase function
    /// the fraction of scattering that stays in the sun's beam (march's forward peak,
    /// render.forward_scattering): the source is the light leaving a beam attenuated by
    /// sigma_t - f sigma_s, sigma_s (1 - f) of it per unit length; 0 = every first scattering
    float forwardFraction = 0.0f;
    vec3 sunIrradiance{0.0f}; ///< 0 = no sun
    /// Emitted power per unit volume at each voxel of the grid, added to the sun's source (the
    /// photons' hand-off, core/lighting/photons.h); null or of another size = none. What falls
    /// in a voxel that takes no part in the solve goes to its neighbours that do.
    const std::vector<vec3>* source = nullptr;
    vec3 sunDirection{0.0f, 1.0f, 0.0f}; ///< toward the sun (unit)
    /// Sky radiance seen through a face of a voxel, by the face's outward normal: up, down,
    /// sideways (the isotropic radiance carrying the sky's current into the face:
    /// skyBoundaryRadiance, core/media/sky.h); 0 = no sky.
    vec3 skyUp{0.0f}, skyDown{0.0f}, skySide{0.0f};
    int maxIterations = 2000;
    /// stop when the residual's norm is below this share of the right-hand side's, per channel
    float tolerance = 1e-5f;
    const std::atomic<bool>* cancel = nullptr; ///< stop iterating once set (core/cancel.h)
};

struct DiffusionVolume {
    Box bounds;
    ivec3 res{0};
    vec3 voxel{0.0f};
    std::vector<vec3> phi; ///< fluence at voxel centres (empty voxels: their faces' values)
    int iterations = 0;
    float residual = 0.0f; ///< the residual's norm over the right-hand side's (worst channel)
    /// the residual reached DiffusionParams::tolerance (false: stopped by maxIterations or a
    /// cancel first)
    bool converged = true;
    std::size_t activeVoxels = 0;
    /// Bytes the solve held at its peak (diffusionBytes' parts, from the arrays' sizes)
    double bytes = 0.0;

    /// Trilinear lookup of the fluence at world point p.
    vec3 sample(vec3 p) const;
    /// The same with the gradient of the trilinear interpolant (per channel: d/dx, d/dy, d/dz).
    vec3 sample(vec3 p, vec3 grad[3]) const;
};

/// What FramePlan::diffusionBytes counts for a solve on a grid of `res` voxels of which
/// `activeVoxels` hold density: per voxel an index and the fluence it returns, per voxel with
/// density its cell (neighbours, conductances, diagonal, right-hand side), its fluence while
/// iterating and its entry in a colour list, and with a hand-off (`source`) its share of the
/// photons' source.
double diffusionBytes(ivec3 res, double activeVoxels, bool source);

/// Solves on the grid of `geometry` (bounds, res, voxel) with densities rho at its voxel
/// centres and the density integral toward the sun tauSun (may be empty when there is no sun).
DiffusionVolume solveDiffusion(const LightVolume& geometry, const std::vector<float>& rho,
                               const std::vector<float>& tauSun, const DiffusionParams& p);

} // namespace nimbus
