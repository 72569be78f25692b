/// @file vdb_reader.h
/// @brief Reading density grids from OpenVDB files into NanoVDB (what VFX pipelines produce:
///        Houdini, Blender/Mantaflow, EmberGen, OpenVDB 1.1 up to 12.x files).
///
/// Only the grid asked for is read (DESIGN.md, demand 3: "unused grids are never read"): the
/// file is opened with delayed loading, its grid descriptors are scanned, and exactly one grid is
/// read with `openvdb::io::File::readGrid(name)`; `LoadedVdbGrid::gridsRead` counts the grids
/// whose tree was read, so tests can prove it. The OpenVDB grid is converted once to a float
/// NanoVDB grid with node-level statistics (min, max, average, standard deviation of the ACTIVE
/// values of every leaf, internal node and the root), which the renderer uses as majorants.
///
/// What is accepted and what is refused (every refusal is a VdbError whose message starts with
/// `<path>: grid "<name>": ` and says what was found):
///  - value types: float, half (float stored as 16 bits: read as float), double (converted to
///    float; values beyond the float range become Inf and are then sanitised, see below).
///    Vector grids (vec3s, vec3d, ...) and integer/bool/point grids are refused (velocity
///    grids are read by loadVdbVelocity(), vdb_velocity.h, through the same child process).
///  - grid classes: fog volume and unknown are accepted; a level set is refused unless
///    VdbLoadOptions::levelsetToFog, which converts it by the rules of
///    openvdb::tools::sdfToFogVolume (interior = 1 as active tiles, the inner half of the narrow
///    band ramps from 0 at the surface to 1, outside 0, background 0; re-implemented in a few
///    lines because LevelSetUtil.h costs ~12 s and ~500 MB to compile, and checked equal value by
///    value against sdfToFogVolume on the Gaffer sphere and on spheres of radius 20..300 voxels).
///  - transforms: any affine (linear) map, including non-uniform scale and rotation; frustum
///    (non-linear) transforms are refused.
///  - a missing grid name: the message lists every grid in the file with its value type.
///  - files that are missing, empty, not VDB or truncated, and files whose header, grid list or
///    grid metadata are corrupted: VdbError, never a crash or a hang. Before OpenVDB reads
///    anything, the header, every grid descriptor and the chosen grid's metadata are scanned
///    with each length and offset checked against the file (OpenVDB trusts them: a garbage
///    string length makes it allocate gigabytes and loop for a minute).
///  - files whose TREE data is corrupted (bit flips inside the blosc/zip-compressed leaf
///    buffers, the node masks, the leaf counts): OpenVDB 10.0.1 trusts these too, and can crash
///    (io::bloscFromStream reads a chunk of the size the file claims into a fixed leaf buffer
///    before checking that size, a heap overflow; DelayedLoadMetadata::getMask asserts on a
///    corrupted leaf count, and Debian's build keeps asserts), loop or allocate gigabytes. So by
///    default (VdbLoadOptions::isolate) the grid is read in a process of its own, see
///    "Isolation" below: a crash, a hang or an exhausted memory limit there becomes a VdbError
///    such as `x.vdb: grid "density": the OpenVDB reader crashed (SIGSEGV, segmentation fault)
///    while reading the grid: the file is corrupt`.
///
/// Isolation (VdbLoadOptions::isolate, on by default): loadVdbGrid() runs the reader executable,
/// nimbus-vdb-reader (built beside the nimbus command and libnimbus.so; NIMBUS_VDB_READER names
/// another), by a fork and an immediate exec: between the two the child makes only system calls,
/// so no lock that another thread of the caller held at the fork (oneTBB's, OpenVDB's, the
/// allocator's) can stop it, and the reader starts with a TBB of its own. It reads the request
/// (file, grid, options) on stdin, reads and converts the grid exactly as the in-process path
/// does, and writes the NanoVDB buffer and every other field of LoadedVdbGrid into a pipe; the
/// parent rebuilds LoadedVdbGrid and checks the NanoVDB grid (every node offset inside the
/// buffer, finite non-negative values) before anything traverses it. A VdbError of the reader
/// (a refusal: a level set, a missing grid, ...) reaches the caller with its exact message. The
/// reader runs with an address-space limit (VdbLoadOptions::memoryLimitBytes beyond what it
/// maps at its start, its libraries; by default the machine's physical memory), no core dumps, an
/// out-of-memory-killer score of 1000 (it goes first, not the caller) and is killed after
/// VdbLoadOptions::timeoutSeconds. Its stderr is captured: forwarded to the caller's stderr
/// after a normal end, quoted in the message after a crash. The memory it peaked at is returned
/// when it exits. Cost: one process start (about 25 ms with OpenVDB's libraries) and one copy of
/// the NanoVDB grid through a pipe (docs/vdb.md, "Corrupt files and the child process"). With
/// isolate = false the grid is read in the calling process: for trusted files only.
///
/// Sanitising (counted, one warning per kind): NaN/Inf values become 0; negative densities are
/// clamped to 0; inactive voxels and tiles whose value is not 0 are set to 0; a non-zero
/// background is set to 0. Nimbus' density is therefore "the active values, 0 elsewhere", so the
/// NanoVDB node statistics (which see only active values) are valid majorants for trilinear
/// sampling. An empty grid loads as an empty NanoVDB grid with a warning.
///
/// Active tiles are kept as tiles: openToNanoVDB copies root and internal-node tiles (value and
/// active state), NanoVDB's ReadAccessor returns the tile value for every voxel a tile covers,
/// so point and trilinear sampling see them, and the node statistics include them (each tile
/// weighted by the voxels it covers). They are NOT densified into leaves: a tile at the upper
/// internal level covers 128^3 voxels, densifying could multiply memory. Code that walks leaf
/// nodes only would miss them: walk the tree, or use the accessor (getDim() reports the size of
/// the node or tile that holds a coordinate, as NanoVDB's HDDA does).
///
/// Coordinates: OpenVDB and NanoVDB sample at voxel CENTRES: index (i,j,k) is the centre of
/// voxel (i,j,k), which covers [i-0.5, i+0.5] x ... in index space. worldFromIndex maps index
/// coordinates to world space (column vectors: world = worldFromIndex * vec4(ijk, 1)).
///
/// @code
///   using namespace nimbus::vdb;
///   try {
///       LoadedVdbGrid g = loadVdbGrid({.path = "smoke.vdb", .gridName = "density"});
///       for (const std::string& w : g.warnings) std::cerr << "warning: " << w << "\n";
///       const nanovdb::FloatGrid* grid = g.grid();          // trilinear: SampleFromVoxels<..,1>
///       glm::vec3 ijk = glm::vec3(g.indexFromWorld * glm::vec4(p, 1.0f));
///   } catch (const VdbError& e) {
///       std::cerr << e.what() << "\n"; // smoke.vdb: grid "density": is a level set ...
///   }
/// @endcode
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/GridHandle.h>
#include <nanovdb/util/HostBuffer.h>

#include "core/geometry.h"
#include "plugin/vdb/vdb_error.h"

namespace nimbus::vdb {

/// What to read.
struct VdbLoadOptions {
    std::string path;                 ///< the .vdb file
    std::string gridName = "density"; ///< the one grid to read (names are case-sensitive)
    bool levelsetToFog = false;       ///< convert a level set to a fog volume (as
                                      ///< openvdb::tools::sdfToFogVolume) instead of refusing it
    /// Read in the reader process (see "Isolation" in the file comment): a corrupted file
    /// that crashes or hangs OpenVDB's reader gives a VdbError instead of ending the caller.
    /// false reads in the calling process: trusted files only.
    bool isolate = true;
    double timeoutSeconds = 600.0;      ///< isolate: kill the child after this long (a hang)
    std::uint64_t memoryLimitBytes = 0; ///< isolate: address space the reader may map beyond its
                                        ///< libraries (0 = the machine's physical memory)
};

/// One grid in a file, as its descriptor says (no tree is read to list these).
struct VdbGridInfo {
    std::string name;
    std::string valueType;       ///< "float", "half", "double", "vec3s", "int32", "bool", ...
    std::uint64_t dataBegin = 0; ///< byte range of the grid's metadata, transform and tree
    std::uint64_t dataEnd = 0;   ///< in the file (its descriptor precedes dataBegin)
};

/// A density grid read from a VDB file and converted to NanoVDB.
struct LoadedVdbGrid {
    /// The float NanoVDB grid (one HostBuffer), with node-level min/max/avg/stddev statistics
    /// of active values (nanovdb::StatsMode::All) and a partial checksum.
    nanovdb::GridHandle<nanovdb::HostBuffer> handle;

    glm::mat4 worldFromIndex{1.0f}; ///< index (voxel centres) -> world, column vectors
    glm::mat4 indexFromWorld{1.0f}; ///< its inverse (computed in double precision)
    glm::vec3 voxelSize{1.0f};      ///< world length of the three index axes

    /// World-space axis-aligned box around the active voxels and tiles, each voxel counted as
    /// its cell [ijk-0.5, ijk+0.5] (the 8 corners of the index box, transformed). Empty (lo = hi
    /// = 0) for an empty grid. @note Trilinear sampling is non-zero up to half a voxel beyond this
    /// box (between the last active centre and the next, inactive, one): pad by half a voxel.
    nimbus::Box worldBounds;
    glm::ivec3 indexMin{0};  ///< inclusive index bounds of the active values;
    glm::ivec3 indexMax{-1}; ///< indexMin > indexMax when the grid is empty

    std::string path;            ///< the file
    std::string gridName;        ///< the grid's name in the file
    std::string sourceValueType; ///< "float", "double" or "half" (as stored in the file)
    std::string gridClass;       ///< as stored: "fog volume", "unknown" or "level set" (converted)
    std::uint32_t fileVersion = 0; ///< VDB file format version: 222 (OpenVDB 1.1) ... 224 (12.x)
    std::string libraryVersion;    ///< "major.minor" of the OpenVDB library that wrote the file
    std::string creator;           ///< file-level "creator" metadata ("" when absent)

    std::uint64_t activeVoxelCount = 0; ///< active voxels, including those covered by tiles
    std::uint64_t activeTileCount = 0;  ///< active tiles (root and internal nodes)
    std::uint64_t leafCount = 0;        ///< leaf nodes (8^3 blocks)
    float minValue = 0.0f;              ///< smallest active value after sanitising (0 when empty)
    float maxValue = 0.0f;              ///< largest active value after sanitising (0 when empty)

    /// Grids whose tree was read from the file: 1 for every successful load (the other grids'
    /// data is never touched). gridsInFile is how many the file holds.
    int gridsRead = 0;
    int gridsInFile = 0;
    std::vector<VdbGridInfo> gridsInFileInfo; ///< every grid of the file, in file order

    std::uint64_t nonFiniteCount = 0;       ///< NaN/Inf values replaced by 0
    std::uint64_t negativeCount = 0;        ///< negative values clamped to 0
    std::uint64_t inactiveNonZeroCount = 0; ///< inactive voxels/tiles whose value was set to 0
    std::vector<std::string> warnings;      ///< "<path>: grid "<name>": ..." one per issue

    /// The NanoVDB grid (never null after a successful load, even when empty).
    const nanovdb::FloatGrid* grid() const { return handle.grid<float>(); }
    bool empty() const { return activeVoxelCount == 0; }
};

/// Reads options.gridName from options.path (see the file comment for what is accepted), in a
/// child process unless options.isolate is false.
/// Thread-safe: independent calls may run concurrently.
/// @throws VdbError for every refusal and every failure (file, format, grid, memory, a crash,
///         hang or invalid reply of the child process).
LoadedVdbGrid loadVdbGrid(const VdbLoadOptions& options);

/// One grid loadVdbGrid() read (vdbRecentReads).
struct VdbRead {
    std::string path;     ///< the file
    std::string gridName; ///< the grid asked for
    int gridsRead = 0;    ///< trees read from the file for it (LoadedVdbGrid::gridsRead)
};

/// Grids loadVdbGrid() has read in this process (failed loads are not counted), and the last
/// kVdbRecentReads of them, oldest first: they prove what a frame read, e.g. that grids no scene
/// names and volumes no instance places are never read (tests/test_plan_obeyed.cpp). Kept
/// bounded for processes that render millions of frames. Thread-safe.
constexpr std::size_t kVdbRecentReads = 256;
std::uint64_t vdbReadCount();
std::vector<VdbRead> vdbRecentReads();

/// Lists the grids of a VDB file (names and value types) from its grid descriptors, without
/// reading any tree. @throws VdbError when the file cannot be opened, is not a VDB file or is
/// truncated.
std::vector<VdbGridInfo> listVdbGrids(const std::string& path);

/// The file of one frame of a per-frame VDB sequence.
struct VdbFrameFile {
    std::string path;    ///< the file to read
    int frame = 0;       ///< the frame asked for
    int sourceFrame = 0; ///< the frame whose file is used (< frame when held)
    bool held = false;   ///< true when an earlier frame's file stands in for a missing one
    std::string warning; ///< set when held: names both frames and the file used
};

/// Expands @p pattern for @p frame (`smoke.####.vdb`, Houdini `$F4`, `$F`; see
/// io::expandFramePattern) and checks that the file exists. A pattern without a frame token names
/// the same file for every frame.
/// When the frame's file is missing: without @p hold, throws VdbError naming the pattern, the
/// frame and the missing path; with @p hold, uses the nearest EARLIER frame whose file exists
/// (searching back at most @p maxHoldFrames frames: one directory listing, or one stat() per
/// frame when the frame token is in a directory name) and sets `held` and `warning`; throws when
/// there is none.
/// @throws VdbError as above; std::invalid_argument from expandFramePattern for a bad token.
VdbFrameFile resolveVdbFrame(const std::string& pattern, int frame, bool hold = false,
                             int maxHoldFrames = 100000);

} // namespace nimbus::vdb
