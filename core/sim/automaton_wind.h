/// @file automaton_wind.h
/// @brief Dobashi's cellular automaton carried by a horizontal layered wind (Dobashi et al. 2000,
/// sec. 3.3: "wind effects are realised by shifting the cell states in the wind direction", the
/// velocity a function of height; Fizimayer 2008 Fig. 4.9 for the shear), and the density of a
/// time between two simulation steps moved to that time by advection (core/sim/advect.h).
///
/// Every step n -> n + 1 is sim::step (the region ellipsoids move through the same wind via
/// AutomatonParams::motion), then the hum, act and cld bits of each cell row y are shifted by
/// whole cells: by floor(X_y(n + 1)) - floor(X_y(n)) along x and z, X_y(n) = n dt w_y the
/// exact displacement of row y (cells), w_y the wind at the row's centre. The fractional
/// remainder is kept (not rounded away), so over many steps a row moves at exactly its wind.
/// Cells shifted out of the grid are dropped, cells shifted in are empty.
///
/// The density at time T between steps n and n + 1 (s = T / dt - n): the smoothed steps n and
/// n + 1, each advected (MacCormack, advect.h) by what separates its stored position from where
/// the wind has carried it at T (row y: X_y(T) - floor(X_y(n)) and X_y(T) - floor(X_y(n + 1))
/// cells, less than 1 + |w_y| dt), then lerped with weight s. A uniform wind therefore moves the
/// density by wind x dT between two times, smoothly, while the automaton forms and dissolves
/// cloud. Like the automaton, the state at step n is a function of (params, wind, n) alone.
///
/// @code
///   sim::AutomatonParams p;                                   // res, controls; motion unset
///   sim::VelocityField w = sim::uniformWind(vec3(4, 0, 1));   // cells / s, y = 0
///   sim::WindAutomaton a(p, w);
///   sim::DensityGrid d;
///   a.densityAt(12.5, d);  // steps 125 and 126, advected to t = 12.5 s, lerped
/// @endcode
#pragma once

#include <cstdint>
#include <vector>

#include "core/sim/advect.h"
#include "core/sim/automaton.h"

namespace nimbus::sim {

/// The step n and the fraction s in [0, 1) of time t >= 0 for steps of dt seconds: n =
/// floor(t / dt) with a relative tolerance of 1e-6, so that a time that is a whole number of
/// steps in decimal (4.0 s at 0.1 s) is that step, not the one before it (0.1f is not 0.1).
void stepOf(double t, float dt, std::uint64_t& n, float& s);

/// Moves every row (y, z) of the three bit fields by d[y] = (dx, dz) cells: the content of cell
/// (x, y, z) goes to (x + dx, y, z + dz); cells leaving the grid are dropped, cells entering are
/// empty; the padding bits stay 0. `scratch` is reused between calls.
void shiftRows(CellBits& b, const std::vector<glm::ivec2>& d, std::vector<std::uint64_t>& scratch);

/// The automaton under a horizontal velocity field given in cells per second (the automaton's
/// index space: cell j centred at j + 1/2, GridFrame origin 0, voxel 1). Keeps the latest state
/// and the smoothed grids of the two latest steps, and a copy of the state every
/// `checkpointEvery` steps (0: none) so that going back in time re-simulates from the nearest
/// one. Not copyable (the ellipsoids' motion hook points into it).
class WindAutomaton {
  public:
    /// `wind`: Uniform or Layered, every y component 0 (validate with windProblem()).
    WindAutomaton(const AutomatonParams& p, const VelocityField& wind,
                  std::uint64_t checkpointEvery = 100);
    WindAutomaton(const WindAutomaton&) = delete;
    WindAutomaton& operator=(const WindAutomaton&) = delete;

    /// "" or why the wind cannot carry the automaton (a vertical component, an invalid field).
    static const char* windProblem(const VelocityField& wind);

    /// The state at step n (re-simulating from the nearest checkpoint when n is behind).
    const AutomatonState& advanceTo(std::uint64_t n);
    /// The density at time t >= 0 seconds (see the file comment); advances to step
    /// floor(t / dt) + 1.
    void densityAt(double t, DensityGrid& out);
    /// Steps this object has computed since it was made (each costs one sim::step and a shift).
    std::uint64_t stepsComputed() const { return stepsComputed_; }
    const AutomatonState& state() const { return state_; }
    const AutomatonParams& params() const { return p_; }
    /// Row y's exact displacement at time t (cells, x and z).
    glm::dvec2 displacement(int y, double t) const;

  private:
    void stepOnce();
    void smoothInto(DensityGrid& g);
    AutomatonParams p_;
    VelocityField wind_;
    EllipsoidWind ellipsoidWind_;
    std::vector<glm::dvec2> rowWind_; ///< cells / s per row
    AutomatonState state_;
    std::uint64_t checkpointEvery_;
    std::vector<AutomatonState> checkpoints_; ///< at steps 0, k, 2k, ...
    Workspace ws_;
    std::vector<std::uint64_t> shiftScratch_;
    std::vector<glm::ivec2> shifts_;
    std::vector<std::uint8_t> smoothScratch_;
    DensityGrid prev_, cur_, movedA_, movedB_;
    AdvectWorkspace advectWs_;
    std::uint64_t prevStep_ = ~std::uint64_t(0), curStep_ = ~std::uint64_t(0);
    std::uint64_t stepsComputed_ = 0;
};

} // namespace nimbus::sim
