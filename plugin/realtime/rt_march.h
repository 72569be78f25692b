/// @file rt_march.h
/// @brief The GLSL march pass: the CPU `march` integrator (core/integrators/march.h) on the GPU
/// for the procedural cumulus field, VDB grids and SDF clouds, one compute invocation per pixel,
/// through the same kernels.
///
/// The shader is assembled at run time from text embedded at build time: `#version 430`, the
/// frame's feature #defines (only the features the frame uses are compiled in: the sun's shadow
/// marches, the sky ambient, the sky background, several samples per pixel), the kernels
/// (core/kernels/source.h), plugin/realtime/march_params.glsl, march_data.glsl and
/// march_pass.glsl.
///
/// Supported (unsupported() names every key that leaves it): field.kind = "cumulus" with its noise
/// evaluated per sample, or, where the frame plan bakes it (plan.bakeNoise: field.evaluation =
/// "baked", or "auto" when the plan chooses to), read from the tiles the CPU baked (the same
/// floats in shader storage buffers, sampled as NoiseVolume::sample), or "vdb" (the NanoVDB float
/// grid the host loaded, in a shader storage buffer, read through PNanoVDB and sampled as
/// GridField::density: the same map, trilinear weights and density scale), one untransformed
/// volume, no surfaces or solids, render.integrator = "march", render.multiple_scattering = "none",
/// "grid" (the diffusion grid) or "photons" (the photon grid, with its skin profile when
/// render.photon_skin > 0, and the sky's diffusion grid), both grids computed on the CPU
/// (Renderer::marchGrids) and read from shader storage buffers, render.shadow = "march", the sky as
/// the height-occluded ambient (render.sky_scattering = "ambient", render.sky_occlusion = "height")
/// when there is no diffusion grid, every phase function (isotropic, hg, dual_hg, draine,
/// mie_approx, and the Lorenz-Mie table from a buffer), octaves, every in-scatter model, jitter,
/// pixel samples and filters, background sky or transparent, the transmittance and depth AOVs.
/// Empty space is skipped with the CPU's majorant grid of the frame when it is given (RT_SKIP:
/// samples in cells whose bound is 0 are not evaluated; the image is the same bit for bit);
/// without it every step in the field's box is taken.
///
/// @code
///   auto context = gl::ComputeContext::create(&error);
///   rt::MarchPass pass;
///   if (!pass.render(scene, plan, fb, stats, &error)) ...
/// @endcode
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/fields/cumulus.h"
#include "core/image.h"
#include "core/kernels/kernels.h"
#include "core/lighting/sky_volume.h"
#include "core/media/mie.h"
#include "core/plan.h"
#include "core/render.h"
#include "core/scene.h"
#include "plugin/realtime/gl_compute.h"

namespace nimbus::rt {

/// A setting of the scene the GLSL pass cannot render yet: the scene-file key and why.
struct Unsupported {
    std::string key;     ///< e.g. "field.kind"
    std::string message; ///< e.g. "field.kind = \"vdb\": the GLSL pass renders ... only"
};

/// Every setting of `scene` (and of its frame plan) that the GLSL pass does not support; empty
/// when it renders the frame as `march` would.
std::vector<Unsupported> unsupported(const SceneDesc& scene, const FramePlan& plan);

/// The features a frame's shader is compiled with (#define RT_... 0/1).
struct MarchFeatures {
    bool sun = false;           ///< RT_SUN: sun light, a shadow march per sample
    bool ambient = false;       ///< RT_AMBIENT: the sky ambient, occluded by height
    bool backgroundSky = false; ///< RT_BACKGROUND_SKY: the sky behind the clouds
    bool multisample = false;   ///< RT_MULTISAMPLE: render.pixel_samples > 1, filtered
    bool mieTable = false;      ///< RT_MIE_TABLE: the Lorenz-Mie table (with the sun only)
    bool diffusion = false;     ///< RT_MS_DIFFUSION: the diffusion grid (sun and sky, or sky)
    bool photons = false;       ///< RT_MS_PHOTONS: the photon grid (the sun's higher orders)
    bool photonSkin = false;    ///< RT_PHOTON_SKIN: render.photon_skin > 0 (with photons)
    bool vdb = false;           ///< RT_VDB: the field is a NanoVDB grid (PNanoVDB), not the cumulus
    bool bakedNoise = false;    ///< RT_BAKED_NOISE: the cumulus noise from the CPU's baked tiles
    /// RT_RGBA_NOISE (with RT_BAKED_NOISE): the tiles are RGBA8 in Olajos' channel layout
    /// (field.evaluation = "rgba"), 3D textures on units 4 and 5 filtered by the texture unit
    bool rgbaNoise = false;
    /// RT_SKIP: empty-space skipping over the frame's majorant grid (binding 13)
    bool skip = false;
    bool sdf = false; ///< RT_SDF: the field is an SDF cloud (its node array), not the cumulus
    /// RT_LIGHT_VOLUME: render.shadow = "volume" (with the sun): the sun's density integral read
    /// from the CPU's light-attenuation volume (binding 15) inside its bounds, as MarchContext
    /// reads it; a shadow march outside
    bool lightVolume = false;
    /// RT_GATE_VOLUME: the octave gate's density integral along the sun's line read from the
    /// same volume (binding 15) where the plan builds it (plan.gateVolume: the light volume, or
    /// the diffusion's sun source), as MarchContext reads it; a second shadow march outside
    bool gateVolume = false;
    /// RT_SKY_VOLUME: the single-scattered sky (render.sky_scattering = "single" or
    /// render.photon_sky) with render.sky_shadow = "volume": its directions and the CPU's sky
    /// volume (binding 7, skyVolumeBuffer), read as MarchContext::skySingleScatter reads them
    bool skyVolume = false;
    /// RT_FORWARD_DELTA: render.forward_scattering = "delta" in effect (plan.forwardFraction
    /// > 0): the sun's single scattering carried by a second transmittance under
    /// sigma_t - g^2 sigma_s, as MarchContext::traceRay carries it
    bool forwardDelta = false;
    /// RT_RESUMABLE: the march in slices of camera steps with the loop-budget check
    /// (march_pass.glsl, "The loop budget"); MarchPass sets it, marchFeatures and the export
    /// leave it off
    bool resumable = false;

    /// The #define lines.
    std::string defines() const;
    /// One key for the program cache.
    std::string key() const { return defines(); }
};

/// The features of frame `plan` of `scene`; `majorant`: the frame's majorant grid (majorantGrid),
/// RT_SKIP when it is given and skips (skipsWith).
MarchFeatures marchFeatures(const SceneDesc& scene, const FramePlan& plan,
                            const MajorantGrid* majorant = nullptr);

/// The majorant grid of frame `plan` for empty-space skipping (RT_SKIP, binding 13): the grid the
/// CPU renders the frame with (Renderer::volumesFor's grid of `field`: buildMajorantGrid at the
/// plan's majorant cell, padded), built as `nimbus render` builds it. Empty (no cells) when the
/// plan does not skip (render.skip_empty = false) or the frame has nothing to bound.
MajorantGrid majorantGrid(Renderer& renderer, const FramePlan& plan, const FrameBindings& bindings);
/// Whether the pass skips with `majorant` for frame `plan`: the plan skips empty space
/// (plan.skipEmpty) and the grid has cells, at least one of them with the bound 0, and its block
/// distances (MajorantGrid::buildBlocks).
bool skipsWith(const FramePlan& plan, const MajorantGrid* majorant);
/// The majorant grid as the shader reads it (binding 13, RT_SKIP): the bound of every cell, x
/// fastest, then the distance of every block of MajorantGrid::kBlock^3 cells as a float
/// (MajorantGrid::blockDistance, x fastest).
std::vector<float> majorantBuffer(const MajorantGrid& majorant);

/// The whole compute shader for `features`.
std::string marchShaderSource(const MarchFeatures& features);
/// Its first part, without the pass: #version, the #defines, the kernels, march_params.glsl and
/// march_data.glsl (the buffers and their lookups; with RT_VDB, PNanoVDB's GLSL text,
/// pnanovdbSource(), where march_data.glsl says `// @pnanovdb`). A test appends its own main() to
/// compare the lookups with the CPU's.
std::string marchDataShaderSource(const MarchFeatures& features);

/// The Lorenz-Mie table as the shader reads it (binding 3): per node (cos theta, R, G, B).
std::vector<glm::vec4> mieTableNodes(const MieTable& table);

/// The SDF cloud's tree as the shader reads it (binding 12, RT_SDF): SdfTree::gpuNodes of the
/// scene's field.kind = "sdf" tree (flattenSdf), postfix, root last; empty for other fields.
std::vector<kern::SdfTreeNode> sdfTreeNodes(const SceneDesc& scene);

/// The bytes of the field's NanoVDB grid as the shader reads them (binding 9, RT_VDB): the
/// nanovdb::FloatGrid of `bindings.grid(0)`, from its first byte, gridSize() bytes (PNanoVDB
/// finds the grid at address 0). Empty with *error when the scene's field has no loaded grid,
/// the grid is rendered shifted (core/rebase.h) or it is too large for 32-bit addresses.
struct VdbGridBytes {
    const void* data = nullptr;
    std::size_t size = 0;
};
VdbGridBytes vdbGridBytes(const FrameBindings* bindings, std::string* error);

/// The cumulus noise tiles the CPU baked (RT_BAKED_NOISE, bindings 10 and 11): the NoiseVolumes
/// Renderer::fieldFor samples (bakeCumulusBase / bakeCumulusDetail, baked once per sequence),
/// uploaded as they are: res^3 floats each, x fastest.
struct BakedNoise {
    std::shared_ptr<const NoiseVolume> base, detail;
};
/// The tiles of frame `plan` from `renderer` (the CPU's own, baked on first use as for `nimbus
/// render`); both null when the plan does not bake the noise.
BakedNoise bakedNoise(Renderer& renderer, const FramePlan& plan, const FrameBindings& bindings);
/// Why `noise` cannot serve a frame of `scene` whose plan bakes the noise: a tile missing, or
/// not at field.base_bake_resolution / detail_bake_resolution; "" when it can.
std::string bakedNoiseError(const SceneDesc& scene, const BakedNoise* noise);
/// Whether frame `plan` reads grids the CPU builds (Renderer::marchGrids): the diffusion or
/// photon grid (render.multiple_scattering), the sun's light-attenuation volume
/// (render.shadow = "volume") or the single-scattered sky's volume (render.sky_shadow =
/// "volume"). `nimbus rt` and the export build them only then.
inline bool readsMarchGrids(const FramePlan& plan) {
    return plan.diffusion || plan.photons || plan.lightVolume || plan.skyVolume;
}
/// Why frame `plan` of `scene` cannot be rendered or exported from `grids` and `noise`: a
/// multiple-scattering grid its features read is missing (named for `consumer`, e.g. "the GLSL
/// pass"), or its baked noise tiles (bakedNoiseError); "" when everything it reads is there.
std::string frameDataError(const SceneDesc& scene, const FramePlan& plan, const MarchGrids* grids,
                           const BakedNoise* noise, const std::string& consumer);
/// The single-scattered sky's buffer (RT_SKY_VOLUME, binding 7): for each of `sky`'s directions
/// w_k 8 floats, w_k and the sky's radiance L_k there times sky.ambient (as MarchContext takes
/// them), each padded to 4; then `sky`'s density integrals as SkyVolume holds them.
std::vector<float> skyVolumeBuffer(const SceneDesc& scene, const SkyVolume& sky);

/// A frame's shader as `nimbus rt` compiles it: the features and the assembled text.
struct MarchShader {
    MarchFeatures features;
    std::string source; ///< marchShaderSource(features)
};

/// The shader of frame `plan` of `scene`: what MarchPass::render compiles and what
/// `nimbus export-glsl` (plugin/realtime/export_glsl.h) preprocesses and writes.
MarchShader marchShader(const SceneDesc& scene, const FramePlan& plan,
                        const MajorantGrid* majorant = nullptr);

/// What `--explain` prints about the GPU pass of a frame: the features, the kernels and pass
/// files compiled in, and what is not done on the GPU.
std::string explainMarch(const SceneDesc& scene, const FramePlan& plan,
                         const MajorantGrid* majorant = nullptr);

/// The frame key of temporal-accumulation pass `pass` (0-based) of a frame whose key is
/// `frameKey` (RtMarchParams::frameKey, which seeds every jitter hash of the frame): pass 0
/// keeps the frame's own key, so one pass renders the frame `nimbus rt` renders without
/// accumulation; pass a > 0 gets a distinct key of the same pcg family, so the camera-ray
/// jitter, the shadow rays' jitter and the pixel-sample offsets of every pass are independent.
std::uint32_t accumulationKey(std::uint32_t frameKey, int pass);

/// Timings and counters of one GPU frame.
struct MarchStats {
    double compileSeconds = 0.0; ///< compiling the program (0 when it was cached)
    double frameSeconds = 0.0;   ///< parameter upload, dispatch, wait and read-back (all passes)
    double uploadSeconds = 0.0;  ///< of frameSeconds: the data's buffers made and filled
    double marchSeconds = 0.0;   ///< of frameSeconds: the work buffers, the dispatches, the wait
    double readSeconds = 0.0;    ///< of frameSeconds: the sums read back to the host
    /// the dispatches alone on the GPU's clock (GL_TIMESTAMP queries before and after each, summed
    /// over every pass and slice of the frame, the discarded renders' included): what the march
    /// costs the GPU, without the uploads, the work buffers' allocation and the read-back
    double gpuSeconds = 0.0;
    std::uint64_t nonFinite = 0; ///< pixels or samples that were NaN/Inf (as RenderStats)
    int sliceSteps = 0;          ///< camera steps per ray per dispatch the frame was rendered with
    int dispatches = 0;          ///< dispatches of the frame, the discarded renders' included
    int budgetRetries = 0; ///< renders discarded: llvmpipe's loop budget ran out (slices shrunk)
};

/// Renders frames with the GLSL march pass. Needs a current gl::ComputeContext; keeps one
/// compiled program per feature set.
class MarchPass {
  public:
    MarchPass();
    ~MarchPass();
    /// Renders frame `plan` of `scene` into fb (resized to the camera, the plan's AOVs). False
    /// with *error when the frame is unsupported (the first unsupported() message), the shader
    /// does not compile (its info log) or GL fails.
    bool render(const SceneDesc& scene, const FramePlan& plan, Framebuffer& fb, MarchStats& stats,
                std::string* error);
    /// The same with the frame's march grids (Renderer::marchGrids), which a frame with
    /// render.multiple_scattering = "grid" or "photons" needs: the pass uploads the diffusion
    /// and photon grids the CPU computed and reads them as MarchContext does. False with *error
    /// when the plan names a grid that `grids` lacks.
    bool render(const SceneDesc& scene, const FramePlan& plan, const MarchGrids* grids,
                Framebuffer& fb, MarchStats& stats, std::string* error);
    /// The same with what the host bound to the frame (host::Session::bindings): a VDB field's
    /// grid (field.kind = "vdb") is uploaded from there. False with *error when the field is a
    /// VDB grid and `bindings` holds none (vdbGridBytes).
    bool render(const SceneDesc& scene, const FramePlan& plan, const MarchGrids* grids,
                const FrameBindings* bindings, Framebuffer& fb, MarchStats& stats,
                std::string* error);
    /// The same with the noise tiles the CPU baked (bakedNoise), which a frame whose plan bakes
    /// the cumulus noise (RT_BAKED_NOISE) needs. False with *error when the plan bakes and
    /// `noise` lacks a tile or its resolution is not the scene's.
    bool render(const SceneDesc& scene, const FramePlan& plan, const MarchGrids* grids,
                const FrameBindings* bindings, const BakedNoise* noise, Framebuffer& fb,
                MarchStats& stats, std::string* error);
    /// The same with the frame's majorant grid (majorantGrid): where it skips (skipsWith) the
    /// shader is compiled with RT_SKIP and steps over the cells whose bound is 0 (the same image,
    /// fewer density lookups); null or empty: every step in the field's box is taken.
    bool render(const SceneDesc& scene, const FramePlan& plan, const MarchGrids* grids,
                const FrameBindings* bindings, const BakedNoise* noise,
                const MajorantGrid* majorant, Framebuffer& fb, MarchStats& stats,
                std::string* error);

    /// Temporal accumulation (`nimbus rt --accumulate N`): every frame rendered is the average
    /// of `passes` (at least 1) renders of it, each with its own jitter (accumulationKey); each
    /// pass dispatches every pixel sample. 1, the default, is one render as before.
    void setAccumulation(int passes) { accumulate_ = passes < 1 ? 1 : passes; }
    int accumulation() const { return accumulate_; }

    /// The march in slices (RT_RESUMABLE; march_pass.glsl, "The loop budget"): each dispatch
    /// takes at most this many camera steps per ray (kWholeRay: the whole ray in one dispatch).
    /// A render whose loop budget ran out anywhere is discarded and done again with slices a
    /// quarter as long (after the whole ray, 64 steps), down to 1 step; the slice found is kept
    /// for the next frames. False from render() when even 1 step is too much.
    static constexpr int kWholeRay = 1048576; // RT_MAX_STEPS (march_pass.glsl)
    void setSliceSteps(int steps) { sliceSteps_ = steps < 1 ? 1 : steps; }
    int sliceSteps() const { return sliceSteps_; }

  private:
    std::map<std::string, std::unique_ptr<gl::ComputeProgram>> programs_;
    /// the work buffers (the pixels' sums, the counters, the rays' state between slices): kept
    /// from frame to frame while the size holds, cleared on the GL's side before each render
    std::unique_ptr<gl::StorageBuffer> pixels_, counters_, slices_;
    int accumulate_ = 1;
    int sliceSteps_ = kWholeRay;
};

} // namespace nimbus::rt
