#include "core/plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "core/fields/advected_field.h"
#include "core/fields/automaton_field.h"
#include "core/fields/field.h"
#include "core/fields/gardner.h"
#include "core/fields/grid.h"
#include "core/fields/sdf_cloud.h"
#include "core/lighting/cloud_depth.h"
#include "core/lighting/diffusion.h"
#include "core/lighting/light_volume.h"
#include "core/lighting/photons.h"
#include "core/lighting/sky_volume.h"
#include "core/media/medium.h"
#include "core/media/phase.h"
#include "core/tracking/volumes.h"

namespace nimbus {

float autoMajorantCell(const SceneDesc& s, const Box& b, float step) {
    if (s.render.majorantCell > 0.0f) return s.render.majorantCell;
    // about four primary steps per cell, at most 256 cells along any axis
    const vec3 e = b.extent();
    const float longest = std::max(e.x, std::max(e.y, e.z));
    return std::max(4.0f * step, longest / 256.0f);
}

float finestVoxel(const SceneDesc& s, const FrameBindings& bindings) {
    float finest = 0.0f;
    auto consider = [&](float voxel) {
        if (voxel > 0.0f && (finest == 0.0f || voxel < finest)) finest = voxel;
    };
    const int volumes = 1 + int(s.volumes.size());
    for (int v = 0; v < volumes; ++v) {
        const FieldDesc& f = v == 0 ? s.field : s.volumes[size_t(v) - 1].field;
        if (f.kind != FieldKind::Vdb || !isPlaced(s, v)) continue;
        const float voxel = minComponent(gridVoxelSize(bindings.grid(v)));
        if (s.instances.empty()) consider(voxel);
        for (const InstanceDesc& in : s.instances)
            if (in.volume == v) consider(voxel * minComponent(glm::abs(in.scale)));
    }
    return finest;
}

namespace {

/// The primary and shadow steps of a frame and why (render.step / render.shadow_step when set).
void chooseSteps(const SceneDesc& s, const FrameBindings& bindings, FramePlan& p) {
    const RenderDesc& r = s.render;
    bool vdb = s.field.kind == FieldKind::Vdb && isPlaced(s, 0);
    for (size_t i = 0; i < s.volumes.size(); ++i) vdb = vdb || isPlaced(s, int(i) + 1);
    const float voxel = finestVoxel(s, bindings);
    char buf[320];
    auto one = [&](float given, float perVoxel, const char* key, const char* voxelKey,
                   float& out) -> std::string {
        if (given > 0.0f) {
            out = given;
            std::snprintf(buf, sizeof buf, "%g (%s)", out, key);
        } else if (voxel > 0.0f) {
            out = perVoxel * voxel;
            std::snprintf(buf, sizeof buf, "%g (%s %g x the finest voxel %g)", out, voxelKey,
                          perVoxel, voxel);
        } else if (vdb) {
            out = kDefaultStep;
            std::snprintf(buf, sizeof buf,
                          "%g x the finest voxel (%s; the grids are read when rendering, not "
                          "for --explain)",
                          perVoxel, voxelKey);
        } else {
            out = kDefaultStep;
            std::snprintf(buf, sizeof buf, "%g (%s = 0: the default of procedural fields)", out,
                          key);
        }
        return buf;
    };
    const std::string primary =
        one(r.step, r.stepVoxels, "render.step", "render.step_voxels", p.step);
    const std::string shadow = one(r.shadowStep, r.shadowStepVoxels, "render.shadow_step",
                                   "render.shadow_step_voxels", p.shadowStep);
    p.stepDecision = "primary " + primary + ", shadow " + shadow;
}

/// The optical depth above which march splits a step: render.step_tau, or
/// render.photon_step_tau where photons carry the sun's multiple scattering (their light is
/// close enough to exact that the single scattering's step error shows; docs/accuracy.md,
/// "Finer steps where photons carry the light"). Called once the model is chosen.
void chooseStepTau(const SceneDesc& s, FramePlan& p) {
    p.stepTau = p.photons ? s.render.photonStepTau : s.render.stepTau;
    if (!(p.stepTau > 0.0f)) return;
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  ", steps split where their optical depth times the transmittance before them "
                  "exceeds %g (%s)",
                  double(p.stepTau),
                  p.photons ? "render.photon_step_tau: photons carry the light"
                            : "render.step_tau");
    p.stepDecision += buf;
}

/// Cells of a grid over `b` with cells of about `cell` (doubles: no int overflow).
double gridCells(const Box& b, float cell, double res[3]) {
    const vec3 e = b.extent();
    double n = 1.0;
    for (int a = 0; a < 3; ++a) {
        res[a] = std::max(1.0, std::ceil(double(e[a]) / double(cell)));
        n *= res[a];
    }
    return n;
}

/// Steps along a ray of length `len` on the schedule (step, growth) (step_schedule.h).
double stepsPerRay(double len, double step, double growth) {
    if (!(step > 0.0)) return 0.0;
    if (growth <= 0.0) return len / step;
    const double tg = std::ceil(1.0 / growth) * step;
    if (len <= tg) return len / step;
    return tg / step + std::log(len / tg) / std::log1p(growth);
}

/// A number as %g prints it.
std::string gText(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

/// " (12.3 MB)" for a size in bytes, "" for 0 (unknown).
std::string megabytes(double bytes, bool atMost = false) {
    if (!(bytes > 0.0)) return "";
    char buf[48];
    std::snprintf(buf, sizeof buf, " (%s%.1f MB)", atMost ? "at most " : "", bytes / 1048576.0);
    return buf;
}

/// The plan's refusals (grids past kMaxGridCells) and warnings (absurd steps per ray) for the
/// field's bounds `b`.
void checkBounds(const SceneDesc& s, const Box& b, FramePlan& p) {
    if (b.empty()) return;
    char buf[512];
    double res[3];
    auto refuse = [&](const char* what, const std::string& key, float cell, double cells,
                      double factor) {
        std::snprintf(
            buf, sizeof buf,
            "%s = %g needs %.4g cells (%.0f x %.0f x %.0f%s) over the field's bounds; "
            "the limit is %.0f (2^27): raise %s",
            key.c_str(), double(cell), cells * factor, res[0], res[1], res[2],
            factor > 1.0 ? (" x " + std::to_string(int(factor)) + " sky directions").c_str() : "",
            kMaxGridCells, what);
        if (p.refusal.empty()) p.refusal = buf;
    };
    if (p.skipEmpty && s.render.majorantCell > 0.0f) {
        const double n = gridCells(b, p.majorantCell, res);
        if (n > kMaxGridCells)
            refuse("render.majorant_cell", "render.majorant_cell", p.majorantCell, n, 1.0);
    }
    const bool lightGrid = p.sunDepthVolume || p.columnVolumes || p.diffusion || p.photons ||
                           p.skyVolume || p.densityGrid;
    if (lightGrid) {
        const double n = gridCells(b, p.lightVolumeCell, res);
        const double dirs = p.skyVolume ? double(p.skyDirections) : 1.0;
        const std::string key = s.render.lightVolumeCell > 0.0f
                                    ? "render.light_volume_cell"
                                    : "render.light_volume_cell = 0 takes the majorant cell; "
                                      "render.majorant_cell";
        if (n * dirs > kMaxGridCells)
            refuse(s.render.lightVolumeCell > 0.0f ? "render.light_volume_cell"
                                                   : "render.light_volume_cell or "
                                                     "render.majorant_cell",
                   key, p.lightVolumeCell, n, dirs);
    }
    if (p.photonsOwnGrid()) {
        const double n = gridCells(b, p.photonCell, res);
        if (n > kMaxGridCells)
            refuse("render.photon_cell_scale", "render.photon_cell_scale x the light-volume cell",
                   p.photonCell, n, 1.0);
    }
    {
        // float precision far from the origin: positions there are quantised to
        // |x| 2^-23, and once that is a sizeable part of a step (or of the field itself) the
        // picture shifts and turns blocky
        double far = 0.0;
        for (int a = 0; a < 3; ++a)
            far = std::max({far, std::abs(double(b.lo[a])), std::abs(double(b.hi[a])),
                            std::abs(double(s.camera.position[a]))});
        const double ulp = far * std::ldexp(1.0, -23);
        const double fine = std::min(double(p.step), double(maxComponent(b.extent())) / 64.0);
        if (fine > 0.0 && ulp > 0.5 * fine) {
            std::snprintf(buf, sizeof buf,
                          "the field or the camera lies %.3g units from the origin, where a "
                          "float resolves only %.3g units (%.0f%% of the finest length the "
                          "frame needs, %.3g): expect a shifted, blocky picture; move the "
                          "scene toward the origin",
                          far, ulp, 100.0 * ulp / fine, fine);
            p.warnings.push_back(buf);
        }
    }
    if (!p.pathtrace) {
        const double len = double(glm::length(b.extent()));
        const double prim = stepsPerRay(len, p.step, s.render.stepGrowth);
        const double shad = stepsPerRay(len, p.shadowStep, s.render.shadowGrowth);
        if (prim > kWarnStepsPerRay) {
            std::snprintf(buf, sizeof buf,
                          "a march step of %g (render.step, render.step_growth %g) takes up to "
                          "%.3g steps per camera ray across the field's %g units: expect a very "
                          "slow frame",
                          double(p.step), double(s.render.stepGrowth), prim, len);
            p.warnings.push_back(buf);
        }
        if (p.shadows && shad > kWarnStepsPerRay) {
            std::snprintf(buf, sizeof buf,
                          "a shadow step of %g (render.shadow_step, render.shadow_growth %g) "
                          "takes up to %.3g steps per shadow ray across the field's %g units: "
                          "expect a very slow frame",
                          double(p.shadowStep), double(s.render.shadowGrowth), shad, len);
            p.warnings.push_back(buf);
        }
    }
}

} // namespace

std::string depthText(double depth) {
    char buf[32];
    std::snprintf(buf, sizeof buf, depth < 1000.0 ? "%.3g" : "%.0f", depth);
    return buf;
}

std::string FramePlan::explain() const {
    std::ostringstream o;
    o << "frame " << frame << " (t = " << time << " s)\n";
    if (!refusal.empty()) o << "  refused: " << refusal << "\n";
    for (const std::string& w : warnings) o << "  warning: " << w << "\n";
    if (rebased) {
        char at[240];
        std::snprintf(at, sizeof at,
                      "  coordinates: rendered relative to (%.17g, %.17g, %.17g), %.3g units from "
                      "the world origin (float positions there would resolve only %.3g units)\n",
                      renderOrigin.x, renderOrigin.y, renderOrigin.z, originDistance,
                      originDistance * std::ldexp(1.0, -23));
        o << at;
    }
    o << "  field noise: " << (bakeNoise ? "baked tiles" : "direct evaluation") << " ("
      << noiseDecision << ")\n";
    if (automaton) {
        char sim[400];
        std::snprintf(sim, sizeof sim,
                      "  automaton: %d x %d x %d cells, simulation time %.4g s: steps 0 to %llu "
                      "from the seed when rendered alone (a renderer continuing a sequence "
                      "computes only the steps since its previous frame), the two bracketing "
                      "steps smoothed, advected to the frame's time and lerped; %.1f MB\n",
                      automatonRes.x, automatonRes.y, automatonRes.z, automatonSimTime,
                      (unsigned long long)automatonSteps, automatonBytes / 1048576.0);
        o << sim;
    }
    if (advected && advectRes.x == 0) {
        o << "  advection: " << advectWind
          << "; the domain follows from the source's bounds and the wind (VDB grids are read "
             "when the frame is rendered)\n";
    } else if (advected) {
        char adv[512];
        std::snprintf(
            adv, sizeof adv,
            "  advection: %s; %d x %d x %d cells of %.4g%s over (%.4g, %.4g, %.4g) to "
            "(%.4g, %.4g, %.4g), steps of %.4g s: %llu from time 0 when rendered alone "
            "(a renderer continuing a sequence computes only the steps since its "
            "previous frame)\n",
            advectWind.c_str(), advectRes.x, advectRes.y, advectRes.z, advectVoxel,
            advectCoarsened ? " (the default voxel, enlarged to stay within 2^24 cells)" : "",
            advectBounds.lo.x, advectBounds.lo.y, advectBounds.lo.z, advectBounds.hi.x,
            advectBounds.hi.y, advectBounds.hi.z, advectStep, (unsigned long long)advectSteps);
        o << adv;
        const AdvectMemory& m = advectMemory;
        const double mb = 1.0 / 1048576.0;
        std::snprintf(adv, sizeof adv,
                      "  advection memory: %.1f MB: the state %.1f, %llu checkpoint%s %.1f, the "
                      "frame %.1f, the step's workspace %.1f",
                      m.total() * mb, m.state * mb, (unsigned long long)m.checkpointCount,
                      m.checkpointCount == 1 ? "" : "s", m.checkpoints * mb, m.frame * mb,
                      m.step.total() * mb);
        o << adv;
        if (m.velocity > 0.0) {
            std::snprintf(adv, sizeof adv, ", the velocity grid %.1f", m.velocity * mb);
            o << adv;
        }
        if (m.step.ringMost > m.step.ring) {
            std::snprintf(adv, sizeof adv,
                          "; up to %.1f MB more where a vertical wind crosses many cells in a "
                          "step (MacCormack's ring of slabs, %.1f MB at most)",
                          (m.step.ringMost - m.step.ring) * mb, m.step.ringMost * mb);
            o << adv;
        }
        o << "\n";
    }
    o << "  march steps: " << stepDecision << "\n";
    o << "  empty-space skipping: "
      << (skipEmpty ? "majorant grid, cell " + std::to_string(majorantCell) : std::string("off"))
      << (sdfTrace ? "; the SDF field by sphere tracing its distance bound" : "") << "\n";
    o << "  sun transmittance: "
      << (!shadows ? std::string("none (no sun)")
          : !pathtrace && !scatters
              ? std::string(surfaces || solids > 0
                                ? "toward the surfaces only (medium.sigma_s = 0: nothing "
                                  "in-scatters)"
                                : "none (medium.sigma_s = 0: nothing in-scatters)")
          : shadowRoulette ? "ratio-tracked shadow rays, traced with a probability from the "
                             "density integral toward the sun (voxel " +
                                 std::to_string(lightVolumeCell) + ")"
          : pathtrace   ? std::string("ratio-tracked shadow rays")
          : lightVolume ? "light-attenuation volume, voxel " + std::to_string(lightVolumeCell)
                        : std::string("shadow march per sample"))
      << "\n";
    if (gateVolume)
        o << "  octave gate: the density along the sun's line read from the sun-depth volume "
             "(voxel "
          << lightVolumeCell << ") where the line leaves it, not a second shadow march\n";
    // the diffusion's memory: "at most" where the cloud was not measured (every voxel counted)
    const std::string diffusionMB = megabytes(diffusionBytes, !cloudMeasured());
    o << "  multiple scattering: "
      << (pathtrace   ? "path traced (delta tracking, to render.max_depth)"
          : !scatters ? "none (medium.sigma_s = 0: the medium only absorbs)"
          : photons
              ? std::string(photonSky ? "sun and sky" : "sun") + ": " +
                    std::to_string(photonCount) + " photons" +
                    (photonCountNote.empty() ? std::string() : " (" + photonCountNote + ")") +
                    " traced through the field, recorded on a grid of voxel " +
                    std::to_string(photonCell) +
                    (photonCellNote.empty() ? std::string() : " (" + photonCellNote + ")") +
                    megabytes(photonGridBytes, photonsOwnGrid()) + ", walking " +
                    (photonWalkNote.empty() ? "the grid chosen when the density is read"
                                            : photonWalkNote) +
                    ", with the single scattering exact (no octaves, render.inscatter "
                    "\"none\")" +
                    (secondShare > 0.0f
                         ? (secondDepth > 2 ? ", the sun's orders 2 to " +
                                                  std::to_string(secondDepth) + " by march"
                                            : std::string(", the sun's second scattering by "
                                                          "march")) +
                               " (about " +
                               std::to_string(int(std::lround(1.0 / double(secondShare)))) +
                               " paths of up to " + std::to_string(secondDepth - 1) +
                               " vertices a camera ray, render.photon_second_share = " +
                               gText(secondShare) + ", photon_march_depth; the photons from " +
                               "the order above)"
                         : std::string()) +
                    (photonBounces > 0 ? ", each traced through " + std::to_string(photonBounces) +
                                             " scatterings, the higher orders from their light "
                                             "diffused on the light-volume grid"
                                       : std::string()) +
                    (photonSky ? std::string(" (the photons shared between the sun and the "
                                             "sky by their power") +
                                     (photonSkyAuto ? ", twice the sun's count: \"auto\" traces "
                                                      "the sky too where the medium absorbs)"
                                                    : ")")
                     : diffusionSharesPhotonGrid()
                         ? "; sky: diffusion on the photons' grid (finer than the "
                           "light-volume grid)" +
                               diffusionMB
                     : diffusionOnPhotonGrid()
                         ? "; sky: diffusion on a grid of voxel " + std::to_string(diffusionCell) +
                               " (finer than the light-volume grid, coarser than the photons')" +
                               diffusionMB
                         : "; sky: diffusion on the light-volume grid" + diffusionMB)
          : diffusion ? "diffusion solved on the light-volume grid (sun and sky)" + diffusionMB
                      : "octaves only")
      << "\n";
    if (msAuto && !pathtrace && scatters) o << "    chosen by " << msDecision << "\n";
    if (!gridCellNote.empty() && diffusion && !pathtrace)
        o << "    the grid's " << gridCellNote << "\n";
    char sky[200];
    if (skyVolume)
        std::snprintf(sky, sizeof sky,
                      "single scattering over %d fixed directions (density integrals on the "
                      "light-volume grid, voxel %g, %.1f MB)",
                      skyDirections, lightVolumeCell, skyVolumeBytes / 1048576.0);
    else
        std::snprintf(sky, sizeof sky,
                      "single scattering over %d directions drawn from the phase function per "
                      "sample, a shadow march toward each",
                      skyDirections);
    if (forwardFraction > 0.0f) {
        char fwd[200];
        std::snprintf(fwd, sizeof fwd,
                      "  forward scattering: %.3g of the scattering (g^2) kept in the sun's and "
                      "the camera's beams (render.forward_scattering = \"delta\")\n",
                      double(forwardFraction));
        o << fwd;
    }
    o << "  sky light: "
      << (!ambient        ? std::string("no")
          : pathtrace     ? std::string(skyNee ? "next-event estimation and phase sampling (MIS)"
                                               : "phase-sampled rays")
          : photonSky     ? std::string(sky) + ", the higher orders from photons"
          : diffusion     ? std::string("in the diffusion grid")
          : skySingle     ? std::string(sky)
          : columnVolumes ? std::string("ambient, column occlusion (volumes of the density up "
                                        "and down)")
                          : std::string("ambient, height occlusion"));
    if (!skyNote.empty()) o << " (" << skyNote << ")";
    o << "\n";
    if (lightGrids > 0) {
        char grids[160];
        std::snprintf(grids, sizeof grids, "  light-volume grid: voxel %g, %d float grid%s",
                      double(lightVolumeCell), lightGrids, lightGrids > 1 ? "s" : "");
        o << grids;
        if (lightGridBytes > 0.0) {
            std::snprintf(grids, sizeof grids, ", %.1f MB\n", lightGridBytes / 1048576.0);
            o << grids;
        } else {
            o << " (sized by the field's bounds: the grids are read when rendering)\n";
        }
    }
    o << "  volumes: " << volumes << ", instances: " << instances;
    if (instanced)
        o << " ("
          << (hierarchical ? "instance boxes, then each volume's majorant grid"
                           : "one coarse world majorant grid")
          << ")";
    o << "\n  surfaces: " << (surfaces ? "ground and/or meshes (Embree)" : "none") << "\n";
    if (solids > 0)
        o << "  SDF solids: " << solids
          << " (sphere traced, soft shadows and AO; no Embree of their own)\n";
    if (motionBlur) {
        char blur[200];
        std::snprintf(blur, sizeof blur,
                      "  motion blur: shutter [%g, %g] s from the frame's time, one time per "
                      "camera sample (march) or path (pathtrace); moving: ",
                      double(shutterOpen), double(shutterClose));
        o << blur << motionNote
          << "; lighting caches (light, sky and diffusion grids, photons) at the frame's time\n";
    } else {
        o << "  motion blur: " << motionNote << "\n";
    }
    o << "  AOVs: beauty" << (aovs.transmittance ? ", transmittance" : "")
      << (aovs.depth ? ", depth" : "") << "\n";
    return o.str();
}

FramePlan planFrame(const SceneDesc& s, int frame, const AovSet& aovs) {
    FrameBindings unread;
    unread.unread = true;
    return planFrame(s, frame, unread, aovs);
}

namespace {

/// [field.advect]: the simulation's domain replaces the source's bounds for the plan.
void planAdvection(const SceneDesc& s, const FrameBindings& bindings, Box& bounds, FramePlan& p) {
    const AdvectDesc& a = s.field.advect;
    const char* scheme = a.maccormack ? "MacCormack" : "semi-Lagrangian";
    char buf[200];
    p.advected = true;
    if (a.wind == AdvectWind::Grid && !bindings.velocity && bindings.unread) {
        // the domain grows with the wind, which is read with the frame
        p.advectWind =
            std::string(scheme) + ", velocity grid \"" + a.velocityGrid + "\" of " + a.velocityPath;
        return;
    }
    std::string problem;
    const FieldMotion wind = advectWind(a, bindings.velocity, bindings.velocityStaggered, &problem);
    if (!problem.empty()) {
        p.refusal = problem;
        return;
    }
    float voxel = 0.0f;
    if (s.field.kind == FieldKind::Vdb && bindings.grid(0).grid) {
        const vec3 v = gridVoxelSize(bindings.grid(0));
        voxel = std::min({v.x, v.y, v.z});
    }
    const AdvectDomain dom = advectDomain(a, bounds, voxel, wind.velocity);
    if (!dom.problem.empty()) {
        p.refusal = dom.problem;
        return;
    }
    p.advectRes = dom.res;
    p.advectVoxel = dom.frame.voxelSize;
    p.advectBounds = dom.bounds;
    p.advectCoarsened = dom.coarsened;
    p.advectStep = advectStep(a, s.render.fps);
    p.advectSteps = advectStepsFor(a, s.render.fps, p.time);
    p.advectMemory = advectMemory(dom, a, s.render.fps, p.time, wind.velocity);
    switch (a.wind) {
    case AdvectWind::Uniform:
        std::snprintf(buf, sizeof buf, "%s, uniform wind (%.4g, %.4g, %.4g)", scheme, a.uniform.x,
                      a.uniform.y, a.uniform.z);
        break;
    case AdvectWind::Layered:
        std::snprintf(buf, sizeof buf, "%s, layered wind of %zu rows", scheme, a.layers.size());
        break;
    case AdvectWind::Grid:
        std::snprintf(buf, sizeof buf, "%s, velocity grid \"%s\" (%s)", scheme,
                      a.velocityGrid.c_str(), bindings.velocityStaggered ? "staggered" : "centred");
        break;
    }
    p.advectWind = buf;
    if (!dom.bounds.empty()) bounds = dom.bounds;
}

/// The cloud measured along the sun for the plan (core/lighting/cloud_depth.h), once a frame:
/// false with the reason when it cannot be measured before rendering.
bool measureCloud(const SceneDesc& s, const FrameBindings& bindings, FramePlan& p,
                  std::string& why) {
    if (p.cloudMeasured()) return true;
    if (s.field.kind == FieldKind::Automaton) {
        why = "a simulated field: its depth is not measured before it is built";
        return false;
    }
    if (s.field.kind == FieldKind::Vdb && !bindings.grid(0).grid) {
        why = bindings.unread ? "chosen when the grid is read" : "no density";
        return false;
    }
    // an advected cloud is measured as its source at time 0, the state the wind carries: one
    // choice for the whole sequence (the wind moves and deforms it, the depth stays near)
    const Field f = makeField(s.field, p.advected ? 0.0f : p.time, bindings.grid(0));
    const Medium m = Medium::fromDesc(s.medium);
    const CloudDepth d =
        measureCloudDepth(f, f.bounds(), s.sun.direction, meanComponent(m.sigma_t), p.step);
    if (d.hits == 0) {
        why = "no density along the sun";
        return false;
    }
    p.cloudTau = d.meanTau;
    p.cloudVolume = d.occupiedVolume;
    p.cloudExtinction = d.meanExtinction;
    // the photons leave over the box that holds density (core/lighting/photons.cpp): the share
    // of them that meet it is measured over that box, here the box of the samples with density
    // (the photons' is the majorant grid's, a little larger). Over the whole bounds a small
    // smoke in wide bounds (daichi_smoke) read 1%, and the voxel rule kept it coarse.
    // (where that box is the bounds, the same rays again: not cast twice)
    const bool sameBox = d.occupiedBox.lo == f.bounds().lo && d.occupiedBox.hi == f.bounds().hi;
    const CloudDepth o = sameBox ? d
                                 : measureCloudDepth(f, d.occupiedBox, s.sun.direction,
                                                     meanComponent(m.sigma_t), p.step);
    p.cloudHitFraction = o.hits > 0 ? o.hitFraction() : d.hitFraction();
    return true;
}

/// "auto" traces the sky by photons too when some channel's albedo is below this (an albedo-1
/// medium's grid sky is exact), at any depth, with at least kAutoPhotonSkyPhotons photons (the
/// voxel still sized for the count the depth gives, doubled). On the validation matrix's 27 thin
/// albedo-0.9 rows (depths along the sun 0.5-1.8) the grid's sky is too bright where the cloud is
/// opaque to the camera (smoke1 front-lit: 1.14x over its pixels of alpha >= 0.95, 12.00% over
/// the cloud); the sky by photons at twice the depth's count (4 M) levelled it (mean ratios
/// 0.99-1.01) but its noise took three cases to 10.5-11.3% (24 of the 27 within 10%, against 26
/// with the grid's sky); at 16 M on the same voxels every one was within 10%, median 5.77% ->
/// 3.99%, worst 6.92% (8 M: worst 9.35%). Until stop 76 the sky's photons
/// were kept to clouds deeper than 4 along the sun, from a measurement at 4 M (docs/accuracy.md,
/// "The thin rows' sky by photons").
constexpr float kAutoPhotonSkyAlbedo = 0.999f;
constexpr std::int64_t kAutoPhotonSkyPhotons = 16000000;

/// render.sky_directions = 0: the directions the sky's single scattering is integrated over at a
/// sample. Where the sky's photons carry its higher orders and the single scattering is marched,
/// kPhotonSkyDirections: the marches are most of such a frame's time, and on the validation
/// matrix's albedo-0.9 rows 4 directions gave the same cases within 10% as 8 (docs/accuracy.md,
/// stop 77); elsewhere kSkyDirections (the sky volume's fixed directions blur with fewer; the
/// sky alone single-scattered is measured at 8).
constexpr int kPhotonSkyDirections = 4;
constexpr int kSkyDirections = 8;

/// render.photons = 0: the photons a frame traces (before "auto" doubles them for the sky), by
/// the cloud's mean optical depth tau along the sun: kPhotonsThin up to a depth of kThinDepth,
/// growing in proportion to it up to kDeepPhotonFactor times that at 4 kThinDepth and above (so a
/// cloud that thickens over a sequence changes its count smoothly). On the validation matrix's 48
/// medium VDB cases (depths 10.6-35.8) 8 M photons took 42 within 10% (median 6.2%) against 31
/// (8.5%) at 2 M and 37 (7.4%) at 4 M, for four times the photons' time; on its thin ones (depths
/// 0.5-1.8) 8 M gained little (median 6.0% -> 5.2%) and took two albedo-0.9 cases just over 10%
/// (docs/accuracy.md, "Photons by the cloud's depth"). A cloud not measured (a simulated field)
/// takes kPhotonsThin.
constexpr std::int64_t kPhotonsThin = 2000000;
constexpr double kThinDepth = 2.0;
constexpr double kDeepPhotonFactor = 4.0;

std::int64_t photonsFor(const SceneDesc& s, const FrameBindings& bindings, FramePlan& p) {
    if (s.render.photons > 0) return s.render.photons;
    std::string why;
    if (!measureCloud(s, bindings, p, why)) {
        p.photonCountNote = "render.photons = 0: " + std::to_string(kPhotonsThin) +
                            ", the cloud's depth not measured (" + why + ")";
        return kPhotonsThin;
    }
    const double factor = std::clamp(p.cloudTau / kThinDepth, 1.0, kDeepPhotonFactor);
    const auto n = std::int64_t(std::llround(double(kPhotonsThin) * factor));
    char buf[240];
    std::snprintf(buf, sizeof buf,
                  "render.photons = 0: from the cloud's mean optical depth along the sun, %s: "
                  "%g M up to %g, %g M from %g",
                  depthText(p.cloudTau).c_str(), double(kPhotonsThin) * 1e-6, kThinDepth,
                  double(kPhotonsThin) * kDeepPhotonFactor * 1e-6, kThinDepth * kDeepPhotonFactor);
    p.photonCountNote = buf;
    return n;
}

/// The medium's single-scattering albedo per channel, sigma_s / (sigma_s + sigma_a) (0 in a
/// channel that neither scatters nor absorbs).
vec3 mediumAlbedo(const MediumDesc& m) {
    return m.sigma_s / glm::max(m.sigma_s + m.sigma_a, vec3(1e-30f));
}

/// The depth, in mean free paths, to which the diffuse light of a medium that absorbs reaches
/// before absorption takes it: 1 / kappa, kappa = sqrt(3 (1 - a)(1 - a g)) the decay of the
/// diffusion approximation's fluence per mean free path (a the albedo of the channel that
/// absorbs least, g the phase function's mean cosine: the similarity relation). Infinite at
/// albedo 1. A photon's walk in such a medium ends after about 1 / (1 - a) scatterings whatever
/// the cloud's depth: at albedo 0.9 and g 0.8, 3.4 mean free paths and 10 scatterings.
double absorptionDepth(const MediumDesc& m) {
    const double a = std::clamp(double(maxComponent(mediumAlbedo(m))), 0.0, 1.0);
    // (at albedo 1 the phase function is not needed: a Mie table would be computed for nothing)
    if (a >= 1.0) return std::numeric_limits<double>::infinity();
    const double g = double(PhaseFunction::fromMedium(m).meanCosine());
    return 1.0 / std::sqrt(3.0 * (1.0 - a) * (1.0 - a * g)); // (a < 1, g <= 1: positive)
}

/// render.multiple_scattering as the frame takes it: "auto" becomes photons where the depth
/// their walks reach is at most render.photon_depth, and the grid elsewhere. That depth is the
/// cloud's mean optical depth along the sun, or in a medium that absorbs the depth the diffuse
/// light reaches (absorptionDepth) where that is less. On the validation matrix photons beat the
/// grid at every depth it has: in thin and medium clouds the grid misses the forward multiple
/// scattering (docs/accuracy.md, "Photons where the cloud is thin or medium"); on the thick rows
/// (500 mean free paths) at albedo 0.9 photons took 3 of 27 cases within 10%, median 19.5%,
/// where the grid had none, median 38% ("Photons in thick clouds that absorb"), and at albedo 1,
/// walking the similar medium, 13 of 27, median 10.2%, where the grid had none, median 31%, at
/// some 50 times the grid's frame ("Photons for thick clouds"). The photons' cost grows with
/// the depth their walks reach; render.photon_depth (1000 by default) is where the grid takes
/// over to bound it. Records the choice in p.msAuto and p.msDecision.
MultipleScattering chooseMultipleScattering(const SceneDesc& s, const FrameBindings& bindings,
                                            bool inScatter, bool oneVolume, FramePlan& p) {
    if (s.render.multipleScattering != MultipleScattering::Auto) return s.render.multipleScattering;
    p.msAuto = true;
    auto grid = [&](const std::string& why) {
        p.msDecision = "render.multiple_scattering = \"auto\": the diffusion grid (" + why + ")";
        return MultipleScattering::Grid;
    };
    if (!inScatter) return grid("nothing in-scatters");
    if (!p.shadows) return grid("no sun: photons carry the sun's light");
    if (!oneVolume)
        return grid("several volumes or instances, which photons do not cover: octaves and the "
                    "sky term as for \"grid\"");
    if (!(s.render.photonDepth > 0.0f)) return grid("render.photon_depth = 0");
    // each photon flight would sphere-trace the SDF solids (sdf_terrain.toml at 64x36: 136 s
    // of photons against 0.2 s of march)
    if (p.solids > 0) return grid("SDF solids, which photons would sphere-trace at every flight");
    std::string why;
    if (!measureCloud(s, bindings, p, why)) return grid(why);
    const double absorbed = absorptionDepth(s.medium);
    const bool byAbsorption = absorbed < p.cloudTau;
    if (byAbsorption) p.absorptionDepth = absorbed;
    const double depth = byAbsorption ? absorbed : p.cloudTau;
    const bool thin = depth <= double(s.render.photonDepth);
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "render.multiple_scattering = \"auto\": %s (%s %s %s render.photon_depth "
                  "%g)",
                  thin ? "photons" : "the diffusion grid",
                  byAbsorption ? "the depth the medium's absorption lets diffuse light reach, "
                                 "less than the cloud's mean optical depth along the sun,"
                               : "the cloud's mean optical depth along the sun",
                  depthText(depth).c_str(), thin ? "<=" : ">", double(s.render.photonDepth));
    p.msDecision = buf;
    return thin ? MultipleScattering::Photons : MultipleScattering::Grid;
}

/// How many cells of size `cell` the measured cloud fills (its occupied volume over theirs).
double cloudCells(const FramePlan& p, double cell) {
    return p.cloudVolume / (cell * cell * cell);
}

/// The finest of lo, 2 lo, 4 lo ... hi (shares of `cell`) at which the cloud fills at most
/// `budget` cells and `fits(scale)` holds; hi where none does. The photons' voxel and the
/// grid's cell are both chosen so.
template <class Fits>
float finestCellScale(const FramePlan& p, float cell, float lo, float hi, double budget,
                      Fits fits) {
    float scale = lo;
    while (scale < hi && (cloudCells(p, double(cell) * scale) > budget || !fits(scale)))
        scale *= 2.0f;
    return scale;
}

/// render.photon_cell_scale = 0: the photons' voxel, in light-volume cells, from the cloud's
/// occupied volume, the finer of two rules (docs/accuracy.md, "Photons where the cloud is thin
/// or medium", "The sky's grid on the photons' voxel", "The photons' voxel and the density they
/// are tracked through"):
/// - by the photons leaving the sun (stop 45): the finest of 1/4, 1/2 ... 4 at which the cloud
///   holds no more than render.photons / kPhotonsPerCell voxels (the noise of a voxel's estimate
///   falls with the photons that cross it, not with their scatterings there, which are
///   correlated: counting those made deep clouds' voxels finer and their flicker twice as
///   large);
/// - by the photons reaching the cloud (render.photons times the share of the rays along the sun
///   over the box holding density that meet it; the photons leave over that box): the finest
///   of 1/8 ... 4 at which it holds no more than that / kPhotonsReachingPerCell. A voxel of a
///   quarter cell (one VDB voxel at the suite's step) left the medium backlit rows 16-28% off;
///   an eighth brought most within 9-13%. The share over the whole bounds (daichi_smoke, a
///   small smoke in wide bounds: 1% of the rays) kept it on a quarter cell, 18-27% off backlit.
///   Where the cloud's mean optical depth along the sun is above kThinDepth (so that photons
///   scatter many times and each voxel's estimate gathers many tracks) the finest is a
///   sixteenth: on the matrix's 48 medium VDB cases (8 M photons) the six backlit ones on an
///   eighth went from 8.2-19.7% to 5.6-12.3% (five of them over 10% before, two after), and
///   the front- and side-lit ones that moved stayed within 10% (up by 0.3-2.1 points); on the
///   thin rows (depths 0.5-1.8, 2 M) a sixteenth took daichi_smoke's backlit rows from 2.7-4.1%
///   to 10.0-10.4% (docs/accuracy.md, "A sixteenth of a cell for deep clouds' photons").
constexpr double kPhotonsPerCell = 256.0;
constexpr float kCountCellFinest = 0.25f;
constexpr double kPhotonsReachingPerCell = 20.0;
constexpr float kPhotonCellFinest = 0.125f;
constexpr float kDeepPhotonCellFinest = 0.0625f;

/// The first rule above, in light-volume cells (the measured cloud's).
float countCellScale(const FramePlan& p) {
    return finestCellScale(p, p.lightVolumeCell, kCountCellFinest, 4.0f,
                           double(p.photonVoxelCount) / kPhotonsPerCell,
                           [](float) { return true; });
}

float autoPhotonCellScale(const SceneDesc& s, const FrameBindings& bindings, FramePlan& p) {
    std::string why;
    if (!measureCloud(s, bindings, p, why) || !(p.cloudVolume > 0.0)) {
        p.photonCellNote = "the light-volume cell (" + why + ")";
        return 1.0f;
    }
    const double reaching = double(p.photonVoxelCount) * p.cloudHitFraction;
    const bool deep = p.cloudTau > kThinDepth;
    const float finest = deep ? kDeepPhotonCellFinest : kPhotonCellFinest;
    const float byReach =
        finestCellScale(p, p.lightVolumeCell, finest, 4.0f, reaching / kPhotonsReachingPerCell,
                        [](float) { return true; });
    const float scale = std::min(countCellScale(p), byReach);
    const double voxels = cloudCells(p, double(p.lightVolumeCell) * scale);
    char buf[400];
    std::snprintf(buf, sizeof buf,
                  "%g light-volume cells: the cloud fills %.3g of them, %.3g photons each, %.3g "
                  "of them reaching it (%.0f%% of the rays along the sun over the box holding it "
                  "meet it; at least %g leaving or %g reaching wanted; not below %g, the depth "
                  "along the sun %s %g)",
                  double(scale), voxels, double(p.photonVoxelCount) / std::max(voxels, 1.0),
                  reaching / std::max(voxels, 1.0), 100.0 * p.cloudHitFraction, kPhotonsPerCell,
                  kPhotonsReachingPerCell, double(finest), deep ? ">" : "<=", kThinDepth);
    p.photonCellNote = buf;
    return scale;
}

/// Whether photons walk a majorant grid of their own (FramePlan::photonOwnWalk): their voxel's
/// optical depth at the cloud's mean extinction, measured along the sun, against
/// render.photon_walk_depth. Unmeasured: march's grid.
void choosePhotonWalk(const SceneDesc& s, const FrameBindings& bindings, FramePlan& p) {
    std::string why;
    if (!measureCloud(s, bindings, p, why) || !(p.cloudExtinction > 0.0)) {
        p.photonWalkNote = "march's majorant grid (" + (why.empty() ? "no density" : why) + ")";
        return;
    }
    const double depth = p.cloudExtinction * double(p.photonCell);
    p.photonVoxelDepth = depth;
    p.photonOwnWalk = depth >= double(s.render.photonWalkDepth);
    // where a voxel is that deep, the similar medium's change near a surface is below it
    p.photonSimilarity = p.photonOwnWalk ? std::max(0, s.render.photonSimilarity) : 0;
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "%s: their voxel is %.3g deep at the cloud's mean extinction, %s "
                  "render.photon_walk_depth %g",
                  p.photonOwnWalk ? "a majorant grid of their own" : "march's majorant grid", depth,
                  p.photonOwnWalk ? ">=" : "<", double(s.render.photonWalkDepth));
    p.photonWalkNote = buf;
    if (p.photonSimilarity > 0)
        p.photonWalkNote += "; after " + std::to_string(p.photonSimilarity) +
                            " scatterings the similar medium (isotropic at sigma_s (1 - g), "
                            "render.photon_similarity)";
}

/// The diffusion grid ("auto" choosing it, or named) with render.light_volume_cell = 0: the
/// light-volume cell as a share of the majorant cell, from the cloud's measured volume: the finest
/// of 1/8, 1/4, 1/2 and 1 at which the cloud fills at most kGridCloudCells cells and the grid's box
/// holds at most kGridMaxCells. On the majorant cell a small thick cloud filled 10 to 2,000
/// cells (daichi_smoke 10, each some 190 mean free paths across) and its multiple scattering
/// came out 0.4 to 0.7 of the reference; the thick rows of the validation matrix went from a
/// median of 45.3% to 36.1% with this rule, better in 42 of 48 VDB cases, worse in 4 (by 8
/// points at most), at up to 0.6 s a case at 64x36 (docs/accuracy.md, "The diffusion grid's
/// cell from the cloud's size").
constexpr double kGridCloudCells = 262144.0;
constexpr double kGridMaxCells = 16777216.0;
float gridCellScale(const Box& bounds, FramePlan& p) {
    const float scale =
        finestCellScale(p, p.majorantCell, 0.125f, 1.0f, kGridCloudCells, [&](float sc) {
            const ivec3 r = lightVolumeResolution(bounds, p.majorantCell * sc);
            return double(r.x) * r.y * r.z <= kGridMaxCells;
        });
    char buf[220];
    std::snprintf(buf, sizeof buf,
                  "cell %g: %g of the majorant cell, at which the cloud fills %.3g cells (at "
                  "most %g wanted; the finest of 1/8 to 1)",
                  double(p.majorantCell * scale), double(scale),
                  cloudCells(p, double(p.majorantCell) * scale), kGridCloudCells);
    p.gridCellNote = buf;
    return scale;
}

} // namespace

bool autoPhotonSkyMedium(const MediumDesc& m) {
    return minComponent(mediumAlbedo(m)) < kAutoPhotonSkyAlbedo;
}

bool photonSkyPossible(const RenderDesc& r, const MediumDesc& m) {
    const bool automatic = r.multipleScattering == MultipleScattering::Auto;
    if (!automatic && r.multipleScattering != MultipleScattering::Photons) return false;
    return r.photonSky || (automatic && r.autoPhotonSky && autoPhotonSkyMedium(m));
}

FramePlan planFrame(const SceneDesc& s, int frame, const FrameBindings& bindings,
                    const AovSet& aovs) {
    FramePlan p;
    p.frame = frame;
    p.time = float(frame) / s.render.fps;
    p.aovs = aovs;
    p.pathtrace = s.render.integrator == Integrator::PathTrace;
    p.shadows = s.sun.enabled && maxComponent(s.sun.irradiance) > 0.0f;
    p.ambient = s.sky.kind != SkyKind::None && s.sky.ambient > 0.0f &&
                maxComponent(glm::max(s.sky.zenith, s.sky.horizon)) > 0.0f;
    p.scatters = maxComponent(s.medium.sigma_s) > 0.0f;
    p.skipEmpty = s.render.skipEmpty;
    Box bounds = s.field.homogeneous.box;
    if (s.field.kind == FieldKind::Cumulus) bounds = s.field.cumulus.bounds;
    if (s.field.kind == FieldKind::Vdb) bounds = bindings.grid(0).bounds;
    if (s.field.kind == FieldKind::Gardner) bounds = gardnerBounds(s.field.gardner);
    if (s.field.kind == FieldKind::Sdf) bounds = sdfCloudBounds(s.field.sdf);
    if (s.field.kind == FieldKind::Automaton) {
        const AutomatonDesc& a = s.field.automaton;
        bounds = a.bounds;
        p.automaton = isPlaced(s, 0);
        p.automatonRes = a.res;
        p.automatonSteps = automatonStepsFor(a, p.time);
        p.automatonSimTime = automatonSimTime(a, p.time);
        p.automatonBytes = automatonBytes(a);
        const std::string problem = automatonProblem(a);
        if (!problem.empty()) p.refusal = "field.kind = \"automaton\": " + problem;
        if (p.automatonSteps > kWarnAutomatonSteps) {
            char buf[320];
            std::snprintf(buf, sizeof buf,
                          "field.kind = \"automaton\": this frame alone re-simulates %llu steps "
                          "from the seed (field.warmup + the frame's time over field.sim_step; "
                          "about 1.6 ms a step per 512 k cells measured): expect a slow first "
                          "frame",
                          (unsigned long long)p.automatonSteps);
            p.warnings.push_back(buf);
        }
    }
    if (s.field.advect.enabled && isPlaced(s, 0)) planAdvection(s, bindings, bounds, p);
    p.sdfTrace =
        p.skipEmpty && s.render.sdfTrace && s.field.kind == FieldKind::Sdf && isPlaced(s, 0);
    chooseSteps(s, bindings, p);
    p.majorantCell = autoMajorantCell(s, bounds, p.step);
    p.volumes = 1 + int(s.volumes.size());
    p.instances = s.instances.empty() ? 1 : int(s.instances.size());
    p.instanced = isInstanced(s);
    p.hierarchical = s.render.hierarchicalSkip;
    p.surfaces = s.ground.enabled || !s.meshes.empty();
    p.solids = int(s.solids.size());
    // the light-attenuation volume covers one untransformed volume; instanced scenes march
    p.lightVolume = p.shadows && s.render.integrator == Integrator::March &&
                    s.render.shadow == ShadowMethod::Volume && !p.instanced && s.volumes.empty() &&
                    (p.scatters || p.surfaces || p.solids > 0);
    p.lightVolumeCell = s.render.lightVolumeCell > 0.0f ? s.render.lightVolumeCell : p.majorantCell;
    const bool marching = s.render.integrator == Integrator::March;
    // the grids of the diffusion and the column sky cover one untransformed volume
    const bool oneVolume = !p.instanced && s.volumes.empty();
    // light scattered in the medium: nothing to compute at albedo 0 (march's in-scattering is
    // sigma_s times it)
    const bool inScatter = marching && p.scatters;
    const MultipleScattering ms = chooseMultipleScattering(s, bindings, inScatter, oneVolume, p);
    // the diffusion grid, chosen by "auto" or named, with no cell named: its cell from the
    // cloud's size, not the majorant's (a named grid has its cloud measured for it here; a
    // simulated field cannot be and keeps the majorant cell)
    if (ms == MultipleScattering::Grid && inScatter && oneVolume &&
        s.render.lightVolumeCell <= 0.0f && !bounds.empty()) {
        std::string why;
        if (measureCloud(s, bindings, p, why) && p.cloudVolume > 0.0)
            p.lightVolumeCell = p.majorantCell * gridCellScale(bounds, p);
    }
    // (photons need a light to leave: the sun, or the sky when they trace it too)
    p.photons = inScatter && oneVolume && (p.shadows || (p.ambient && s.render.photonSky)) &&
                ms == MultipleScattering::Photons;
    if (p.photons) p.photonBounces = std::max(0, s.render.photonBounces);
    chooseStepTau(s, p);
    // the sky traced by photons too: its first scattering is march's (as with
    // render.sky_scattering = "single"), the orders above it the photons'
    // "auto" traces the sky by photons too where the medium absorbs (albedo below 1 in a
    // channel): there the grid's sky was 0.86-1.78 times the reference on the validation matrix's
    // medium rows (the sky alone) and 1.14 in the opaque core of a thin cloud, at albedo 1 it is
    // exact (the white furnace). The sky then takes about half the photons, so "auto" traces twice
    // render.photons, and at least kAutoPhotonSkyPhotons: 11 of the 27 medium cases at albedo 0.9
    // within 10% against 5 with the grid's sky (docs/accuracy.md, "The sky by photons where the
    // medium absorbs"), every thin one against 26 of 27
    p.photonSky = p.photons && p.ambient && photonSkyPossible(s.render, s.medium) &&
                  (s.render.photonSky || p.cloudMeasured());
    p.photonSkyAuto = p.photonSky && !s.render.photonSky;
    p.photonVoxelCount = p.photons ? photonsFor(s, bindings, p) * (p.photonSkyAuto ? 2 : 1) : 0;
    p.photonCount = p.photonVoxelCount;
    if (p.photonSkyAuto && s.render.photons == 0 && p.photonCount < kAutoPhotonSkyPhotons) {
        p.photonCount = kAutoPhotonSkyPhotons;
        p.photonCountNote += "; twice that with the sky's, at least " +
                             std::to_string(kAutoPhotonSkyPhotons / 1000000) +
                             " M, the voxel sized for " + std::to_string(p.photonVoxelCount);
    }
    // the sky's multiple scattering is the diffusion grid's in either model (unless photons
    // trace it; then the grid carries only what photons hand off)
    p.diffusion = inScatter && oneVolume &&
                  ((ms == MultipleScattering::Grid && (p.shadows || p.ambient)) ||
                   (ms == MultipleScattering::Photons &&
                    ((p.ambient && !p.photonSky) || p.photonBounces > 0)));
    p.skySingle =
        inScatter && p.ambient &&
        (p.photonSky || (!p.diffusion && s.render.skyScattering == SkyScattering::Single));
    // part of the diffusion grid's model of the sun's multiple scattering (its source is what
    // leaves the beams): not with render.multiple_scattering = "none" (single scattering, which
    // pathtrace at max_depth = 1 checks) nor with photons (which trace that light themselves)
    if (p.diffusion && p.shadows && !p.photons &&
        s.render.forwardScattering == ForwardScattering::Delta) {
        const float g = PhaseFunction::fromMedium(s.medium).meanCosine();
        if (g > 0.0f) p.forwardFraction = g * g;
    }
    p.inScatter = p.photons ? InScatter::None : s.render.inScatter;
    // photons record on the light-volume grid, or on a grid of their own at
    // render.photon_cell_scale of its cell (docs/accuracy.md, "Photons on the matrix")
    if (p.photons)
        p.photonCell = p.lightVolumeCell * (s.render.photonCellScale > 0.0f
                                                ? s.render.photonCellScale
                                                : autoPhotonCellScale(s, bindings, p));
    // the sky alone in the diffusion grid (photons carry the sun to the end; with sky photons
    // and no hand-off there is no grid): on a finer grid where the cloud is small, the photons'
    // voxel but no finer than their first rule gives (countCellScale): on the photons' finest
    // voxels the sky at albedo 0.9 came out too bright again (mean ratios up to 1.13)
    p.diffusionCell = p.lightVolumeCell;
    if (p.diffusion && p.photons && p.photonBounces == 0 && p.photonCell < p.lightVolumeCell)
        p.diffusionCell =
            std::min(p.lightVolumeCell,
                     std::max(p.photonCell, s.render.photonCellScale > 0.0f || !p.cloudMeasured()
                                                ? p.photonCell
                                                : p.lightVolumeCell * countCellScale(p)));
    const bool skyVolume = p.skySingle && s.render.skyShadow == SkyShadow::Volume;
    // like the sun's, the sky's volumes cover one untransformed volume; instanced scenes march
    p.skyVolume = skyVolume && oneVolume;
    if (skyVolume && !oneVolume)
        p.skyNote = "render.sky_shadow = \"volume\" covers one untransformed volume; this scene "
                    "has several or instances";
    if (p.skySingle)
        p.skyDirections = s.render.skyDirections > 0
                              ? std::min(s.render.skyDirections, kMaxSkyDirections)
                          : p.photonSky && !p.skyVolume ? kPhotonSkyDirections
                                                        : kSkyDirections;
    if (p.skyVolume) {
        const ivec3 res = lightVolumeResolution(bounds, p.lightVolumeCell);
        p.skyVolumeBytes = double(res.x) * res.y * res.z * p.skyDirections * sizeof(float);
    }
    p.columnVolumes = inScatter && oneVolume && p.ambient && !p.diffusion && !p.skySingle &&
                      s.render.skyOcclusion == SkyOcclusion::Column;
    // the diffusion's sun source needs the density integral toward the sun, and so does the
    // photons' skin profile (core/lighting/photons.h)
    p.shadowRoulette = s.render.integrator == Integrator::PathTrace && oneVolume && p.shadows &&
                       s.render.shadowRoulette;
    p.skyNee = p.pathtrace && s.render.skyNee;
    p.sunDepthVolume = p.shadowRoulette || p.lightVolume ||
                       (p.diffusion && p.shadows && !p.photons) ||
                       (p.photons && s.render.photonSkin > 0.0f);
    // the octave gate's line integral from that volume where the frame has one (octaves stand
    // down under photons)
    p.gateVolume = p.sunDepthVolume && s.render.integrator == Integrator::March && !p.photons &&
                   s.render.octaves > 1 && s.render.octaveGate > 0.0f;
    // (photons on a grid of their own read their densities there)
    p.densityGrid =
        (p.diffusion && !p.diffusionOnPhotonGrid()) || (p.photons && !p.photonsOwnGrid());
    // what Renderer::render builds on the light-volume grid (the densities are kept for the sky
    // volume too when density integrals are built beside it)
    const int integrals = (p.sunDepthVolume ? 1 : 0) + (p.columnVolumes ? 2 : 0);
    p.lightGrids = integrals + ((p.densityGrid || (p.skyVolume && integrals > 0)) ? 1 : 0);
    if (p.lightGrids > 0 && !bounds.empty()) { // (a VDB field unread for --explain: unknown)
        const ivec3 res = lightVolumeResolution(bounds, p.lightVolumeCell);
        p.lightGridBytes = double(res.x) * res.y * res.z * p.lightGrids * sizeof(float);
    }
    if (p.photons && !bounds.empty()) {
        // the photon grid, the density grid they are tracked through (photonTrackingCell, from
        // the majorant grid's smallest cell as buildMajorantGrid sizes them and the photons'
        // voxel) and the hand-off's sums (core/lighting/photons.h); the light-volume grid's
        // densities they share are counted with the light grids
        const vec3 ext = bounds.extent();
        const ivec3 mr = majorantResolution(ext, p.majorantCell);
        const float majorantMin = minComponent(ext / vec3(mr));
        p.photonTrackingCell = photonTrackingCell(bounds, majorantMin, p.photonCell);
        choosePhotonWalk(s, bindings, p);
        const ivec3 lr = lightVolumeResolution(bounds, p.lightVolumeCell);
        p.photonGridBytes =
            photonBytes(bounds, lightVolumeResolution(bounds, p.photonCell), p.photonTrackingCell,
                        p.skipEmpty && p.majorantCell > 0.0f ? double(mr.x) * mr.y * mr.z : 0.0,
                        p.photonOwnWalk, p.photonsOwnGrid(),
                        p.photonBounces > 0 ? double(lr.x) * lr.y * lr.z : 0.0);
    }
    // the sun's light scattered twice, by paths from march's samples: the photons' voxels
    // average it over a depth the camera does not see, most where a thin edge is lit from
    // behind; not in a cloud at most kThinDepth deep along the sun, where no voxel holds such a
    // skin and the paths only add their noise (docs/accuracy.md, "The sun's second scattering
    // by march"). Decided here, after the photons' walk, whose choice measures the cloud.
    p.secondShare = p.photons && p.shadows && marching && s.render.maxDepth >= 2 &&
                            (p.cloudTau < 0.0 || p.cloudTau > kThinDepth)
                        ? std::max(0.0f, s.render.photonSecondShare)
                        : 0.0f;
    // and the orders above it where a photon voxel is deeper than the diffuse light reaches in
    // a medium that absorbs: its average of the lit skin with the dark inside is the thick
    // albedo-0.9 rows' dimness (docs/accuracy.md, "The sun's orders 2 to 8 by march"); at
    // albedo 1 and in shallower voxels they only add noise
    if (p.secondShare > 0.0f && p.photonVoxelDepth > absorptionDepth(s.medium))
        p.secondDepth = std::max(2, std::min(s.render.photonMarchDepth, s.render.maxDepth));
    if (p.diffusion && !bounds.empty()) {
        const ivec3 res = lightVolumeResolution(bounds, p.diffusionCell);
        const double n = double(res.x) * res.y * res.z;
        const vec3 v = bounds.extent() / vec3(res);
        const double active = p.cloudMeasured() && p.cloudVolume > 0.0
                                  ? std::min(n, p.cloudVolume / (double(v.x) * v.y * v.z))
                                  : n;
        p.diffusionBytes = diffusionBytes(res, active, p.photons && p.photonBounces > 0);
        // a grid of its own (finer than the light-volume grid, coarser than the photons'):
        // its densities
        if (p.diffusionOnPhotonGrid() && !p.diffusionSharesPhotonGrid())
            p.diffusionBytes += n * sizeof(float);
    }
    checkBounds(s, bounds, p);
    // motion blur: only with the shutter open and something placed that moves
    const std::string moving = movingVolumes(s);
    const bool shutterOpen = s.render.shutterClose > s.render.shutterOpen;
    p.motionBlur = shutterOpen && !moving.empty();
    p.motionNote = !shutterOpen     ? "off (render.shutter closed)"
                   : moving.empty() ? "off (render.shutter open, but no placed volume moves)"
                                    : moving;
    if (p.motionBlur) {
        p.shutterOpen = s.render.shutterOpen / s.render.fps;
        p.shutterClose = s.render.shutterClose / s.render.fps;
    }

    if (p.advected) {
        p.noiseDecision = "[field.advect]: the source is sampled once onto the advection grid";
        return p;
    }
    if (s.field.kind != FieldKind::Cumulus) {
        p.noiseDecision =
            s.field.kind == FieldKind::Gardner     ? "Gardner's sine sums: nothing to bake"
            : s.field.kind == FieldKind::Automaton ? "Dobashi's cellular automaton: nothing to bake"
                                                   : "not a procedural field";
        return p;
    }
    const CumulusDesc& c = s.field.cumulus;
    const double bakeEvals =
        std::pow(double(c.baseBakeResolution), 3) + std::pow(double(c.detailBakeResolution), 3);
    // Expected noise evaluations if evaluated directly: every pixel marches the diagonal of the
    // bounds; about a tenth of the samples survive the cheap envelope test, and each of those
    // costs a shadow march of ~12 more.
    const vec3 e = bounds.extent();
    const double stepsPerRay = std::min(4096.0, double(glm::length(e)) / p.step);
    const double directEvals = double(s.camera.width) * s.camera.height * stepsPerRay * 0.1 *
                               (1.0 + (p.shadows ? 12.0 : 0.0));
    char buf[256];
    switch (c.eval) {
    case NoiseEval::Direct:
        p.bakeNoise = false;
        p.noiseDecision = "field.evaluation = \"direct\"";
        break;
    case NoiseEval::Baked:
        p.bakeNoise = true;
        p.noiseDecision = "field.evaluation = \"baked\"";
        break;
    case NoiseEval::Rgba:
        p.bakeNoise = true;
        p.noiseDecision = "field.evaluation = \"rgba\" (Olajos' RGBA8 channels)";
        break;
    case NoiseEval::Auto:
        p.bakeNoise = directEvals > bakeEvals;
        std::snprintf(buf, sizeof buf, "auto: ~%.3g direct noise evaluations vs %.3g to bake",
                      directEvals, bakeEvals);
        p.noiseDecision = buf;
        break;
    }
    return p;
}

} // namespace nimbus
