/// @file advect.h
/// @brief Wind advection of a dense density grid (issue 13, item 2): semi-Lagrangian advection
/// (Stam 1999) with an RK2 (or RK3) backtrace and trilinear sampling, and the bounded MacCormack
/// correction of Selle, Fedkiw, Kim, Liu and Rossignac 2008 ("An Unconditionally Stable
/// MacCormack Method", J. Sci. Comput. 35): a forward and a backward semi-Lagrangian step, the
/// error correction phi^{n+1} = phi_hat^{n+1} + (phi^n - phi_hat^n) / 2, then the result clamped
/// to the min/max of the 8 source samples the forward backtrace used (no new extrema; clamped
/// rather than reverted to semi-Lagrangian, as Selle et al. also allow).
///
/// Velocity sources (one closed enum, one switch): a uniform wind; a height-layered wind (rows
/// (altitude, wind), linear in altitude, clamped outside the table, so layers shear, Fizimayer
/// Fig. 4.9); a sampled velocity grid, cell-centred or MAC-staggered as Mantaflow and OpenVDB
/// store it (x of entry (i, j, k) on the cell's lower x face, y on its lower y face, z on its
/// lower z face). Velocities are world units per second; altitude is world y.
///
/// Coordinates: a grid with frame (origin, h) has cell (i, j, k) centred at
/// origin + (i + 1/2, j + 1/2, k + 1/2) h. The backtrace runs in the density grid's index space
/// (cells), so a far origin costs no precision there.
///
/// Deterministic: every cell is computed from the input alone, rows (y, z) are split between TBB
/// threads whole, and the per-step sums are added per row then in row order, so the result and
/// the stats are the same bits on any thread count. Measured stability, accuracy and cost:
/// docs/advection.md.
///
/// @code
///   sim::DensityGrid d = ...;                         // res, values (x fastest)
///   sim::GridFrame f{vec3(0.0f), 25.0f};              // origin (m), voxel size (m)
///   sim::VelocityField wind = sim::layeredWind({{500.0f, {4, 0, 0}}, {2000.0f, {12, 0, 3}}});
///   sim::AdvectParams ap;                             // MacCormack, RK2, zero outside
///   sim::AdvectWorkspace ws;
///   sim::DensityGrid next;
///   sim::AdvectStats st = sim::advect(d, f, wind, 0.5f, ap, next, ws);
///   // st.massBefore, st.massAfter, st.maxCfl, st.clampedCells
/// @endcode
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

#include "core/sim/automaton.h" // DensityGrid

namespace nimbus::sim {

/// Where a dense grid lies in the world: cell (i, j, k) spans origin + [i, i + 1) h etc.
struct GridFrame {
    vec3 origin{0.0f};
    float voxelSize = 1.0f; ///< h, world units
};

/// One row of a layered wind: the wind (world units / s) at world altitude y.
struct WindLayer {
    float altitude = 0.0f;
    vec3 wind{0.0f};
};

/// A sampled velocity grid (world units / s), x fastest. Centred: v[i] at the cell centre.
/// Staggered (MAC, Mantaflow / OpenVDB layout): v[i].x at the cell's lower x face
/// origin + (i, j + 1/2, k + 1/2) h, v[i].y at (i + 1/2, j, k + 1/2) h, v[i].z at
/// (i + 1/2, j + 1/2, k) h; a grid of n + 1 entries per axis holds the upper faces of n cells.
/// Outside its samples the velocity is the nearest sample's (clamp to edge, per component).
struct VelocityGrid {
    ivec3 res{0};
    GridFrame frame;
    std::vector<vec3> v;
    size_t index(int x, int y, int z) const { return (size_t(z) * res.y + y) * res.x + x; }
};

enum class VelocityKind { Uniform, Layered, Centred, Staggered };

/// A steady velocity field (the same over the whole step).
struct VelocityField {
    VelocityKind kind = VelocityKind::Uniform;
    vec3 uniform{0.0f};                 ///< Uniform
    std::vector<WindLayer> layers;      ///< Layered: altitudes strictly increasing
    const VelocityGrid* grid = nullptr; ///< Centred, Staggered: not owned, must outlive the field
    /// Staggered (made by withPlanes(), which staggeredGrid() calls): the grid's x, y and z
    /// components copied into three planes of res.x * res.y * res.z floats each (index order as
    /// VelocityGrid::index), read by advect()'s 8-cell blocks with plain loads where a vec3 grid
    /// needs shuffles; shared by copies of the field. Null: the blocks are not used (the per-cell
    /// grid kernel is).
    std::shared_ptr<const std::vector<float>> planes;
};

VelocityField uniformWind(vec3 wind);
VelocityField layeredWind(std::vector<WindLayer> layers);
VelocityField centredGrid(const VelocityGrid& g);
/// A staggered grid's field, with its planes (withPlanes()) unless @p planes is false: a field
/// only looked up, validated or compared needs none (advect() then takes its per-cell kernel).
VelocityField staggeredGrid(const VelocityGrid& g, bool planes = true);
/// @p f with VelocityField::planes when it is a staggered grid's field without them: a copy of
/// the components (12 bytes per face, one pass over the grid, in parallel). Make it once per
/// grid, not per step, and again after editing the grid's values (advect() reads the copy,
/// velocityAt() the grid). Other fields are returned as they are.
VelocityField withPlanes(VelocityField f);

/// "" when the field is usable, else the first problem (empty or unsorted layers, a grid whose
/// v does not hold res entries, a voxel size <= 0, non-finite values).
const char* validate(const VelocityField& v);
/// The velocity (world units / s) at world position p.
vec3 velocityAt(const VelocityField& v, vec3 p);

enum class AdvectScheme { SemiLagrangian, MacCormack };
enum class Backtrace { Euler, RK2, RK3 }; ///< RK2: explicit midpoint; RK3: Ralston's
/// What a lookup outside the density grid returns: 0 (matter leaves, nothing enters), the
/// nearest cell, or the grid wrapped around (periodic).
enum class Boundary { Zero, Clamp, Periodic };

struct AdvectParams {
    AdvectScheme scheme = AdvectScheme::MacCormack;
    Backtrace backtrace = Backtrace::RK2;
    Boundary boundary = Boundary::Zero;
    /// The characteristic (not the density) is traced in substeps of at most this many cells
    /// each, from the speed at the cell: ceil(CFL_cell / traceCfl) substeps, at most
    /// maxTraceSubsteps. The density is still sampled once per step (no extra diffusion). 0: one
    /// substep. A uniform wind, and a layered wind without vertical components, are traced in
    /// one substep (exact: the velocity is constant along the path).
    float traceCfl = 1.0f;
    int maxTraceSubsteps = 64;
    /// MacCormack only: clamp to the 8 source samples (Selle et al.'s limiter). Off only to
    /// measure what the limiter does (the result may then leave the source range).
    bool limiter = true;
    /// A uniform wind or a layered one without vertical components moves every cell of a row of
    /// x by the same amount: such steps look up the y and z stencils once per row (the same
    /// bits, 3-5x faster, docs/advection.md). A velocity grid (centred or staggered) takes the
    /// grid kernel: the first stage's y and z stencil once per row, no switch on the kind per
    /// lookup, and (AVX2, RK2, zero boundary, one trace substep) 8 cells per block, also the
    /// same bits. Off only to compare with the per-cell path (the reference).
    bool rowKernel = true;
};

/// What one step did.
struct AdvectStats {
    double massBefore = 0.0; ///< sum of density x h^3 before the step
    double massAfter = 0.0;  ///< after
    float maxCfl = 0.0f;     ///< max over cell centres of |v| dt / h (cells crossed per step)
    std::uint64_t clampedCells = 0; ///< cells the MacCormack limiter changed
    double clampedMass =
        0.0;             ///< sum over them of |change| x h^3 (bounds the limiter's mass change)
    int maxSubsteps = 0; ///< most trace substeps any cell used
};

/// Scratch buffers reused between steps.
struct AdvectWorkspace {
    DensityGrid fwd, tmp;
    std::vector<float> lo, hi;
    /// MacCormack with a velocity grid: per z slab lo, hi and the backward trace's end (x, y,
    /// z), a ring of whole slabs (its size / (5 x slab cells)); per row the last slab its pass-2
    /// lookups read
    std::vector<float> ring;
    std::vector<int> rowReach;
    std::vector<double> rowMassIn, rowMassOut, rowClampMass;
    std::vector<float> rowCfl;
    std::vector<std::uint32_t> rowClamped, rowSubsteps;
};

/// Which of advect()'s kernels a step through `vel` with `params` takes.
struct StepKernel {
    bool exact = false; ///< the wind is constant along a trace: one substep (exactInOneSubstep)
    bool row = false;   ///< the row kernel (a wind the same along every row of x)
    bool grid = false;  ///< the grid kernel (a velocity grid)
    bool mac = false;   ///< MacCormack: a forward grid (AdvectWorkspace::fwd)
    bool fused = false; ///< MacCormack with the grid kernel: the ring of slabs, pass 2 following
    /// MacCormack's limiter range kept per cell (AdvectWorkspace::lo, hi): the per-cell path
    bool limiterGrids = false;
};
StepKernel stepKernel(const VelocityField& vel, const AdvectParams& params);

/// The bytes an AdvectWorkspace holds after a step on a grid of `res` cells (what advect()
/// sizes; `inPlace`: out is in, whose result goes through AdvectWorkspace::tmp).
struct StepMemory {
    double grids = 0.0; ///< tmp, fwd, lo and hi
    double rows = 0.0;  ///< the per-row sums
    /// The fused MacCormack's ring: the slabs it starts with (a periodic boundary: every slab);
    /// it grows, up to ringMost (the whole grid), while a vertical wind reaches further
    double ring = 0.0, ringMost = 0.0;
    double total() const { return grids + rows + ring; }
};
StepMemory stepMemory(ivec3 res, const VelocityField& vel, const AdvectParams& params,
                      bool inPlace);

/// One step of length dt (seconds): out = the density `in` (placed by `frame`) advected through
/// `vel`. `out` may be `in`. Expects validate(vel) == "" and a finite dt.
AdvectStats advect(const DensityGrid& in, const GridFrame& frame, const VelocityField& vel,
                   float dt, const AdvectParams& params, DensityGrid& out, AdvectWorkspace& ws);

/// Sum of density x h^3 (rows summed in double, then added in order: deterministic).
double gridMass(const DensityGrid& d, const GridFrame& frame);

/// Trilinear lookup at index-space position p (cells; cell i centred at i + 1/2) with the given
/// boundary; lo/hi (if not null) receive the min/max of the 8 samples used.
float sampleDensity(const DensityGrid& d, vec3 p, Boundary b, float* lo = nullptr,
                    float* hi = nullptr);

/// The region ellipsoids of the automaton move through a velocity field: pass
/// `ellipsoidMotion` as AutomatonParams::motion and a pointer to this as motionUser. `frame`
/// places the automaton's cells in the world; the hook returns cells / s.
struct EllipsoidWind {
    const VelocityField* field = nullptr;
    GridFrame frame;
};
vec3 ellipsoidMotion(vec3 centreCells, double t, const void* user);

} // namespace nimbus::sim
