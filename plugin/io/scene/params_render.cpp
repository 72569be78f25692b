/// @file params_render.cpp
/// @brief Scene-file parameter table: the rows of [render] (see table.h).
#include "core/plan.h"
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addRenderParams(std::vector<Param>& t) {
    const Section<RenderDesc> ren{"render",
                                  [](Staging& s) -> RenderDesc& { return s.file.scene.render; }};
    auto pathtrace = [](const SceneFile& f) {
        return f.scene.render.integrator == Integrator::PathTrace;
    };
    auto marching = [](const SceneFile& f) {
        return f.scene.render.integrator == Integrator::March;
    };
    auto photonsOn = [](const SceneFile& f) {
        return f.scene.render.multipleScattering == MultipleScattering::Photons ||
               f.scene.render.multipleScattering == MultipleScattering::Auto;
    };
    t.push_back(ren.param(
        "integrator",
        WordTable<Integrator>{{"march", Integrator::March}, {"pathtrace", Integrator::PathTrace}},
        "march: fast single-scattering ray marching with approximations "
        "(production); pathtrace: unbiased multiple scattering (references).",
        &RenderDesc::integrator));
    t.push_back(
        ren.param("spp", closed(1, 1 << 20), "Path-traced samples per pixel.", &RenderDesc::spp)
            .usedWhen("render.integrator = \"pathtrace\"", pathtrace));
    t.push_back(ren.param("max_depth", closed(1, 1 << 20),
                          "Scattering events per path (and per photon) at most (1 = single "
                          "scattering). A walk in a thick albedo-1 cloud can take hundreds of "
                          "thousands: the default, the most allowed, lets one through a cloud 500 "
                          "mean free paths across end by leaving it; the old default of 256 took "
                          "4-14% of the light of such clouds' references (docs/accuracy.md, "
                          "stop 72). Lower it to trade that light for time.",
                          &RenderDesc::maxDepth)
                    .usedWhen("render.integrator = \"pathtrace\" or "
                              "render.multiple_scattering = \"photons\" or \"auto\"",
                              [=](const SceneFile& f) { return pathtrace(f) || photonsOn(f); }));
    t.push_back(ren.param("rr_depth", closed(1, 1 << 20),
                          "Russian roulette (unbiased path termination) from this depth on.",
                          &RenderDesc::rrDepth)
                    .usedWhen("render.integrator = \"pathtrace\"", pathtrace));
    t.push_back(ren.param("shadow_roulette", {},
                          "pathtrace: trace the sun's shadow ray from a scattering point with a "
                          "probability from the precomputed density integral toward the sun "
                          "(weighted by its inverse: unbiased), so points deep in thick cloud "
                          "skip most of them; one untransformed volume only.",
                          &RenderDesc::shadowRoulette)
                    .usedWhen("render.integrator = \"pathtrace\"", pathtrace));
    t.push_back(ren.param("sky_nee", {},
                          "pathtrace: sample the sky by next-event estimation too (uniform "
                          "directions, a shadow ray each, MIS with phase sampling); off = the "
                          "sky through phase-sampled rays alone (lower noise for less work on "
                          "smooth skies: docs/accuracy.md).",
                          &RenderDesc::skyNee)
                    .usedWhen("render.integrator = \"pathtrace\"", pathtrace));
    t.push_back(ren.param("shadow",
                          WordTable<ShadowMethod>{{"march", ShadowMethod::March},
                                                  {"volume", ShadowMethod::Volume}},
                          "Sun transmittance for march: a shadow march per sample, or a "
                          "light-attenuation volume propagated slice by slice along the sun "
                          "(Fizimayer 2008) and read trilinearly.",
                          &RenderDesc::shadow)
                    .usedWhen("render.integrator = \"march\"", marching));
    t.push_back(
        ren.param("light_volume_cell", atLeast(0),
                  "Voxel size of the light-attenuation volumes (sun shadows, multiple "
                  "scattering, column sky occlusion, single-scattered sky; world "
                  "units); 0 = the majorant cell, or finer where the diffusion grid carries "
                  "the multiple scattering (multiple_scattering \"grid\", or \"auto\" "
                  "choosing it): the finest of 1/8 to 1 majorant cell at which the "
                  "cloud fills at most 262,144 cells (--explain says which).",
                  &RenderDesc::lightVolumeCell)
            .usedWhen("render.shadow = \"volume\", render.multiple_scattering = "
                      "\"grid\" or \"photons\", render.sky_occlusion = "
                      "\"column\" or render.sky_shadow = \"volume\"",
                      [](const SceneFile& f) {
                          const RenderDesc& r = f.scene.render;
                          return r.shadow == ShadowMethod::Volume ||
                                 r.multipleScattering != MultipleScattering::None ||
                                 r.skyOcclusion == SkyOcclusion::Column ||
                                 (r.skyScattering == SkyScattering::Single &&
                                  r.skyShadow == SkyShadow::Volume);
                      }));
    auto hasVdb = [](const SceneFile& f) {
        return f.scene.field.kind == FieldKind::Vdb || !f.scene.volumes.empty();
    };
    t.push_back(ren.param("step", atLeast(0),
                          "Primary ray-march step (world units); 0 = chosen per frame: "
                          "`step_voxels` x the finest voxel of the VDB grids the scene places, "
                          "or 0.05 for procedural fields (`--explain` and the EXR's frame plan "
                          "say which and why).",
                          &RenderDesc::step)
                    .scalesWithStep());
    t.push_back(ren.param("step_voxels", above(0),
                          "Primary step of VDB volumes when `step` is 0, in voxels of the finest "
                          "placed grid (OpenVDB's vdb_render: 1). Measured on three VDB files: "
                          "the step error is below 1% of the image from 1 voxel on.",
                          &RenderDesc::stepVoxels)
                    .scalesWithStep()
                    .usedWhen("render.step = 0 and the scene has a VDB volume",
                              [hasVdb](const SceneFile& f) {
                                  return f.scene.render.step == 0.0f && hasVdb(f);
                              }));
    t.push_back(
        ren.param("step_tau", atLeast(0),
                  "Splits thick march steps, camera and shadow rays alike: a step whose "
                  "optical depth (at the largest density of its sample and the samples "
                  "before and after it; on camera rays also at the density bound of the "
                  "majorant-grid cells the step reaches into, so that a cloud's edge seen "
                  "grazing between two samples is not missed) times the transmittance in "
                  "front of it exceeds "
                  "this is taken as that many sub-steps (jittered apart), at most 64. "
                  "A step's light is looked at where its transmittance puts it, right in "
                  "the mean for a constant density however thick the step; but one "
                  "density sample stands for the whole step (wrong on coarse VDB voxels "
                  "and at a cloud's edge) and one light sample is noisy. 0 = never split. "
                  "Measured on "
                  "the validation matrix in single scattering: 0.5 took the medium "
                  "clouds' median error from 24% to 7.6% and the thick ones' from 83% "
                  "to 15% for 1.02-1.16x the density lookups. Where photons carry the sun's "
                  "multiple scattering, render.photon_step_tau takes its place.",
                  &RenderDesc::stepTau)
            .usedWhen("render.integrator = \"march\"", marching));
    t.push_back(ren.param("step_growth", atLeast(0),
                          "Distance-adaptive steps: step = max(step, step_growth * distance).",
                          &RenderDesc::stepGrowth)
                    .scalesWithStep()
                    .marchOnly());
    t.push_back(ren.param("jitter", {},
                          "Offset the samples within each step by a random fraction per pixel "
                          "(trades banding for noise); off = step midpoints.",
                          &RenderDesc::jitter));
    t.push_back(ren.param("pixel_samples", closed(1, 4096),
                          "Camera rays per pixel for march, stratified over the filter's width "
                          "and weighted by the filter; 1 = one ray through the pixel centre.",
                          &RenderDesc::pixelSamples)
                    .usedWhen("render.integrator = \"march\"", marching));
    t.push_back(ren.param("filter",
                          WordTable<PixelFilter>{{"box", PixelFilter::Box},
                                                 {"gaussian", PixelFilter::Gaussian},
                                                 {"blackman_harris", PixelFilter::BlackmanHarris}},
                          "Pixel reconstruction filter weighting the samples of a pixel (march "
                          "with pixel_samples > 1, pathtrace with jitter on).",
                          &RenderDesc::filter));
    t.push_back(ren.param("filter_width", closed(0.5, 8),
                          "Width of the pixel filter in pixels (box 1 = the pixel itself; "
                          "gaussian and blackman_harris reach into the neighbours from 2 on).",
                          &RenderDesc::filterWidth));
    t.push_back(ren.param("epsilon", closedOpen(0, 1),
                          "Stop marching when the transmittance falls below this.",
                          &RenderDesc::epsilon)
                    .marchOnly());
    t.push_back(ren.param("shadow_step", atLeast(0),
                          "First shadow-ray step (world units); 0 = chosen per frame like `step`, "
                          "from `shadow_step_voxels` (0.05 for procedural fields).",
                          &RenderDesc::shadowStep)
                    .scalesWithStep()
                    .marchOnly());
    t.push_back(ren.param("shadow_step_voxels", above(0),
                          "First shadow step of VDB volumes when `shadow_step` is 0, in voxels of "
                          "the finest placed grid (OpenVDB's vdb_render: 3; measured on three VDB "
                          "files, 3 had 1.8-3.2x the error of 1 for about 20% less time).",
                          &RenderDesc::shadowStepVoxels)
                    .scalesWithStep()
                    .usedWhen("render.shadow_step = 0 and the scene has a VDB volume",
                              [hasVdb](const SceneFile& f) {
                                  return f.scene.render.shadowStep == 0.0f && hasVdb(f);
                              })
                    .marchOnly());
    t.push_back(ren.param("shadow_growth", atLeast(0),
                          "Shadow steps grow geometrically by this factor.",
                          &RenderDesc::shadowGrowth)
                    .marchOnly());
    t.push_back(ren.param("skip_empty", {}, "Skip empty space with the majorant grid.",
                          &RenderDesc::skipEmpty));
    t.push_back(
        ren.param("sdf_trace", {},
                  "field.kind = \"sdf\": skip the empty space around the cloud by sphere "
                  "tracing its distance bound; false = the majorant grid (for "
                  "comparison).",
                  &RenderDesc::sdfTrace)
            .usedWhen("render.skip_empty = true and field.kind = \"sdf\"", [](const SceneFile& f) {
                return f.scene.render.skipEmpty && f.scene.field.kind == FieldKind::Sdf;
            }));
    t.push_back(ren.param("hierarchical_skip", {},
                          "Instanced volumes: find the instance boxes a ray crosses (Embree), then "
                          "walk each volume's own majorant grid; false = one coarse world grid "
                          "over all instances (for comparison).",
                          &RenderDesc::hierarchicalSkip)
                    .usedWhen("render.skip_empty = true",
                              [](const SceneFile& f) { return f.scene.render.skipEmpty; }));
    t.push_back(ren.param("majorant_cell", atLeast(0),
                          "Majorant grid cell size (world units); 0 = chosen by the plan.",
                          &RenderDesc::majorantCell)
                    .usedWhen("render.skip_empty = true",
                              [](const SceneFile& f) { return f.scene.render.skipEmpty; }));
    auto multiple = [](const SceneFile& f) { return f.scene.render.octaves > 1; };
    t.push_back(ren.param("octaves", closed(1, 16),
                          "Multiple-scattering octaves (Wrenninge 2015): octave i adds the sun "
                          "term again with scaled weight, optical depth and g; 1 = single "
                          "scattering only.",
                          &RenderDesc::octaves)
                    .marchOnly());
    t.push_back(ren.param("octave_extinction", closed(0, 1),
                          "Sun optical depth of octave i is scaled by octave_extinction^i.",
                          &RenderDesc::octaveExtinction)
                    .calibratedOver({0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9})
                    .usedWhen("render.octaves > 1", multiple)
                    .marchOnly());
    t.push_back(ren.param("octave_contribution", closed(0, 1),
                          "Weight of octave i is octave_contribution^i; at most "
                          "`octave_extinction` (energy conservation).",
                          &RenderDesc::octaveContribution)
                    .calibratedOver({0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9})
                    .usedWhen("render.octaves > 1", multiple)
                    .marchOnly());
    t.push_back(ren.param("octave_eccentricity", closed(0, 1),
                          "Phase asymmetry g of octave i is scaled by octave_eccentricity^i.",
                          &RenderDesc::octaveEccentricity)
                    .calibratedOver({0.0, 0.25, 0.5, 0.75, 1.0})
                    .usedWhen("render.octaves > 1", multiple)
                    .marchOnly());
    t.push_back(ren.param("octave_gate", closed(0, 16),
                          "Octaves above the first fade where the cloud along the sun's line "
                          "through the sample is optically thin: weighted by 1 - exp(-octave_gate "
                          "sigma_s tau), tau the density integral toward the sun plus the one away "
                          "from it: read from the sun-depth volume where the frame builds one "
                          "(render.shadow = \"volume\", or the diffusion grid's sun source) where "
                          "the sun's line leaves it, else a second shadow march per sample. "
                          "Octaves calibrated on a "
                          "thick cloud otherwise add multiply scattered light to thin ones; 0.25 "
                          "(the default scene's setting) took its thin cases on the validation "
                          "matrix from 33-42% to 4-11% relative RMSE, its thick ones unchanged, "
                          "for 1.27x its frame time when it marched (2026-11-29). 0 = off.",
                          &RenderDesc::octaveGate)
                    .usedWhen("render.octaves > 1", multiple)
                    .marchOnly());
    t.push_back(
        ren.param("multiple_scattering",
                  WordTable<MultipleScattering>{{"none", MultipleScattering::None},
                                                {"grid", MultipleScattering::Grid},
                                                {"photons", MultipleScattering::Photons},
                                                {"auto", MultipleScattering::Auto}},
                  "Sun light scattered more than once and sky light: none (octaves and "
                  "the sky term of `sky_scattering` only); grid: solved once per frame as a "
                  "diffusion process on the light-volume grid (Stam 1995; similarity "
                  "relation for g, Marshak boundaries lit by the sky), read trilinearly; "
                  "it replaces the sky ambient term, octaves add to it; photons: the "
                  "sun's part from `render.photons` photons traced through the field "
                  "once per frame and recorded on the light-volume grid toward the "
                  "camera (no octaves, nothing to calibrate), the sky's from the "
                  "diffusion grid; auto: photons where the cloud's mean optical depth "
                  "along the sun, measured each frame, is at most `render.photon_depth` "
                  "(1000), or where the medium absorbs enough that its "
                  "diffuse light reaches no deeper than that (1 / sqrt(3 (1 - a)(1 - a g)) "
                  "mean free paths: 3.4 at albedo 0.9 and g 0.8, at any thickness), the grid "
                  "elsewhere (`--explain` and the frame's "
                  "log line say which); where it chooses photons and the medium absorbs "
                  "(albedo below 1 in a channel), the sky's light is traced by photons too "
                  "(as `render.photon_sky`, with twice `render.photons` and at least 16 M; "
                  "not in `nimbus rt`, "
                  "whose GPU march keeps the grid's sky). A sequence whose cloud crosses "
                  "photon_depth "
                  "switches model between frames: name the model for such a sequence.",
                  &RenderDesc::multipleScattering)
            .marchOnly());
    t.push_back(
        ren.param("photon_depth", atLeast(0),
                  "multiple_scattering = \"auto\": the cloud's mean optical depth "
                  "along the sun (over the rays toward the sun that meet density) up to "
                  "which photons carry the sun's multiple scattering; above it the "
                  "diffusion grid does. In a medium that absorbs, the depth compared is "
                  "the one its diffuse light reaches before absorption takes it, 1 / "
                  "sqrt(3 (1 - a)(1 - a g)) mean free paths (a the albedo of the channel "
                  "that absorbs least, g the phase function's mean cosine), where that "
                  "is less: photons' walks end there whatever the cloud's depth. Photons "
                  "are exact up to their grid's voxel and "
                  "their cost grows with the depth (the pass of 2 M photons on smoke1, 2 cores: "
                  "2.4 s at 4, 15 s at 64, 25 s at 500, 37 s at 1000, 59 s at 2000; "
                  "\"auto\" traces 8 M from a depth of 8); the grid costs the same "
                  "at any depth but misses the forward multiple scattering of thin "
                  "clouds and the light near the skin of thick ones (on the validation "
                  "matrix's thick albedo-1 clouds, 500 deep: photons 13 of 27 cases "
                  "within 10%, the grid none; docs/accuracy.md, \"Photons for thick "
                  "clouds\"). 0 = always the grid.",
                  &RenderDesc::photonDepth)
            .usedWhen("render.multiple_scattering = \"auto\"",
                      [](const SceneFile& f) {
                          return f.scene.render.multipleScattering == MultipleScattering::Auto;
                      })
            .marchOnly());
    auto gridOn = [](const SceneFile& f) {
        return f.scene.render.multipleScattering != MultipleScattering::None;
    };
    t.push_back(
        ren.param("photons", closed(0, 1 << 30),
                  "Photons traced from the sun per frame (multiple_scattering = "
                  "\"photons\", or \"auto\" where it chooses them; with "
                  "render.photon_sky shared with the sky, and \"auto\" tracing the sky "
                  "too traces twice this many, with 0 at least 16 M on voxels sized for "
                  "twice the count below); their noise falls "
                  "as 1 / sqrt(photons), their cost grows with them and with the "
                  "cloud's depth. 0 = chosen per frame by the cloud's mean optical depth "
                  "along the sun tau: 2 M up to tau 2, 1 M per unit of tau above, 8 M from tau 8 "
                  "(the frame's log line says how many). On the "
                  "validation matrix's medium VDB clouds 8 M took 42 of 48 cases within "
                  "10% against 31 at 2 M, for 4x the photons' time; on its thin ones 8 M "
                  "gained little "
                  "(docs/accuracy.md, \"Photons by the cloud's depth\").",
                  &RenderDesc::photons)
            .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
            .marchOnly());
    t.push_back(ren.param("photon_skin", closed(0, 4),
                          "Photons: how the sun's multiply scattered light falls off inside a "
                          "voxel of the light-volume grid, brightest under the sunlit surface: as "
                          "max(exp(-photon_skin sigma_t tau), 0.1) with tau the density integral "
                          "toward the sun. Photons record the light divided by this profile and "
                          "march multiplies it back at each sample: the voxel's light keeps about "
                          "its mean and takes this shape. 0 = flat over the voxel. A model "
                          "parameter, like the octaves: on the default scene at 640x360 (4 M "
                          "photons) 0.2 measured 9.0% relative RMSE against 10.0% flat; on a "
                          "homogeneous box with voxels of two mean free paths it did not help.",
                          &RenderDesc::photonSkin)
                    .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
                    .marchOnly());
    t.push_back(
        ren.param("photon_cell_scale", closed(0, 4),
                  "The voxel of the grid photons record on, in light-volume cells: 1 = "
                  "that grid itself; below 1 a finer grid of their own, for the light "
                  "near lit surfaces and in small clouds, noisier per voxel (it needs "
                  "more photons) and larger. 0 = chosen each frame, the finer of: the "
                  "finest of 1/4, 1/2, 1, 2 and 4 at which the cloud fills at most "
                  "render.photons / 256 voxels, and the finest of 1/8 ... 4 (1/16 ... 4 "
                  "where the cloud's mean optical depth along the sun is above 2) at "
                  "which it fills at most the photons reaching it (render.photons times the share "
                  "of rays along the sun over the box holding density that meet it) / 20 "
                  "(a small cloud gets a fine grid, a wide cloud layer a coarse one); "
                  "photons are tracked through "
                  "the density on a grid of that voxel (half the majorant cell at most). "
                  "Where the voxel is finer than the light-volume cell the diffusion grid "
                  "carrying the sky is solved on a finer grid too (no finer than the first "
                  "rule). On the validation matrix at 2 M photons this measured 25 of the "
                  "54 medium cases within 10% (the first rule alone: 13) and 52 of the 54 "
                  "thin ones (docs/accuracy.md, \"Photons where the cloud is thin or "
                  "medium\", \"The photons' voxel and the density they are tracked "
                  "through\").",
                  &RenderDesc::photonCellScale)
            .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
            .marchOnly());
    t.push_back(
        ren.param("photon_step_tau", atLeast(0),
                  "render.step_tau where photons carry the sun's multiple scattering (\"photons\", "
                  "or \"auto\" where it chooses them): march splits its steps more finely "
                  "there, since the photons' light is close enough to exact that the single "
                  "scattering's step error shows (the grid's own error hides it). 0 = never split. "
                  "On the validation matrix's thin and medium VDB rows 0.125 measured 92 of 96 "
                  "within 10% (worst 10.7%) against 91 (12.3%) at 0.5, for 1.07x their march "
                  "time; on the default scene's grid 0.125 would have cost 2x a frame "
                  "(docs/accuracy.md, \"Finer steps where photons carry the light\").",
                  &RenderDesc::photonStepTau)
            .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
            .marchOnly());
    t.push_back(
        ren.param("photon_second_share", closed(0, 1),
                  "Where photons carry the sun's multiple scattering (\"photons\", or \"auto\" "
                  "where it chooses them), march estimates the sun's light scattered exactly "
                  "twice itself, by paths of two vertices from its samples (a direction from "
                  "the phase function, a flight to a collision, the sun's shadow march there), "
                  "about 1 / share of them per camera ray, each standing for that share of the "
                  "ray's light; the photons then record from their second scattering on (paths "
                  "to render.photon_march_depth and the photons above it where their voxel is "
                  "deeper than an absorbing medium's diffuse light reaches). A "
                  "photon voxel averages that light over a depth the camera does not see, most "
                  "where a thin edge is lit from behind. Not in a cloud at most 2 mean free "
                  "paths deep along the sun, where the voxels hold that light well. 0 = the "
                  "photons carry it everywhere (as in the GLSL port). On the validation matrix "
                  "0.002 took the thick rows to 20 of 54 within 10% (16 at 0), median 12.1% "
                  "(14.7%), the worst case (a thick smoke lit from behind, albedo 0.9) 62.5% "
                  "to 44.2%, and the medium ones to 48 of 54 (46); a thick smoke at 320x180 "
                  "took 1.37x the frame (docs/accuracy.md, \"The sun's second scattering by "
                  "march\").",
                  &RenderDesc::photonSecondShare)
            .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
            .marchOnly());
    t.push_back(
        ren.param("photon_march_depth", closed(2, 64),
                  "With photon_second_share, where the photons' voxel is deeper (in mean "
                  "free paths at the cloud's mean extinction) than the medium's absorption "
                  "lets diffuse light reach (1 / sqrt(3 (1 - albedo) (1 - albedo g)); never at "
                  "albedo 1): march's paths from its samples carry the sun's light scattered "
                  "2 up to this many times (a path of up to this - 1 vertices, the sun's "
                  "shadow march at each) and the photons the orders above (at most "
                  "render.max_depth). Such a voxel averages the lit skin with the dark inside. "
                  "Elsewhere the paths stop at the second order. On the validation matrix 8 "
                  "took the thick albedo-0.9 rows to 8 of 27 within 10% (5 at 2), median "
                  "13.1% (16.0%), the worst VDB row 44.2% to 26.0%; a thick smoke at 320x180 "
                  "took 1.5x the frame (docs/accuracy.md, \"The sun's orders 2 to 8 by "
                  "march\").",
                  &RenderDesc::photonMarchDepth)
            .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
            .marchOnly());
    t.push_back(ren.param("photon_bounces", closed(0, 1 << 20),
                          "Photons: the scatterings each photon is traced through; at its next "
                          "one the light it carries becomes a source of the diffusion grid, "
                          "which carries the higher orders (smooth deep inside a thick cloud, "
                          "where a photon's walk is long). 0 = photons are traced to "
                          "render.max_depth and the grid carries only the sky.",
                          &RenderDesc::photonBounces)
                    .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
                    .marchOnly());
    t.push_back(ren.param("photon_similarity", closed(0, 1 << 20),
                          "Photons walking a majorant grid of their own (their voxel at least "
                          "render.photon_walk_depth mean free paths deep): after this many "
                          "scatterings a photon walks the similar medium, isotropic scattering "
                          "at sigma_s (1 - g) with sigma_a as it is (the similarity relation; the "
                          "first flight there keeps its direction). The light diffuses as in the "
                          "real medium in 1 - g times the scatterings; what changes is the "
                          "light within a few mean free paths of a surface, below such a voxel. "
                          "On the validation matrix's thick albedo-1 rows under photons (g 0.8) "
                          "it measured 13 of 27 cases within 10%, median 10.2% (the real walk: "
                          "14, 10.0%); a 640x360 frame of thick smoke1 (g 0.6) took 95 s against "
                          "189 s, in 2.4 times fewer scatterings, its pixels 1.1% from the real "
                          "walk's (docs/accuracy.md, \"Photons in the similar medium\"). 0 = the "
                          "real medium throughout; nothing changes where g <= 0.",
                          &RenderDesc::photonSimilarity)
                    .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
                    .marchOnly());
    t.push_back(ren.param("photon_walk_depth", atLeast(0),
                          "Photons: they walk a majorant grid of their own (the bounds of the "
                          "density they read, cell by cell) where their voxel is at least this "
                          "many mean free paths deep at the cloud's mean extinction (measured "
                          "along the sun each frame), march's grid elsewhere (`--explain` says "
                          "which). March's grid bounds the density loosely; photons look it up "
                          "only at a share of its events, but every event records, which lowers "
                          "the noise where voxels are shallow. On the validation matrix the "
                          "medium rows' voxels are 0.44-2.5 deep, where their own grid measured "
                          "0.3-2.2 points more error in five of six cases; the thick rows' are "
                          "11-61, where it took 2.6-4.1x less time at the same error (three "
                          "thick smokes at albedo 1, render.max_depth 4096: 24-48 s against "
                          "63-199 s a frame on 2 cores; docs/accuracy.md, \"Photons on a "
                          "majorant grid of their own\"). 0 = always their own grid.",
                          &RenderDesc::photonWalkDepth)
                    .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
                    .marchOnly());
    t.push_back(ren.param("photon_sky", {},
                          "Photons: trace the sky's light with photons as well as the sun's "
                          "(photons leave the sky from every direction, each carrying the sky's "
                          "radiance there); march then integrates the sky's single scattering "
                          "itself and the diffusion grid keeps no sky of its own (with "
                          "render.photon_bounces it carries the photons' higher orders only). "
                          "render.photons is shared between the sun and the sky in proportion "
                          "to the power each sends into the cloud's box. For absorbing media "
                          "(albedo < 1), where the grid's sky is too bright or too dark; at "
                          "albedo 1 the grid's sky is exact and this adds noise. "
                          "multiple_scattering = \"auto\" turns it on by itself where it "
                          "chooses photons and the medium absorbs (with twice render.photons, "
                          "and with render.photons = 0 at least 16 M); "
                          "name \"photons\" to choose yourself. Keep render.sky_shadow = "
                          "\"march\" with it: the sky volume's coarse voxel and few fixed "
                          "directions left the single-scattered sky at 0.15-0.45 of the "
                          "reference on the validation matrix. On its 27 medium cases at albedo "
                          "0.9, 11 within 10% (median 11.5%) against 5 (14.3%) with the grid's "
                          "sky, at 4 M photons; smoke1 at albedo 0.9, 640x360: 14.0 s a frame "
                          "against 5.5 s (docs/accuracy.md, \"The sky by photons where the "
                          "medium absorbs\").",
                          &RenderDesc::photonSky)
                    .usedWhen("render.multiple_scattering = \"photons\" or \"auto\"", photonsOn)
                    .marchOnly());
    t.push_back(ren.param("ms_strength", atLeast(0),
                          "Scale of the multiply scattered sun light, the diffusion grid's or "
                          "the sun's photons' (1 = their solution as it is; the grid loses "
                          "light in moderately thick, porous cloud). The sky's part, from the "
                          "grid or from render.photon_sky, is not scaled.",
                          &RenderDesc::msStrength)
                    .calibratedOver({0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0})
                    .usedWhen("render.multiple_scattering = \"grid\" or \"photons\"", gridOn)
                    .marchOnly());
    t.push_back(ren.param("ms_p1", closed(0, 1),
                          "Grid diffusion: weight of the flux term (phi + 3 g F.w) of the "
                          "diffuse radiance scattered toward the camera; 0 = isotropic.",
                          &RenderDesc::msP1)
                    .calibratedOver({0.0, 0.5, 1.0})
                    .usedWhen("render.multiple_scattering = \"grid\" or \"auto\"",
                              [](const SceneFile& f) {
                                  const MultipleScattering ms = f.scene.render.multipleScattering;
                                  return ms == MultipleScattering::Grid ||
                                         ms == MultipleScattering::Auto;
                              })
                    .marchOnly());
    auto noMs = [](const SceneFile& f) {
        return f.scene.render.multipleScattering == MultipleScattering::None;
    };
    auto skySingle = [](const SceneFile& f) {
        const RenderDesc& r = f.scene.render;
        return (r.multipleScattering == MultipleScattering::None &&
                r.skyScattering == SkyScattering::Single) ||
               photonSkyPossible(r, f.scene.medium);
    };
    auto skyAmbient = [](const SceneFile& f) {
        return f.scene.render.multipleScattering == MultipleScattering::None &&
               f.scene.render.skyScattering == SkyScattering::Ambient;
    };
    t.push_back(ren.param("sky_scattering",
                          WordTable<SkyScattering>{{"ambient", SkyScattering::Ambient},
                                                   {"single", SkyScattering::Single}},
                          "Sky light inside the medium without multiple scattering: ambient (an "
                          "isotropic term standing for every order of scattering, occluded by "
                          "`sky_occlusion`), or single: the sky light scattered once, "
                          "integrated over `sky_directions` directions weighted by the phase "
                          "function, each with its transmittance (`sky_shadow`): what pathtrace "
                          "computes with max_depth = 1.",
                          &RenderDesc::skyScattering)
                    .usedWhen("render.multiple_scattering = \"none\"", noMs)
                    .marchOnly());
    t.push_back(
        ren.param("sky_shadow",
                  WordTable<SkyShadow>{{"march", SkyShadow::March}, {"volume", SkyShadow::Volume}},
                  "Single-scattered sky: the transmittance toward each direction from a "
                  "shadow march per sample (the directions drawn from the phase function, "
                  "stratified, anew at every sample: noise, no bias; surfaces occlude), "
                  "or from a density integral per fixed direction propagated on the "
                  "light-volume grid (no noise, but biased unless the voxel is small "
                  "against a mean free path and the directions many: on the validation "
                  "matrix's medium clouds at 8 directions it gave 0.15-0.45 of the "
                  "single-scattered sky; surfaces do not occlude; one untransformed "
                  "volume only, else march).",
                  &RenderDesc::skyShadow)
            .usedWhen("render.multiple_scattering = \"none\" and "
                      "render.sky_scattering = \"single\", or render.photon_sky (which \"auto\" "
                      "turns on in an absorbing medium)",
                      skySingle)
            .marchOnly());
    t.push_back(ren.param("sky_directions", closed(0, 256),
                          "Single-scattered sky: directions the sky is integrated over at each "
                          "sample (shadow marches: the noise falls as 1 / sqrt(directions)), or "
                          "fixed directions of a Fibonacci lattice (volumes: voxels x directions "
                          "x 4 bytes). 0 = chosen per frame: 4 where the sky's photons carry its "
                          "higher orders and its single scattering is marched (the marches are "
                          "most of such a frame; 4 gave the same error as 8 on the validation "
                          "matrix), else 8.",
                          &RenderDesc::skyDirections)
                    .usedWhen("render.multiple_scattering = \"none\" and "
                              "render.sky_scattering = \"single\", or render.photon_sky (which "
                              "\"auto\" turns on in an absorbing medium)",
                              skySingle)
                    .marchOnly());
    t.push_back(ren.param("sky_occlusion",
                          WordTable<SkyOcclusion>{{"height", SkyOcclusion::Height},
                                                  {"column", SkyOcclusion::Column}},
                          "Sky ambient inside the medium: height (darker toward the base of the "
                          "field, down to 0.3), or column: the upper and lower hemispheres' sky "
                          "weighted by the openness of the vertical column above and below the "
                          "sample, normalised so that an albedo-1 medium under a uniform sky "
                          "returns the sky (white furnace).",
                          &RenderDesc::skyOcclusion)
                    .usedWhen("render.multiple_scattering = \"none\" and "
                              "render.sky_scattering = \"ambient\"",
                              skyAmbient)
                    .marchOnly());
    t.push_back(ren.param("sky_openness", atLeast(0),
                          "Column sky occlusion: weights e^(-k tau) of the hemispheres, tau the "
                          "transport optical depth above / below; 0 = the mean sky.",
                          &RenderDesc::skyOpenness)
                    .calibratedOver({0.0, 0.25, 0.5, 1.0, 2.0, 4.0})
                    .usedWhen("render.multiple_scattering = \"none\", render.sky_scattering = "
                              "\"ambient\" and render.sky_occlusion = \"column\"",
                              [skyAmbient](const SceneFile& f) {
                                  return skyAmbient(f) &&
                                         f.scene.render.skyOcclusion == SkyOcclusion::Column;
                              })
                    .marchOnly());
    auto inscatterOn = [](const SceneFile& f) {
        return f.scene.render.inScatter != InScatter::None;
    };
    t.push_back(ren.param("inscatter",
                          WordTable<InScatter>{{"none", InScatter::None},
                                               {"olajos", InScatter::Olajos},
                                               {"powder", InScatter::Powder}},
                          "Approximate in-scatter term: none, Olajos 1 - e^-cd, or Schneider's "
                          "Beer-powder 2 e^-d (1 - e^-2d). None with render.multiple_scattering "
                          "= \"photons\": photons trace the light scattered more than once "
                          "that these terms stand for, so the single scattering stays exact.",
                          &RenderDesc::inScatter)
                    .marchOnly());
    t.push_back(
        ren.param("inscatter_c", above(0),
                  "The c of Olajos' 1 - e^-cd, d the density as the field holds it (its values "
                  "times field.density, without medium.density_scale): the term follows the "
                  "density's units, not its optical depth, so a cloud stored near 0 and made "
                  "thick by density_scale has its single scattering darkened to about 0.6 at "
                  "the default strength (docs/accuracy.md, stop 68).",
                  &RenderDesc::inScatterC)
            .usedWhen(
                "render.inscatter = \"olajos\"",
                [](const SceneFile& f) { return f.scene.render.inScatter == InScatter::Olajos; })
            .marchOnly());
    t.push_back(
        ren.param("forward_scattering",
                  WordTable<ForwardScattering>{{"delta", ForwardScattering::Delta},
                                               {"none", ForwardScattering::None}},
                  "march: the light scattered into the phase function's forward peak (a "
                  "fraction g^2 of all scattering, delta-M) stays in the beam it came from: the "
                  "sun's single scattering is attenuated by sigma_t - g^2 sigma_s toward the sun "
                  "and toward the camera, and the diffusion grid's source is the light that "
                  "leaves that beam (docs/accuracy.md, \"Forward scattering\"); none = plain "
                  "single scattering. Part of the diffusion grid's model "
                  "(render.multiple_scattering = \"grid\", one untransformed volume): none "
                  "with \"none\" (single scattering) or photons, at g <= 0 or without the sun.",
                  &RenderDesc::forwardScattering)
            .usedWhen("render.integrator = \"march\" and render.multiple_scattering = \"grid\" "
                      "or \"auto\"",
                      [](const SceneFile& f) {
                          const MultipleScattering ms = f.scene.render.multipleScattering;
                          return f.scene.render.integrator == Integrator::March &&
                                 (ms == MultipleScattering::Grid || ms == MultipleScattering::Auto);
                      }));
    t.push_back(ren.param("inscatter_strength", closed(0, 1),
                          "Blend weight of the in-scatter term.", &RenderDesc::inScatterStrength)
                    .usedWhen("render.inscatter != \"none\"", inscatterOn)
                    .marchOnly());
    t.push_back(ren.param(
        "background",
        WordTable<Background>{{"sky", Background::Sky}, {"transparent", Background::Transparent}},
        "What camera rays that leave the scene show: the sky, or alpha 0.",
        &RenderDesc::background));
    t.push_back(ren.param("seed", kUInt32,
                          "Base random seed; every frame derives its own from it and the frame "
                          "number.",
                          &RenderDesc::seed));
    t.push_back(ren.param("seed_per_frame", {},
                          "true: each frame's noise differs (it flickers on a static shot and "
                          "averages out in motion); false: every frame draws the same random "
                          "numbers (no flicker, a fixed noise pattern). See docs/temporal.md.",
                          &RenderDesc::seedPerFrame));
    t.push_back(ren.param("threads", closed(0, 1024), "Worker threads; 0 = all cores.",
                          &RenderDesc::threads)
                    .neutralToPixels());
    t.push_back(ren.param("tile_size", closed(4, 256), "Edge of the square render tiles (pixels).",
                          &RenderDesc::tileSize)
                    .neutralToPixels());
    t.push_back(ren.param("fps", above(0), "Frames per second: frame f is at time f / fps.",
                          &RenderDesc::fps));
    t.push_back(ren.pair("shutter", closed(-4, 4),
                         "Motion blur: [open, close] in frames around the frame's time (e.g. "
                         "[-0.25, 0.25]); moving volumes are seen at a time in it per camera "
                         "sample. [0, 0] (equal): closed, no blur. docs/motion_blur.md.",
                         &RenderDesc::shutterOpen, &RenderDesc::shutterClose)
                    .checkedBy([](const Value& v) -> std::string {
                        if (v.v[0] <= v.v[1]) return "";
                        return "open " + formatFloat(v.v[0]) + " is after close " +
                               formatFloat(v.v[1]) + "; expected [open, close] with open <= close";
                    }));
}

} // namespace nimbus::io::scene
