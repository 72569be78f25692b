/// @file automaton.h
/// @brief Dobashi's cellular automaton for cloud formation (Dobashi et al. 2000, as described by
/// Fizimayer 2008 ch. 2.3 and 4), with Fizimayer's stable-simulation controls (region
/// ellipsoids that carry the probabilities, drift with the wind, age, shrink and expire; the
/// number of ellipsoids adapted to hold a target cloud cover), Dobashi's weighted smoothing of
/// the cloud bits into a continuous density, linear interpolation between simulation steps, and
/// the block maxima a majorant grid needs. Rules: DESIGN.md "Reference parameters"; the layout,
/// the falloff, the defaults and the measured cost: docs/automaton.md.
///
/// Bit layout: each of hum, act and cld is a bit array of nx x ny x nz cells (y up), 64 cells per
/// std::uint64_t along x (cell x of a row is bit x % 64 of word x / 64; bits past nx in the last
/// word of a row are always 0); rows are stored with the word index fastest, then y, then z:
/// word (z * ny + y) * wordsPerRow + x / 64. The growth rule is then word-wide bit operations.
///
/// Randomness is counter-based: cell c of step n draws from hash(seed, n, c), the ellipsoid
/// controls from hash(seed, n, stream, k); nothing depends on the order in which cells are
/// visited, so a state is a function of (params, step) alone, whatever the thread count.
///
/// @code
///   sim::AutomatonParams p;            // 256 x 32 x 256, stable defaults
///   sim::Simulation s(p);              // step 0
///   sim::DensityGrid d;
///   s.densityAt(1.25, d);              // lerp of the smoothed steps 12 and 13
///   auto maj = sim::blockMaxima(d, 8); // per 8^3 block
/// @endcode
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace nimbus::sim {

using glm::ivec3;
using glm::vec3;

/// The three bit fields of the automaton (see the file comment for the layout).
struct CellBits {
    ivec3 res{0};
    int wordsPerRow = 0;
    std::vector<std::uint64_t> hum, act, cld;

    CellBits() = default;
    explicit CellBits(ivec3 r);
    size_t rowWord(int y, int z) const { return (size_t(z) * res.y + y) * wordsPerRow; }
    size_t wordCount() const { return hum.size(); }
    /// Mask of the valid bits of word w of a row (all ones except in the last word).
    std::uint64_t validMask(int w) const;
    static bool get(const std::vector<std::uint64_t>& f, const CellBits& b, int x, int y, int z) {
        return (f[b.rowWord(y, z) + (x >> 6)] >> (x & 63)) & 1u;
    }
    static void set(std::vector<std::uint64_t>& f, const CellBits& b, int x, int y, int z, bool v) {
        std::uint64_t& w = f[b.rowWord(y, z) + (x >> 6)];
        const std::uint64_t m = std::uint64_t(1) << (x & 63);
        w = v ? (w | m) : (w & ~m);
    }
    bool operator==(const CellBits& o) const = default;
};

/// Number of set bits of a field.
std::uint64_t countBits(const std::vector<std::uint64_t>& f);
/// Fraction of the nx x nz columns holding at least one cloud cell (the sky cover).
double columnCover(const CellBits& b);

/// A region ellipsoid (Fizimayer 4.2): probabilities of humidity and activation fall from their
/// maxima at the centre to 0 at the surface, extinction rises from 0 to its maximum. Units are
/// cells, times seconds.
struct RegionEllipsoid {
    vec3 centre{0.0f};
    vec3 radii{1.0f}; ///< full-size semi-axes
    float age = 0.0f;
    float lifetime = 1.0f;
    bool operator==(const RegionEllipsoid& o) const = default;
};

enum class InitialCells { Empty, Full };

/// All parameters; the defaults are the stable set (docs/automaton.md).
struct AutomatonParams {
    ivec3 res{256, 32, 256};
    std::uint64_t seed = 1;
    float dt = 0.1f;             ///< seconds per simulation step (Fizimayer 1.4)
    vec3 wind{4.0f, 0.0f, 1.0f}; ///< cells per second; ellipsoids move by wind * dt
    float pHum = 0.1f;           ///< humidity regeneration at an ellipsoid's centre
    float pAct = 0.01f;          ///< activation at an ellipsoid's centre
    float pExt = 0.1f;           ///< extinction far outside every ellipsoid
    int cloudDensity = 24;       ///< initial number of region ellipsoids
    int minEllipsoids = 2, maxEllipsoids = 64;
    float targetCover = 0.35f;               ///< column cover that density adaptation holds
    float coverTolerance = 0.05f;            ///< no adaptation while |cover - target| <= this
    int adaptPeriod = 10;                    ///< steps between two changes of the ellipsoid count
    float sizeMean = 28.0f, sizeVar = 8.0f;  ///< horizontal semi-axis (cells): mean, half-width
    float heightRatio = 0.35f;               ///< vertical semi-axis = heightRatio x horizontal
    float lifeMean = 40.0f, lifeVar = 15.0f; ///< lifetime (s): mean, half-width
    float shrinkTime = 8.0f;                 ///< the last seconds of a life, radii shrinking to 0
    float regionMargin = 40.0f;              ///< region bounds = volume grown by this (x, z; cells)
    float layerLo = 0.3f, layerHi = 0.6f;    ///< centre heights, fractions of ny
    InitialCells initial = InitialCells::Empty;
    /// The motion of the ellipsoids: null moves every centre by wind * dt; otherwise each
    /// centre c moves by motion(c, t, motionUser) * dt (cells per second at t = step * dt), the
    /// hook a layered wind or a velocity grid plugs into. It must be a pure function of its
    /// arguments (determinism).
    vec3 (*motion)(vec3 centre, double t, const void* user) = nullptr;
    const void* motionUser = nullptr;
};

/// Checks the parameters: "" when they are usable, else what is wrong (the first problem).
/// Every function below expects valid parameters.
const char* validate(const AutomatonParams& p);

/// The whole simulation state at one step.
struct AutomatonState {
    CellBits bits;
    std::vector<RegionEllipsoid> ellipsoids;
    std::uint64_t step = 0;
    int targetCount = 0;         ///< ellipsoid count the adaptation holds
    std::uint64_t lastAdapt = 0; ///< step of the last change of targetCount
    double cover = 0.0;          ///< column cover of bits
    bool operator==(const AutomatonState& o) const = default;
};

/// Per-cell weight w in [0, 1] of the region ellipsoids, quantised to 16 bits (0..65535), x
/// fastest; `inside` is a bit field (CellBits layout) holding every cell whose weight is not 0
/// (and possibly a few of weight 0 next to them).
struct RegionWeights {
    ivec3 res{0};
    std::vector<std::uint16_t> w;
    std::vector<std::uint64_t> inside;
    size_t index(int x, int y, int z) const { return (size_t(z) * res.y + y) * res.x + x; }
};

/// The falloff of one ellipsoid at normalised distance squared d2 = |(p - c) / r|^2:
/// (1 - d2)^2 inside, 0 outside (1 at the centre, 0 with zero slope at the surface).
inline float regionFalloff(float d2) {
    return d2 < 1.0f ? (1.0f - d2) * (1.0f - d2) : 0.0f;
}
/// Radii of an ellipsoid now: full size, shrinking linearly to 0 over the last shrinkTime.
vec3 currentRadii(const RegionEllipsoid& e, float shrinkTime);

/// Counter-based hash of (seed, step, cell): the random bits of one cell in one step.
std::uint64_t cellHash(std::uint64_t seed, std::uint64_t step, std::uint64_t cell);
/// A probability as a 21-bit threshold thr = round(p 2^21).
std::uint32_t probabilityThreshold(float p);
/// Whether an event of threshold thr scaled by the weight w16 / 65535 fires for the 21-bit
/// uniform u: u 65535 < thr w16 (exact integers, no division), probability
/// ceil(thr w16 / 65535) / 2^21.
inline bool fires(std::uint32_t u, std::uint32_t thr, std::uint32_t w16) {
    return std::uint64_t(u) * 65535u < std::uint64_t(thr) * w16;
}
/// The three 21-bit uniforms of a cell hash: humidity, activation, extinction.
inline std::uint32_t uniformHum(std::uint64_t h) {
    return std::uint32_t(h & 0x1FFFFF);
}
inline std::uint32_t uniformAct(std::uint64_t h) {
    return std::uint32_t((h >> 21) & 0x1FFFFF);
}
inline std::uint32_t uniformExt(std::uint64_t h) {
    return std::uint32_t((h >> 42) & 0x1FFFFF);
}

/// Growth (word-wide): hum' = hum & ~act; cld' = cld | act; act' = ~act & hum & f_act.
/// `scratch` receives the old act words (reused between calls). TBB-parallel over z.
void growthStep(CellBits& b, std::vector<std::uint64_t>& scratch);
/// Rasterises the ellipsoids (at their current radii) into w = max over ellipsoids of the
/// falloff. TBB-parallel over z.
void regionWeights(const std::vector<RegionEllipsoid>& ellipsoids, float shrinkTime,
                   RegionWeights& out);
/// Extinction cld' = cld & (u_ext >= thr(pExt (1 - w))), humidity hum' = hum | (u_hum <
/// thr(pHum w)), activation act' = act | (u_act < thr(pAct w)), the uniforms from
/// cellHash(seed, step, cell index). Cells with w = 0 and no cloud draw nothing.
void stochasticStep(CellBits& b, const RegionWeights& w, const AutomatonParams& p,
                    std::uint64_t step);

/// Scratch buffers reused between steps.
struct Workspace {
    std::vector<std::uint64_t> act;
    RegionWeights weights;
};

/// Step 0: the initial cells and `cloudDensity` ellipsoids at random places and ages.
AutomatonState initialState(const AutomatonParams& p);
/// One full step n -> n + 1: growth, region weights, stochastic rules, then the ellipsoid
/// controls (wind, ageing, expiry, density adaptation, replacement).
void step(AutomatonState& s, const AutomatonParams& p, Workspace& ws);
/// Only the controls of a step (done by step()): move by wind * dt, age, drop expired or
/// departed ellipsoids, adapt targetCount to s.cover, retire or spawn to hold it.
void updateEllipsoids(AutomatonState& s, const AutomatonParams& p);
/// The state at step n, re-simulated from the seed (cost: n steps; docs/automaton.md).
AutomatonState stateAtStep(const AutomatonParams& p, std::uint64_t n);
/// The same from a checkpoint (any state of the same parameters at a step <= n; a state is a
/// plain value, so a checkpoint is a copy): n - checkpoint.step steps.
AutomatonState stateAtStep(const AutomatonParams& p, std::uint64_t n,
                           const AutomatonState& checkpoint);

/// A dense float grid, x fastest.
struct DensityGrid {
    ivec3 res{0};
    std::vector<float> v;
    float at(int x, int y, int z) const { return v[(size_t(z) * res.y + y) * res.x + x]; }
};

/// Dobashi's weighted smoothing: the separable binomial kernel [1 2 1] / 4 on each axis (a 3^3
/// kernel, weight 8/64 at the cell, 4/64 face, 2/64 edge, 1/64 corner neighbours) applied to
/// cld, cells outside the grid counting as empty. Values are k / 64 exactly. `scratch` reused.
void smoothDensity(const CellBits& b, DensityGrid& out, std::vector<std::uint8_t>& scratch);
/// out = (1 - s) a + s b per cell (the density between two steps, s in [0, 1]).
void lerpDensity(const DensityGrid& a, const DensityGrid& b, float s, DensityGrid& out);

/// Maxima of a density grid per block of block^3 cells, each block grown by `apron` cells on
/// every side (1 covers trilinear lookups across block faces); x fastest.
struct BlockMaxima {
    ivec3 res{0};
    int block = 8;
    std::vector<float> v;
    float at(int x, int y, int z) const { return v[(size_t(z) * res.y + y) * res.x + x]; }
};
void blockMaxima(const DensityGrid& d, int block, int apron, BlockMaxima& out);
/// The blocks blockMaxima() makes for a grid of `res` cells (BlockMaxima::res).
inline ivec3 blockMaximaRes(ivec3 res, int block) {
    return (res + block - 1) / block;
}

/// A simulation driven by time: keeps the state and the smoothed grids of the two steps that
/// bracket the last requested time; going back in time re-simulates from the seed.
class Simulation {
  public:
    /// Keeps a checkpoint every `checkpointEvery` steps (0: none), so that going back in time
    /// re-simulates from the nearest one instead of from step 0 (about 0.8 MB each at 256 x 32
    /// x 256).
    explicit Simulation(const AutomatonParams& p, std::uint64_t checkpointEvery = 100);
    /// Density at time t >= 0 (seconds): lerp of the smoothed steps floor(t / dt) and the next.
    void densityAt(double t, DensityGrid& out);
    const AutomatonState& state() const { return state_; }
    const AutomatonParams& params() const { return p_; }

  private:
    void advanceTo(std::uint64_t n); ///< state_ at step n, smoothed grids of n - 1 and n
    AutomatonParams p_;
    AutomatonState state_;
    std::uint64_t checkpointEvery_;
    std::vector<AutomatonState> checkpoints_; ///< at steps 0, k, 2k, ...
    Workspace ws_;
    std::vector<std::uint8_t> smoothScratch_;
    DensityGrid prev_, cur_;
    bool havePrev_ = false;
};

} // namespace nimbus::sim
