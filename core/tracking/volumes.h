/// @file volumes.h
/// @brief Several volumes, each placed any number of times (instances with a transform and a
/// density scale), and what a ray sees of them: the summed density and merged majorant segments.
///
/// Two levels of empty-space skipping (the hierarchy of the VDB issue): an InstanceQuery (Embree
/// in plugin/geom, or a linear scan here) finds the instance boxes a ray crosses; inside each box
/// the ray, taken to the volume's own space, walks that volume's majorant grid (filled from the
/// NanoVDB tree's node maxima for grids). Where instances overlap their extinctions add, and so do
/// their majorants. For comparison, `coarse` is one world-space grid over all instances without
/// the first level. Affine transforms keep the ray parameter: t means the same distance in world
/// and local space, so steps and optical depths need no conversion.
#pragma once

#include <memory>
#include <vector>

#include <glm/glm.hpp>

#include "core/accel.h"
#include "core/cancel.h"
#include "core/fields/field.h"
#include "core/tracking/majorant.h"
#include "core/tracking/motion_blur.h"

namespace nimbus {

struct VolumeInstance {
    int volume = 0;
    glm::mat4 worldFromLocal{1.0f};
    glm::mat4 localFromWorld{1.0f};
    float density = 1.0f;
    bool identity = true; ///< worldFromLocal is the identity
    Box worldBounds;      ///< world box around the volume's transformed bounds
};

/// The transform of an instance description: translate * Rz * Ry * Rx * scale.
glm::mat4 instanceTransform(const InstanceDesc& d);

/// More than one placement, or a transformed one: the scene needs instance queries.
bool isInstanced(const SceneDesc& s);
/// Whether a placement uses volume `v` (0 = `field`); without placements only `field` is.
bool isPlaced(const SceneDesc& s, int v);

/// The volumes of one frame, their majorant grids and their instances.
struct VolumeSet {
    std::vector<Field> fields;        ///< one per volume, in its own space
    std::vector<MajorantGrid> grids;  ///< per volume; used where `useGrid`
    std::vector<char> useGrid;        ///< per volume
    std::vector<float> wholeMajorant; ///< per volume: bound over all its bounds
    /// per volume (empty: none): an SDF cloud walked by sphere tracing instead of its grid
    std::vector<char> traceSdf;
    std::vector<VolumeInstance> instances;
    Box bounds;                           ///< union of the instances' world boxes
    std::unique_ptr<InstanceQuery> query; ///< null: linear scan over `instances`
    MajorantGrid coarse;                  ///< world grid, used when `useCoarse`
    bool useCoarse = false;
    /// Set by the host to stop the frame (core/cancel.h): ray walks over this set end early.
    const std::atomic<bool>* cancel = nullptr;
    /// Motion blur (setShutter): the shutter, and per volume the box where it can hold density
    /// over it (empty: no blur, every volume's own bounds).
    Shutter shutter;
    std::vector<Box> sweptBounds;

    /// Where volume v can hold density during the frame (its bounds, swept when blurred).
    const Box& boundsOf(size_t v) const {
        return v < sweptBounds.size() ? sweptBounds[v] : fields[v].bounds();
    }

    /// One untransformed instance of one volume: the common case, no query needed.
    bool single() const { return instances.size() == 1 && instances[0].identity; }
    /// Summed density at a world point (linear scan; for tests and light volumes).
    float densityAt(vec3 p) const;
    /// Upper bound of the summed density over a world box (linear scan).
    float majorantOver(const Box& b) const;
};

/// Makes the instances of `descs` (empty: volume 0 once, untransformed) and their world boxes.
/// Instances of empty volumes are left out. Throws std::invalid_argument for a bad volume index.
std::vector<VolumeInstance> makeInstances(const std::vector<Field>& fields,
                                          const std::vector<InstanceDesc>& descs);

/// Opens the shutter (motion blur): the moving volumes' swept bounds, and the instances' world
/// boxes and `bounds` grown to them. Call after makeInstances, before the majorant grids.
void setShutter(VolumeSet& vs, const Shutter& shutter);

/// Builds the world-space coarse grid over all instances (each instance adds its bound to the
/// cells its box overlaps; over vs.shutter when it is open).
MajorantGrid buildCoarseMajorantGrid(const VolumeSet& vs, float cell, float padding = 0.05f);

/// What one ray sees of a VolumeSet between tmin and tmax. density() must be asked at
/// non-decreasing t (as marching and tracking do); nextSegment() yields non-empty majorant
/// segments in order, the sum over the instances active on each.
class RayVolumes {
  public:
    /// False when the ray crosses no instance (or the frame is cancelled).
    bool begin(const VolumeSet& vs, const Ray& ray, float tmin, float tmax);
    float tIn() const { return tIn_; }
    float tOut() const { return tOut_; }
    float density(float t);
    /// The density at t, looked at ahead of the queries: density() may still be asked at any t
    /// from `from` on (march looks at a step's sample, then may split the step from its start).
    /// The instances whose spans end before `from` are done with, as density() would be.
    float densityAhead(float t, float from);
    bool nextSegment(MajorantSegment& seg);
    /// The density bound of the majorant-grid cells that hold the point at t, summed over the
    /// instances there (0 outside every grid): the volumes' own grids, read whether or not the
    /// walk skips with them (march builds them for render.step_tau; 0 where none is built).
    float cellMajorant(float t) const;
    /// The time offset (seconds from the frame's time) of the densities asked from now on:
    /// motion blur, one per camera sample. 0 (the default): the frame's time.
    void setTime(float dt) { time_ = dt; }
    float time() const { return time_; }
    /// Iterator-style adapter for marchSegments()
    bool next(MajorantSegment& seg) { return nextSegment(seg); }
    /// Asked every CancelPoll::kEvery steps by marchSegments and sampleTmaj (core/cancel.h).
    bool cancelled() { return poll_.now(); }

  private:
    struct Span {
        int instance;
        float t0, t1;
        Ray local;
    };
    struct Walker {
        MajorantIterator it;
        MajorantSegment seg;
        float scale;
    };
    const VolumeSet* vs_ = nullptr;
    Ray ray_{};
    float tIn_ = 0.0f, tOut_ = 0.0f;
    std::vector<Span> spans_; ///< sorted by t0
    std::vector<InstanceHit> hits_;
    size_t densityNext_ = 0;
    std::vector<int> densityActive_;
    size_t segNext_ = 0;
    std::vector<Walker> walkers_;
    float cur_ = 0.0f;
    float time_ = 0.0f;
    bool coarseStarted_ = false;
    MajorantIterator coarse_{nullptr, Box{}, Ray{}, 0.0f, 0.0f, 0.0f};
    CancelPoll poll_;
    /// One untransformed instance (VolumeSet::single, no coarse grid): its walk and lookups
    /// without the span and walker lists (the same segments and densities; a path tracer starts
    /// a ray at every collision, and that bookkeeping was a tenth of a thick reference's time)
    bool single_ = false;
    bool oneStarted_ = false;
    const Field* oneField_ = nullptr;
    Walker one_{MajorantIterator{nullptr, Box{}, Ray{}, 0.0f, 0.0f, 0.0f}, MajorantSegment{}, 1.0f};
    /// the single walk's next segment, started on first use
    bool nextSingle(MajorantSegment& seg);
};

} // namespace nimbus
