/// @file majorant.h
/// @brief The majorant structure: a coarse grid of density upper bounds over a field's bounds,
/// walked with a 3D DDA (Amanatides & Woo 1987) that yields `{t0, t1, sigma_maj}` segments.
///
/// This is Olajos' "preprocessed cloud structure" and Fizimayer's density maps done
/// conservatively: every cell holds Field::majorant() of the cell grown by a small padding, so
/// a sample whose position rounds into a neighbouring cell is still covered, and a cell whose
/// bound is 0 provably holds no cloud. Written once; every integrator walks it.
#pragma once

#include <atomic>

#include <cstdint>
#include <vector>

#include "core/fields/field.h"
#include "core/tracking/motion_blur.h"

namespace nimbus {

struct MajorantGrid {
    Box bounds;
    ivec3 res{0};
    vec3 cellSize{0.0f};
    std::vector<float> maj; ///< density bound per cell, x fastest

    /// Empty-space skipping: blocks of kBlock^3 cells; per block, 0 when it holds a non-zero
    /// cell, else its distance in blocks (Chebyshev, at most 255) to the nearest block that
    /// does: the cube of 2 d - 1 blocks around it is empty. Left empty (no skipping) until
    /// buildBlocks(); the builders below call it.
    static constexpr int kBlock = 4;
    ivec3 blockRes{0};
    std::vector<std::uint8_t> blockDistance;

    float at(ivec3 c) const { return maj[(size_t(c.z) * res.y + c.y) * res.x + c.x]; }
    /// The bound of the cell holding the point p: 0 outside the grid, or where it was not built.
    float boundAt(vec3 p) const {
        if (maj.empty()) return 0.0f;
        const vec3 u = (p - bounds.lo) / cellSize;
        if (!(u.x >= 0.0f && u.y >= 0.0f && u.z >= 0.0f)) return 0.0f; // NaN too
        const ivec3 c(u);
        if (c.x >= res.x || c.y >= res.y || c.z >= res.z) return 0.0f;
        return at(c);
    }
    /// Distance of the block holding cell c (0: not empty).
    int blockDistanceAt(ivec3 c) const {
        const ivec3 b = c / kBlock;
        return blockDistance[(size_t(b.z) * blockRes.y + b.y) * blockRes.x + b.x];
    }
    /// Fills blockDistance from maj (call again after changing maj).
    void buildBlocks();
    size_t cellCount() const { return maj.size(); }
    /// Fraction of cells whose bound is 0 (skippable).
    double emptyFraction() const;
    /// The box of the cells whose bound is above 0: no density lies outside it. Empty (a
    /// default Box) when no cell has one.
    Box occupiedBounds() const;
};

/// Cells per axis of a majorant grid over an extent `ext` with cells of at most `cell`: at
/// least 1 (buildMajorantGrid's; its cells are ext / res).
ivec3 majorantResolution(vec3 ext, float cell);

/// Builds the grid over field.bounds() with cells of about `cell` world units (TBB-parallel).
/// `padding` grows each cell by this fraction of its size before bounding. Stops early (the
/// grid incomplete) once `cancel` is set (core/cancel.h).
/// With an open `shutter` and a moving field (motion blur, core/tracking/motion_blur.h) the
/// grid spans sweptBounds() and each cell holds sweptMajorant(): a bound over the shutter.
/// `tight` (the path tracer's grids), with the shutter closed, where the field has
/// Field::tightMajorant (grids with a dense copy): each cell holds the largest voxel its
/// stencils read instead of the maxima of the tree nodes it overlaps. Every null collision of
/// delta and ratio tracking costs a density lookup; these bounds halve them on a thick cloud.
MajorantGrid buildMajorantGrid(const Field& field, float cell, float padding = 0.05f,
                               const std::atomic<bool>* cancel = nullptr,
                               const Shutter& shutter = {}, bool tight = false);

/// A stretch [t0, t1] of a ray with density bound sigma_maj > 0.
struct MajorantSegment {
    float t0;
    float t1;
    float sigma_maj;
};

/// Walks the non-empty cells of a grid along a ray, in order, leaping over blocks of empty cells
/// in one step (two-level DDA) when the grid has its blocks. With a null grid it yields the
/// whole [tmin, tmax] clipped to `bounds` once (no skipping), with sigma_maj = `wholeMajorant`.
class MajorantIterator {
  public:
    MajorantIterator(const MajorantGrid* grid, const Box& bounds, const Ray& ray, float tmin,
                     float tmax, float wholeMajorant);
    /// Segments of an SDF cloud by sphere tracing (Hart 1996) its 1-Lipschitz bound, no grid:
    /// from the box entry the walk leaps by sdf.skip() (no density closer than that, the
    /// displacement amplitude included) until it reaches the support; there it yields segments
    /// of length L (local units) at sdf.majorantBall(bound, L), L the length over which the
    /// support certainly continues or a minimum of about half the soft shell (falloff +
    /// displacement). The ray's direction need not be unit (instances): t steps are local
    /// lengths over |d|.
    MajorantIterator(const SdfCloudField& sdf, const Box& bounds, const Ray& ray, float tmin,
                     float tmax);
    bool next(MajorantSegment& seg);
    /// Bound evaluations so far (traced walks only).
    std::uint64_t traceSteps() const { return steps_; }

  private:
    bool nextTraced(MajorantSegment& seg);
    /// From inside an empty block at distance d: moves the walk to the first cell past the
    /// empty cube of 2 d - 1 blocks around it.
    void leap(int d);
    /// The cell holding coordinate x along axis a (unclamped).
    int cellOf(int a, float x) const;
    /// Ray parameter where it meets the grid plane `edge` (a cell index) of axis a.
    float edgeT(int a, int edge) const;
    /// Moves the walk into cell c along axis a and sets where it leaves it.
    void enterCell(int a, int c);

    const MajorantGrid* grid_;
    Ray ray_{};
    float t_ = 0.0f, tEnd_ = 0.0f;
    bool done_ = true;
    float whole_ = 0.0f;
    ivec3 cell_{0}, step_{0};
    vec3 tNext_{0.0f}, tDelta_{0.0f};
    const SdfCloudField* sdf_ = nullptr;
    float dirLength_ = 1.0f, minSegment_ = 0.0f;
    std::uint64_t steps_ = 0;
};

} // namespace nimbus
