/// @file advected_field.h
/// @brief Any field carried by a wind ([field.advect], AdvectDesc in core/scene.h): the source
/// field at time 0 (a VDB sequence: the frame's own grid) is sampled at the cell centres of a
/// dense grid of cubic cells over the simulation domain, then moved through the wind in steps
/// of `step` seconds by sim::advect (semi-Lagrangian, bounded MacCormack by default). A frame
/// between two steps takes one more, shorter step from the step before it. The frame's grid is
/// looked up trilinearly like the automaton's (core/fields/automaton_field.h: the same frame
/// type, the same block-maxima majorants).
///
/// Deterministic per scene: the state after n steps is a function of the source and n alone,
/// so a frame rendered alone (a farm task) re-simulates from time 0 and gives the same bits as
/// the same frame inside a sequence, where a Renderer keeps one AdvectedSequence between frames
/// and frame f + 1 costs only the steps after frame f (checkpoints in memory every
/// AdvectDesc::checkpointEvery steps serve frames rendered backwards).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "core/fields/automaton_field.h"
#include "core/scene.h"
#include "core/sim/advect.h"

namespace nimbus {

struct Field;
struct FieldMotion;

/// The most cells of an advection grid: 2^24 (64 MB per float grid; a step keeps about six).
constexpr double kMaxAdvectCells = 16777216.0;
/// Densities below this share of the source's maximum are set to 0 in a frame (MacCormack's
/// sub-visible residue, see AdvectedSequence::frameAt).
constexpr float kAdvectResidue = 1e-5f;
/// Default cells along the longest side of a procedural source's bounds.
constexpr int kDefaultAdvectCells = 128;

/// Where the simulation runs, from the description and the source.
struct AdvectDomain {
    sim::GridFrame frame; ///< origin and cubic cell size
    ivec3 res{0};
    Box bounds;             ///< origin + res * voxel
    bool coarsened = false; ///< the default voxel was enlarged to stay within kMaxAdvectCells
    std::string problem;    ///< "" or why it cannot run (an explicit voxel past the limit, ...)
};

/// The domain for a source whose density lies in `source` (a VDB: its voxel `sourceVoxel`,
/// else 0). `until` seconds of wind grow the default bounds (AdvectDesc::until).
AdvectDomain advectDomain(const AdvectDesc& d, const Box& source, float sourceVoxel,
                          const sim::VelocityField& wind);
/// The advection's wind in world units / s ("" problem) from the description and, for
/// AdvectWind::Grid, the frame's velocity grid; `problem` names what is wrong. A staggered
/// grid's field comes without planes: the AdvectedSequence that advects with it adds them
/// (sim::withPlanes(), one copy of the grid per sequence).
FieldMotion advectWind(const AdvectDesc& d, std::shared_ptr<const sim::VelocityGrid> grid,
                       bool staggered, std::string* problem = nullptr);
/// Seconds per step (AdvectDesc::step, or one frame).
float advectStep(const AdvectDesc& d, float fps);
/// Full steps from time 0 to a frame at `time` (the frame adds one partial step when it falls
/// between two).
std::uint64_t advectStepsFor(const AdvectDesc& d, float fps, float time);
/// The step parameters a scene's advection uses (the scheme; RK2, zero boundary).
sim::AdvectParams advectParams(const AdvectDesc& d);

/// The memory of an advection at a frame, bytes by part: advectMemory() is the plan's figure,
/// AdvectedSequence::memory() measures what a sequence holds (tests compare the two).
struct AdvectMemory {
    double state = 0.0;       ///< the state after the frame's full steps
    double checkpoints = 0.0; ///< the kept states: step 0, and one every checkpointEvery steps
    std::uint64_t checkpointCount = 0;
    double frame = 0.0;    ///< the frame's grid and its block maxima (held by the field)
    sim::StepMemory step;  ///< the advection's workspace (its ring at its least)
    double velocity = 0.0; ///< the velocity grid and, staggered, its planes (0: none, or unread)
    double total() const { return state + checkpoints + frame + step.total() + velocity; }
};
/// The plan's figure for a frame `time` seconds in, rendered alone or after earlier frames of a
/// sequence (the same states are kept either way), through `wind` (advectWind(); a velocity
/// grid's bytes from its resolution).
AdvectMemory advectMemory(const AdvectDomain& dom, const AdvectDesc& d, float fps, float time,
                          const sim::VelocityField& wind);

/// The source's density at the cell centres of the domain (empty for an empty domain).
sim::DensityGrid sampleSource(const AdvectDomain& domain, const Field& source);

/// The simulation a Renderer keeps between the frames of a sequence.
class AdvectedSequence {
  public:
    /// `source`: the field at time 0 (sampled here, at the cell centres of `domain`).
    AdvectedSequence(const AdvectDesc& d, float fps, const AdvectDomain& domain,
                     const Field& source, const FieldMotion& wind);
    /// The frame at `time` seconds. Cancelled (cancel set): an incomplete frame, and the kept
    /// state is left as it was.
    std::shared_ptr<const AutomatonFrame> frameAt(float time,
                                                  const std::atomic<bool>* cancel = nullptr);
    std::uint64_t stepsComputed() const { return stepsComputed_; }
    /// Whether `source` (sampled on this domain) and `wind` are those this sequence started
    /// from, bit for bit: a host that reads the same static VDB file again for every frame
    /// then continues the sequence instead of re-simulating from time 0.
    bool sameSource(const Field& source, const FieldMotion& wind) const;
    /// The last step's report (mass, CFL, limiter).
    const sim::AdvectStats& lastStats() const { return last_; }
    const AdvectDomain& domain() const { return domain_; }
    /// Cells the last frame set to 0 as residue (below kAdvectResidue x the source's maximum).
    std::uint64_t residueCells() const { return residueCells_; }
    /// What the sequence holds now (AdvectMemory::frame is 0: the frames are the caller's),
    /// from its buffers' capacities.
    AdvectMemory memory() const;

  private:
    void advanceTo(std::uint64_t n, const std::atomic<bool>* cancel);

    AdvectDesc desc_;
    AdvectDomain domain_;
    sim::VelocityField wind_;
    std::shared_ptr<const sim::VelocityGrid> windGrid_; ///< owns wind_.grid
    sim::AdvectParams params_;
    float dt_ = 0.0f;
    sim::DensityGrid state_; ///< after n_ steps
    std::uint64_t n_ = 0;
    std::map<std::uint64_t, sim::DensityGrid> checkpoints_; ///< step 0 always
    sim::AdvectWorkspace ws_;
    sim::AdvectStats last_;
    std::uint64_t stepsComputed_ = 0;
    float sourceMax_ = 0.0f;
    std::uint64_t residueCells_ = 0;
};

/// A frame of an advected field: the automaton's dense-grid lookup and majorants.
struct AdvectedField {
    AutomatonField grid;
    float density(vec3 p) const { return grid.density(p); }
    float majorant(const Box& b) const { return grid.majorant(b); }
};

} // namespace nimbus
