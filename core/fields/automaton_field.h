/// @file automaton_field.h
/// @brief A cloud from Dobashi's cellular automaton (Dobashi et al. 2000; Fizimayer 2008 ch. 4)
/// as a density field: the automaton's grid of `res` cells spans the scene's bounds, the
/// density of a frame is Dobashi's weighted smoothing of the cloud bits, interpolated between
/// simulation steps and carried by the scene's layered wind (core/sim/automaton_wind.h), looked
/// up trilinearly between cell centres (0 outside the grid) and scaled by `density`. The
/// majorant of a box is the largest density of the 8^3-cell blocks its trilinear support
/// touches (sim::blockMaxima of the frame's own grid), so it bounds every lookup.
///
/// The simulation advances in time: a Renderer keeps one AutomatonSequence between the frames
/// of a sequence (Renderer::fieldFor), so frame f + 1 costs the steps between f and f + 1; a
/// lone frame re-simulates from step 0 and gives the same bits (the state at step n is a
/// function of the description and n alone). Measured costs: docs/automaton.md.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/scene.h"
#include "core/sim/automaton_wind.h"

namespace nimbus {

/// The density of one frame on the automaton's grid, placed in the world.
struct AutomatonFrame {
    sim::DensityGrid density; ///< already times AutomatonDesc::density
    sim::BlockMaxima maxima;  ///< per 8^3 block, no apron (majorant() widens the box instead)
    Box bounds;
    vec3 cellsPerUnit{1.0f}; ///< res / extent
};

struct AutomatonField {
    std::shared_ptr<const AutomatonFrame> frame;

    /// Trilinear between cell centres, 0 past the outermost cells' neighbours.
    float density(vec3 p) const;
    /// The largest block maximum over the cells whose trilinear support meets b (grown by one
    /// cell for rounding), times 1 + 2^-20 (a float lerp may exceed its inputs by an ulp).
    float majorant(const Box& b) const;
};

/// The automaton's parameters (sizes in cells) without the wind; "" or the first problem of
/// the description (resolution past kMaxAutomatonCells, empty bounds, the automaton's own
/// checks, a wind table that is unsorted or not horizontal).
sim::AutomatonParams automatonParams(const AutomatonDesc& d);
std::string automatonProblem(const AutomatonDesc& d);
/// The layered wind of the description in the automaton's index space (cells / s, altitudes in
/// cells): exact, since a map that scales each axis keeps a wind linear in altitude linear.
sim::VelocityField automatonIndexWind(const AutomatonDesc& d);

/// Simulation time of a frame at `time` seconds: the warm-up plus the frame time.
double automatonSimTime(const AutomatonDesc& d, float time);
/// Steps from the seed to the state a frame at `time` needs (floor(T / dt) + 1).
std::uint64_t automatonStepsFor(const AutomatonDesc& d, float time);
/// Memory of the simulation and of one frame's grids (bytes): three bit fields, six float
/// grids, the region weights.
double automatonBytes(const AutomatonDesc& d);

/// The simulation a Renderer keeps between frames.
class AutomatonSequence {
  public:
    explicit AutomatonSequence(const AutomatonDesc& d);
    /// The frame at `time` seconds (frame / fps): simulates forward from the kept state (or
    /// from the nearest checkpoint when `time` is earlier).
    std::shared_ptr<const AutomatonFrame> frameAt(float time);
    std::uint64_t stepsComputed() const { return sim_.stepsComputed(); }
    const AutomatonDesc& desc() const { return desc_; }

  private:
    AutomatonDesc desc_;
    sim::WindAutomaton sim_;
};

/// The field of a frame from a sequence (the Renderer's) or, without one, simulated from step 0.
AutomatonField makeAutomatonField(const AutomatonDesc& d, float time,
                                  AutomatonSequence* sequence = nullptr);

} // namespace nimbus
