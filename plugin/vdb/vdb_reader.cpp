/// @file vdb_reader.cpp
/// @brief loadVdbGrid() and listVdbGrids() (see vdb_reader.h). The only translation unit that
///        reads OpenVDB files: OpenVDB's headers cost ~20 s and ~600 MB per translation unit.
#include "plugin/vdb/vdb_reader.h"
#include "plugin/vdb/vdb_isolate.h"
#include "plugin/vdb/vdb_velocity.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/GridDescriptor.h>

#include <nanovdb/util/OpenToNanoVDB.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cctype>
#include <deque>
#include <mutex>
#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <new>
#include <sstream>
#include <system_error>

namespace nimbus::vdb {

namespace {

namespace fs = std::filesystem;

std::string quoted(const std::string& s) {
    return "\"" + s + "\"";
}

/// "<path>: grid "<name>": "
std::string gridContext(const std::string& path, const std::string& grid) {
    return path + ": grid " + quoted(grid) + ": ";
}

/// Called inside a catch block of a grid read: rethrows the exception in flight as a VdbError
/// naming the file (`ctx`) and its versions (a VdbError passes unchanged).
[[noreturn]] void rethrowAsVdbError(const std::string& ctx, const std::string& version) {
    try {
        throw;
    } catch (const VdbError&) {
        throw;
    } catch (const std::bad_alloc&) {
        throw VdbError(ctx + "out of memory while reading it" + version +
                       " (a corrupted file, or a grid too large for this machine)");
    } catch (const std::exception& e) {
        throw VdbError(ctx + "OpenVDB could not read it" + version + ": " + e.what() +
                       " (a corrupted or truncated file?)");
    } catch (...) {
        throw VdbError(ctx + "OpenVDB could not read it" + version +
                       ": unknown exception (a corrupted file?)");
    }
}

std::string versionText(std::uint32_t fileVersion, const std::string& library) {
    return "file format version " + std::to_string(fileVersion) + ", written by OpenVDB " + library;
}

/// Edit distance, for "did you mean" suggestions on short grid names.
std::size_t editDistance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diag = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            std::size_t up = row[j];
            bool same =
                std::tolower((unsigned char)a[i - 1]) == std::tolower((unsigned char)b[j - 1]);
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (same ? 0 : 1)});
            diag = up;
        }
    }
    return row[b.size()];
}

/// The byte size of OpenVDB's fixed-size metadata types (openvdb/Metadata.h, Types.h); 0 for
/// strings and types it does not know (read with the stored size).
std::uint32_t fixedMetadataSize(const std::string& type) {
    static const std::pair<const char*, std::uint32_t> sizes[] = {
        {"bool", 1},   {"int32", 4},  {"int64", 8},  {"float", 4},  {"double", 8}, {"vec2i", 8},
        {"vec2s", 8},  {"vec2d", 16}, {"vec3i", 12}, {"vec3s", 12}, {"vec3d", 24}, {"vec4i", 16},
        {"vec4s", 16}, {"vec4d", 32}, {"mat4s", 64}, {"mat4d", 128}};
    for (const auto& [name, size] : sizes)
        if (type == name) return size;
    return 0;
}

/// @p s with bytes outside printable ASCII as \xNN, at most 64 characters (names read from a
/// damaged file go into messages).
std::string printable(const std::string& s) {
    std::string out;
    for (unsigned char c : s.substr(0, 64)) {
        if (c >= 32 && c < 127) {
            out += char(c);
        } else {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\x%02x", c);
            out += buf;
        }
    }
    return s.size() > 64 ? out + "..." : out;
}

/// Reads the structure of a VDB file (header, metadata, grid descriptors, a grid's metadata
/// and transform type) the way OpenVDB lays it out, but with every length and offset checked
/// against the bytes that remain. OpenVDB's own readers trust the lengths they read: a
/// truncated or overwritten file makes them allocate gigabytes for one string or loop for
/// minutes. What passes this scan still goes through OpenVDB, which does the real reading.
class StructureReader {
  public:
    StructureReader(std::istream& is, std::uint64_t fileSize, std::string context)
        : is_(is), fileSize_(fileSize), context_(std::move(context)) {}

    /// The read position; after a failed read (tellg says -1) the end of the file.
    std::uint64_t pos() {
        const std::streamoff p = is_.tellg();
        return p < 0 ? fileSize_ : std::uint64_t(p);
    }
    void seek(std::uint64_t p) {
        if (p > fileSize_) truncated("a position", p - pos());
        is_.clear();
        is_.seekg(std::streamoff(p));
    }
    void setEnd(std::uint64_t end) { end_ = std::min(end, fileSize_); }
    /// Bytes left before the end of the file or of the grid (setEnd).
    std::uint64_t left() { return remaining(); }

    template <class T> T pod(const char* what) {
        if (remaining() < sizeof(T)) truncated(what, sizeof(T));
        T v{};
        is_.read(reinterpret_cast<char*>(&v), sizeof(T));
        if (!is_) truncated(what, sizeof(T));
        return v;
    }
    std::string str(const char* what, std::uint32_t maxLength) {
        const std::uint32_t n = pod<std::uint32_t>(what);
        if (n > remaining()) truncated(what, n);
        if (n > maxLength) {
            corrupted(std::string(what) + " claims " + std::to_string(n) + " characters");
        }
        std::string s(n, '\0');
        is_.read(s.data(), n);
        if (!is_) truncated(what, n);
        return s;
    }
    void skip(std::uint64_t n, const char* what) {
        if (n > remaining()) truncated(what, n);
        is_.seekg(std::streamoff(n), std::ios::cur);
    }
    /// A MetaMap (openvdb::MetaMap::readMeta): count, then name, type name, byte count, bytes.
    /// Returns the value of string metadata @p wanted ("" when absent).
    std::string metaMap(const std::string& wanted = "") {
        const std::uint32_t count = pod<std::uint32_t>("the metadata count");
        if (count > remaining() / 12) { // an entry takes at least 12 bytes
            corrupted("the metadata claims " + std::to_string(count) + " entries");
        }
        std::string value;
        for (std::uint32_t i = 0; i < count; ++i) {
            const std::string name = str("a metadata name", 1u << 16);
            const std::string type = str("a metadata type", 256);
            const std::uint32_t bytes = pod<std::uint32_t>("a metadata size");
            // OpenVDB reads a typed value with the size of its type, not the stored size: a
            // mismatch would misalign every later read (a fuzzed int32 -> int64 type name made
            // it allocate 1.8 GB for the next "string").
            const std::uint32_t expected = fixedMetadataSize(type);
            if (expected != 0 && bytes != expected) {
                corrupted("metadata \"" + printable(name) + "\" of type " + printable(type) +
                          " claims " + std::to_string(bytes) + " bytes, its type takes " +
                          std::to_string(expected));
            }
            if (type == "bool") {
                // OpenVDB copies the byte into a bool: any byte but 0 and 1 is not a valid bool,
                // and code reading it (GridBase::saveFloatAsHalf) is then undefined; ASan saw
                // a string copied past its literal from such a flag (docs/fuzzing.md, find 7)
                const auto b = pod<std::uint8_t>("a bool metadata value");
                if (b > 1)
                    corrupted("metadata \"" + printable(name) + "\" of type bool holds the byte " +
                              std::to_string(b) + ", not 0 or 1");
                continue;
            }
            if (!wanted.empty() && name == wanted && type == "string" && bytes <= 4096) {
                if (bytes > remaining()) truncated("a metadata value", bytes);
                value.resize(bytes);
                is_.read(value.data(), bytes);
                if (!is_) truncated("a metadata value", bytes);
            } else {
                skip(bytes, "a metadata value");
            }
        }
        return value;
    }

    [[noreturn]] void truncated(const std::string& what, std::uint64_t wantedBytes) {
        if (wantedBytes == 0) // the size is not known (a header read that ran out)
            throw VdbError(context_ + "the file is truncated: " + what +
                           " ends past the end of "
                           "the file, which has only " +
                           std::to_string(fileSize_) + " bytes" + version_);
        if (end_ < fileSize_) {
            corrupted(what + " needs " + std::to_string(wantedBytes) + " bytes at byte " +
                      std::to_string(pos()) + ", past the end of the grid (byte " +
                      std::to_string(end_) + ")");
        }
        throw VdbError(context_ + "the file is truncated: " + what + " needs " +
                       std::to_string(wantedBytes) + " bytes at byte " + std::to_string(pos()) +
                       " but the file has only " + std::to_string(fileSize_) +
                       " bytes (an interrupted copy or write?)" + version_);
    }
    [[noreturn]] void corrupted(const std::string& what) {
        throw VdbError(context_ + "corrupted file: " + what + version_);
    }
    void setVersionText(std::string v) { version_ = std::move(v); }
    void setContext(std::string c) { context_ = std::move(c); }

  private:
    std::uint64_t remaining() {
        const std::uint64_t p = pos();
        return (is_ && p <= end_) ? end_ - p : 0;
    }
    std::istream& is_;
    std::uint64_t fileSize_;
    std::uint64_t end_ = fileSize_;
    std::string context_;
    std::string version_;
};

/// The header and the grid descriptors of a file, read as openvdb::io::File::open reads them.
struct DescriptorScan {
    std::uint32_t fileVersion = 0;
    std::string libraryVersion;
    std::string creator;
    std::vector<VdbGridInfo> grids;
    bool checked = true; ///< false for pre-2012 files without grid offsets (nothing checked)
};

class DescriptorScanner : private openvdb::io::Archive {
    /// The bytes of one value of a grid's tree as its root node stores it (a half grid's
    /// root holds floats); 0 for value types not checked.
    static std::uint32_t rootValueBytes(const std::string& valueType) {
        static const std::pair<const char*, std::uint32_t> sizes[] = {
            {"float", 4}, {"half", 4},   {"double", 8}, {"int32", 4},  {"int64", 8},
            {"bool", 1},  {"vec3s", 12}, {"vec3h", 12}, {"vec3d", 24}, {"vec3i", 12}};
        for (const auto& [name, size] : sizes)
            if (valueType == name) return size;
        return 0;
    }

    /// The transform and the root node's tile table of a grid (openvdb::math::Transform::read,
    /// TreeBase::readTopology, RootNode::readTopology), from the transform's type name on. OpenVDB
    /// reads each root tile's active flag, and a bool grid's values, straight into a bool: a
    /// byte other than 0 and 1 is undefined behaviour in every later use (UBSan in
    /// RootNode.h, docs/fuzzing.md find 8), and a corrupted tile count makes it loop billions
    /// of times. Transforms OpenVDB cannot read are left to its own error, later.
    void rootTiles(StructureReader& r, std::ifstream& is, const VdbGridInfo& grid) {
        const std::uint32_t valueBytes = rootValueBytes(grid.valueType);
        if (valueBytes == 0) return;
        try {
            openvdb::math::Transform transform;
            transform.read(is); // fixed-size maps; the type name was checked above
        } catch (const openvdb::Exception&) {
            return;
        }
        if (!is) return; // a truncated transform: OpenVDB says so when it reads the grid
        r.pod<std::int32_t>("the tree's buffer count");
        r.skip(valueBytes, "the background value");
        const auto tiles = r.pod<std::uint32_t>("the root node's tile count");
        const auto children = r.pod<std::uint32_t>("the root node's child count");
        const std::uint64_t tileBytes = 12 + valueBytes + 1; // coordinates, value, active flag
        if (tiles > r.left() / tileBytes)
            r.corrupted("the root node claims " + std::to_string(tiles) + " tiles of " +
                        std::to_string(tileBytes) + " bytes in the " + std::to_string(r.left()) +
                        " bytes left of the grid");
        const bool boolValues = grid.valueType == "bool";
        auto flag = [&](const char* what, std::uint32_t tile) {
            const auto b = r.pod<std::uint8_t>(what);
            if (b > 1)
                r.corrupted(std::string(what) + " of root tile " + std::to_string(tile + 1) +
                            " of " + std::to_string(tiles) + " holds the byte " +
                            std::to_string(b) + ", not 0 or 1");
        };
        for (std::uint32_t t = 0; t < tiles; ++t) {
            r.skip(12, "a root tile's coordinates");
            if (boolValues)
                flag("the bool value", t);
            else
                r.skip(valueBytes, "a root tile's value");
            flag("the active flag", t);
        }
        if (children > r.left() / 12)
            r.corrupted("the root node claims " + std::to_string(children) +
                        " child nodes in the " + std::to_string(r.left()) +
                        " bytes left of the grid");
    }

  public:
    /// Scans @p path; when @p gridToCheck is a grid of the file, also checks that grid's
    /// metadata and transform type (the part of a grid OpenVDB reads with trusted lengths).
    DescriptorScan scan(const std::string& path, const std::string& gridToCheck = "") {
        std::error_code ec;
        fs::file_status st = fs::status(path, ec);
        if (ec || !fs::exists(st)) {
            throw VdbError(path + ": cannot open the file: " +
                           (ec ? ec.message() : std::string("no such file")));
        }
        if (fs::is_directory(st)) throw VdbError(path + ": is a directory, not a VDB file");
        const std::uintmax_t size = fs::file_size(path, ec);
        if (ec) throw VdbError(path + ": cannot read the file size: " + ec.message());
        std::ifstream is(path, std::ios::binary);
        if (!is) throw VdbError(path + ": cannot open the file: " + std::strerror(errno));
        if (size == 0) throw VdbError(path + ": the file is empty (0 bytes), not a VDB file");
        if (size < 16) {
            throw VdbError(path + ": not a VDB file (only " + std::to_string(size) +
                           " bytes, shorter than a VDB header)");
        }

        DescriptorScan out;
        auto streamMeta = std::make_shared<openvdb::io::StreamMetadata>();
        streamMeta->setSeekable(true);
        openvdb::io::setStreamMetadataPtr(is, streamMeta, /*transfer=*/false);
        try {
            readHeader(is); // fixed-size fields only; checks the magic number
        } catch (const openvdb::Exception& e) {
            throw VdbError(path + ": not a VDB file, or a VDB format this OpenVDB (" +
                           std::string(openvdb::getLibraryVersionString()) +
                           ") cannot read: " + e.what());
        }
        StructureReader r(is, size, path + ": ");
        if (!is) r.truncated("the file header", 0);
        openvdb::io::setVersion(is, libraryVersion(), fileVersion()); // for Transform::read
        out.fileVersion = fileVersion();
        out.libraryVersion =
            std::to_string(libraryVersion().first) + "." + std::to_string(libraryVersion().second);
        r.setVersionText(" (" + versionText(out.fileVersion, out.libraryVersion) + ")");
        out.creator = r.metaMap("creator");

        if (!inputHasGridOffsets()) {
            out.checked = false; // pre-2012 layout: nothing to list or check up front
            return out;
        }
        const std::int32_t count = r.pod<std::int32_t>("the grid count");
        if (count < 0 || std::uint64_t(count) > size / 16) {
            r.corrupted("it claims " + std::to_string(count) + " grids");
        }
        std::uint64_t previousEnd = r.pos();
        const VdbGridInfo* toCheck = nullptr;
        bool toCheckIsInstance = false; // an instance shares its parent's tree: none of its own
        out.grids.reserve(std::size_t(count));
        for (std::int32_t i = 0; i < count; ++i) {
            // openvdb::io::GridDescriptor::read: unique name, type, [instance parent],
            // grid, block and end positions.
            r.setContext(path + ": grid #" + std::to_string(i + 1) + ": ");
            const std::string uniqueName = r.str("a grid name", 1u << 16);
            const std::string name = openvdb::io::GridDescriptor::stripSuffix(uniqueName);
            r.setContext(gridContext(path, name));
            std::string type = r.str("a grid type", 1024);
            std::string instanceParent;
            if (out.fileVersion >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING)
                instanceParent = r.str("an instance parent name", 1u << 16);
            const auto gridPos = r.pod<std::int64_t>("the grid offsets");
            const auto blockPos = r.pod<std::int64_t>("the grid offsets");
            const auto endPos = r.pod<std::int64_t>("the grid offsets");
            if (endPos > std::int64_t(size)) {
                throw VdbError(gridContext(path, name) +
                               "the file is truncated: the grid's data ends at byte " +
                               std::to_string(endPos) + " but the file has only " +
                               std::to_string(size) + " bytes (an interrupted copy or write?) (" +
                               versionText(out.fileVersion, out.libraryVersion) + ")");
            }
            if (gridPos < std::int64_t(previousEnd) || blockPos < gridPos || endPos < blockPos) {
                r.corrupted("inconsistent grid offsets (" + std::to_string(gridPos) + ", " +
                            std::to_string(blockPos) + ", " + std::to_string(endPos) + ")");
            }
            previousEnd = std::uint64_t(endPos);
            bool half = false;
            const std::string suffix = "_HalfFloat"; // GridDescriptor.cc HALF_FLOAT_TYPENAME_SUFFIX
            if (type.size() > suffix.size() &&
                type.compare(type.size() - suffix.size(), suffix.size(), suffix) == 0) {
                type.resize(type.size() - suffix.size());
                half = true;
            }
            std::string valueType = "unregistered type " + type;
            if (openvdb::GridBase::isRegistered(type))
                valueType = openvdb::GridBase::createGrid(type)->valueType();
            if (half && valueType == "float") valueType = "half";
            if (half && valueType == "vec3s") valueType = "vec3h";
            out.grids.push_back({name, valueType, std::uint64_t(gridPos), std::uint64_t(endPos)});
            if (name == gridToCheck && !toCheck) {
                toCheck = &out.grids.back();
                toCheckIsInstance = !instanceParent.empty();
            }
            r.seek(std::uint64_t(endPos));
        }
        // The grid's own header (openvdb::io::Archive::readGrid): compression flags, metadata,
        // transform type name. Layout verified for file versions >= 222 (OpenVDB 1.1 and later).
        if (toCheck && out.fileVersion >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) {
            r.setContext(gridContext(path, toCheck->name));
            r.seek(toCheck->dataBegin);
            r.setEnd(toCheck->dataEnd);
            r.pod<std::uint32_t>("the compression flags");
            r.metaMap();
            const std::uint64_t transformAt = r.pos();
            r.str("the transform type", 256);
            if (!toCheckIsInstance) {
                r.seek(transformAt);
                rootTiles(r, is, *toCheck);
            }
        }
        return out;
    }
};

std::string listGrids(const std::vector<VdbGridInfo>& grids) {
    if (grids.empty()) return "the file has no grids";
    std::string s = "the file has " + std::to_string(grids.size()) +
                    (grids.size() == 1 ? " grid: " : " grids: ");
    for (std::size_t i = 0; i < grids.size(); ++i) {
        if (i) s += ", ";
        s += grids[i].name + " (" + grids[i].valueType + ")";
    }
    return s;
}

[[noreturn]] void missingGrid(const std::string& path, const std::string& name,
                              const std::vector<VdbGridInfo>& grids) {
    std::string msg = gridContext(path, name) + "no grid of that name; " + listGrids(grids);
    const VdbGridInfo* best = nullptr;
    std::size_t bestDistance = 3; // suggest only close names
    for (const VdbGridInfo& g : grids) {
        std::size_t d = editDistance(name, g.name);
        if (d < bestDistance) bestDistance = d, best = &g;
    }
    if (best) msg += " (did you mean " + quoted(best->name) + "?)";
    throw VdbError(msg);
}

bool isScalarFloatType(const std::string& t) {
    return t == "float" || t == "half" || t == "double";
}

/// What the sanitising pass over leaf voxels found.
struct SanitizeCounts {
    std::uint64_t nonFinite = 0, negative = 0, inactiveNonZero = 0;
    float mostNegative = 0.0f;
    void add(const SanitizeCounts& o) {
        nonFinite += o.nonFinite;
        negative += o.negative;
        inactiveNonZero += o.inactiveNonZero;
        mostNegative = std::min(mostNegative, o.mostNegative);
    }
    /// Sanitises one value in place.
    void fix(float& v, bool active) {
        if (!active) {
            if (v != 0.0f) v = 0.0f, ++inactiveNonZero; // NaN != 0 is true: NaN lands here too
        } else if (!std::isfinite(v)) {
            v = 0.0f, ++nonFinite;
        } else if (v < 0.0f) {
            mostNegative = std::min(mostNegative, v);
            v = 0.0f, ++negative;
        }
    }
};

/// Replaces NaN/Inf by 0, clamps negatives to 0 and sets inactive values to 0, in every leaf
/// (in parallel: with delayed loading this also decompresses the leaves) and every tile.
SanitizeCounts sanitize(openvdb::FloatTree& tree) {
    using LeafT = openvdb::FloatTree::LeafNodeType;
    std::vector<LeafT*> leaves;
    leaves.reserve(tree.leafCount());
    tree.getNodes(leaves);
    SanitizeCounts counts = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, leaves.size(), 16), SanitizeCounts{},
        [&](const tbb::blocked_range<std::size_t>& r, SanitizeCounts c) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                LeafT& leaf = *leaves[i];
                float* v = leaf.buffer().data(); // loads a delayed-load leaf
                if (!v) throw std::runtime_error("a leaf node could not be loaded");
                const auto& mask = leaf.getValueMask();
                for (openvdb::Index n = 0; n < LeafT::SIZE; ++n) c.fix(v[n], mask.isOn(n));
            }
            return c;
        },
        [](SanitizeCounts a, const SanitizeCounts& b) {
            a.add(b);
            return a;
        });
    // Tiles of the root and the internal nodes (not the leaf voxels, done above).
    auto it = tree.beginValueAll();
    it.setMaxDepth(openvdb::FloatTree::ValueAllIter::LEAF_DEPTH - 1);
    for (; it; ++it) {
        float v = *it;
        const float before = v;
        counts.fix(v, it.isValueOn());
        if (!(v == before)) it.setValue(v);
    }
    return counts;
}

glm::mat4 toGlm(const openvdb::Mat4d& m) {
    // OpenVDB multiplies row vectors (world = [i j k 1] * M, translation in row 3); glm
    // multiplies column vectors and stores columns, so glm[c][r] = M(c, r) is the same layout.
    glm::mat4 g(1.0f);
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) g[r][c] = float(m(r, c));
    return g;
}

/// A float copy of a double grid: leaves copied value by value, tiles re-added at their level.
/// (Cheaper to compile than Tree's value-converting copy constructor, which instantiates a
/// converting copy of every node type.) Values beyond the float range become +-Inf.
openvdb::FloatGrid::Ptr toFloatGrid(const openvdb::DoubleGrid& source) {
    using DoubleLeaf = openvdb::DoubleTree::LeafNodeType;
    using FloatLeaf = openvdb::FloatTree::LeafNodeType;
    const openvdb::DoubleTree& from = source.tree();
    // Made by OpenVDB's grid registry: FloatGrid::create() here would instantiate the whole
    // vtable of Grid<FloatTree> in this translation unit (~10 s of compile time).
    openvdb::FloatGrid::Ptr grid = openvdb::gridPtrCast<openvdb::FloatGrid>(
        openvdb::GridBase::createGrid(openvdb::FloatGrid::gridType()));
    if (!grid) throw VdbError("OpenVDB cannot create a float grid");
    openvdb::FloatTree& to = grid->tree();
    to.root().setBackground(float(source.background()), /*updateChildNodes=*/false);
    std::vector<const DoubleLeaf*> leaves;
    leaves.reserve(from.leafCount());
    from.getNodes(leaves);
    for (const DoubleLeaf* d : leaves) {
        auto f = std::make_unique<FloatLeaf>(d->origin(), 0.0f);
        f->setValueMask(d->getValueMask());
        const double* src = d->buffer().data(); // loads a delayed-load leaf
        if (!src) throw std::runtime_error("a leaf node could not be loaded");
        float* dst = f->buffer().data();
        for (openvdb::Index n = 0; n < FloatLeaf::SIZE; ++n) dst[n] = float(src[n]);
        to.addLeaf(f.release());
    }
    auto it = from.cbeginValueAll();
    it.setMaxDepth(openvdb::DoubleTree::ValueAllIter::LEAF_DEPTH - 1); // tiles only
    for (; it; ++it) {
        if (!it.isValueOn() && *it == source.background()) continue;
        to.addTile(it.getLevel(), it.getCoord(), float(*it), it.isValueOn());
    }
    grid->setTransform(source.transform().copy());
    for (auto m = source.beginMeta(); m != source.endMeta(); ++m)
        grid->insertMeta(m->first, *m->second);
    return grid;
}

/// Level set -> fog volume in place, with the rules of openvdb::tools::sdfToFogVolume (default
/// cutoff): outside (distance > 0) becomes inactive 0; a voxel at distance d <= 0 becomes
/// d / cutoff, active when > 0, where cutoff is the most negative tile value of the lower
/// internal nodes (normally -background, the narrow-band half-width), or the most negative value
/// of the tree when no such tile is negative; an interior tile (value < 0) becomes an active 1.
/// Written here because LevelSetUtil.h costs ~12 s and ~500 MB more to compile; checked against
/// sdfToFogVolume value by value on the Gaffer sphere level set.
void levelSetToFog(openvdb::FloatTree& tree) {
    using LeafT = openvdb::FloatTree::LeafNodeType;
    float minTile = std::numeric_limits<float>::max(); // tiles of the lower internal nodes
    float minLeaf = std::numeric_limits<float>::max(); // every value of every leaf
    for (auto it = tree.cbeginValueAll(); it; ++it) {
        if (it.getLevel() == 0)
            minLeaf = std::min(minLeaf, *it);
        else if (it.getLevel() == 1)
            minTile = std::min(minTile, *it);
    }
    const float minSdf = minTile > 0.0f ? std::min(minTile, minLeaf) : minTile;
    const float cutoff = std::max(minSdf, -std::numeric_limits<float>::max());
    const float weight = 1.0f / cutoff;
    std::vector<LeafT*> leaves;
    leaves.reserve(tree.leafCount());
    tree.getNodes(leaves);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size()), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            LeafT& leaf = *leaves[i];
            leaf.setValuesOff();
            float* v = leaf.buffer().data();
            for (openvdb::Index n = 0; n < LeafT::SIZE; ++n) {
                v[n] = v[n] > 0.0f ? 0.0f : v[n] * weight;
                if (v[n] > 0.0f) leaf.setValueOn(n);
            }
        }
    });
    auto it = tree.beginValueAll();
    it.setMaxDepth(openvdb::FloatTree::ValueAllIter::LEAF_DEPTH - 1); // tiles only
    for (; it; ++it) {
        const bool inside = *it < 0.0f;
        it.setValue(inside ? 1.0f : 0.0f);
        it.setActiveState(inside);
    }
    tree.root().setBackground(0.0f, /*updateChildNodes=*/false);
}

} // namespace

std::vector<VdbGridInfo> listVdbGrids(const std::string& path) {
    detail::initializeOpenVdb();
    try {
        return DescriptorScanner().scan(path).grids;
    } catch (const VdbError&) {
        throw;
    } catch (const std::exception& e) {
        throw VdbError(path + ": cannot list the grids: " + e.what());
    }
}

namespace {

std::mutex g_readsMutex;
std::uint64_t g_readCount = 0;
std::deque<VdbRead> g_reads; // the last kVdbRecentReads loads

} // namespace

std::uint64_t vdbReadCount() {
    std::lock_guard<std::mutex> lock(g_readsMutex);
    return g_readCount;
}

std::vector<VdbRead> vdbRecentReads() {
    std::lock_guard<std::mutex> lock(g_readsMutex);
    return std::vector<VdbRead>(g_reads.begin(), g_reads.end());
}

LoadedVdbGrid loadVdbGrid(const VdbLoadOptions& options) {
    LoadedVdbGrid g = options.isolate ? detail::loadVdbGridIsolated(options)
                                      : detail::loadVdbGridInProcess(options);
    detail::recordVdbRead(g.path, g.gridName, g.gridsRead);
    return g;
}

LoadedVdbGrid detail::loadVdbGridInProcess(const VdbLoadOptions& options, bool checkGrid) {
    detail::initializeOpenVdb(); // idempotent and thread-safe (no colours in the log)
    const std::string& path = options.path;
    const std::string ctx = gridContext(path, options.gridName);

    LoadedVdbGrid out;
    out.path = path;
    out.gridName = options.gridName;

    DescriptorScan scan;
    try {
        scan = DescriptorScanner().scan(path, options.gridName);
    } catch (const VdbError&) {
        throw;
    } catch (const std::bad_alloc&) {
        throw VdbError(path + ": out of memory reading the file header (a corrupted file?)");
    } catch (const std::exception& e) {
        throw VdbError(path + ": cannot read the file header: " + e.what() +
                       " (not a VDB file, or a corrupted one)");
    }
    out.fileVersion = scan.fileVersion;
    out.libraryVersion = scan.libraryVersion;
    out.creator = scan.creator;
    out.gridsInFile = int(scan.grids.size());
    out.gridsInFileInfo = scan.grids;
    const std::string version = " (" + versionText(scan.fileVersion, scan.libraryVersion) + ")";

    // Refuse by the descriptor's type before any tree is read.
    auto found = std::find_if(scan.grids.begin(), scan.grids.end(),
                              [&](const VdbGridInfo& g) { return g.name == options.gridName; });
    if (found == scan.grids.end()) missingGrid(path, options.gridName, scan.grids);
    if (!isScalarFloatType(found->valueType)) {
        const bool vector = found->valueType.rfind("vec", 0) == 0;
        throw VdbError(ctx + "holds " + found->valueType + " values" +
                       (vector ? " (a vector grid, e.g. a velocity field)" : "") +
                       "; a density grid must hold float, half or double values");
    }

    try {
        openvdb::io::File file(path);
        file.setCopyMaxBytes(0); // read in place: no private copy of the file in $TMPDIR
        file.open(/*delayLoad=*/true);
        openvdb::GridBase::Ptr base = file.readGrid(options.gridName);
        ++out.gridsRead;
        if (!base) throw VdbError(ctx + "OpenVDB returned no grid" + version);

        openvdb::FloatGrid::Ptr grid;
        if (auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) {
            grid = f;
            out.sourceValueType = base->saveFloatAsHalf() ? "half" : "float";
        } else if (auto d = openvdb::gridPtrCast<openvdb::DoubleGrid>(base)) {
            grid = toFloatGrid(*d);
            out.sourceValueType = "double";
        } else {
            throw VdbError(ctx + "has grid type " + base->type() + " (" + base->valueType() +
                           " values); a density grid must be a float, half or double grid with "
                           "the standard 5-4-3 tree");
        }
        base.reset();

        const openvdb::GridClass cls = grid->getGridClass();
        out.gridClass = openvdb::GridBase::gridClassToString(cls);
        if (cls == openvdb::GRID_LEVEL_SET) {
            if (!options.levelsetToFog) {
                throw VdbError(ctx + "is a level set (a signed distance field of a surface, not "
                                     "a fog volume of densities); refusing to render distances "
                                     "as density. Set levelset_to_fog = true in the scene's "
                                     "[field] (or the [[volume]]) to convert it to a fog volume "
                                     "(inside = 1, as openvdb::tools::sdfToFogVolume does)");
            }
            if (!(grid->background() > 0.0f)) {
                throw VdbError(ctx + "is a level set whose background (" +
                               std::to_string(grid->background()) +
                               ") is not a positive distance; cannot convert it to a fog volume");
            }
            levelSetToFog(grid->tree());
            grid->setGridClass(openvdb::GRID_FOG_VOLUME);
        } else if (cls == openvdb::GRID_STAGGERED) {
            out.warnings.push_back(ctx + "is marked as a staggered grid (a class for vector "
                                         "grids); read as a density fog volume");
        }

        const openvdb::math::Transform& xform = grid->transform();
        if (!xform.isLinear()) {
            throw VdbError(ctx + "has a non-linear (" + xform.mapType() +
                           ") transform; only affine transforms are supported");
        }
        const openvdb::math::AffineMap::Ptr affine = xform.baseMap()->getAffineMap();
        const openvdb::Mat4d m = affine->getMat4();
        const double det = m.getMat3().det();
        bool finite = true;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) finite = finite && std::isfinite(m(r, c));
        if (!finite || !(std::abs(det) > 0.0)) {
            throw VdbError(ctx + "has a degenerate index-to-world transform (determinant " +
                           std::to_string(det) + ")");
        }

        openvdb::FloatTree& tree = grid->tree();
        const float background = grid->background();
        if (!(background == 0.0f)) {
            out.warnings.push_back(ctx + "background value " + std::to_string(background) +
                                   " is not 0; set to 0 (density outside the active voxels is 0)");
            tree.root().setBackground(0.0f, /*updateChildNodes=*/true);
        }
        SanitizeCounts counts = sanitize(tree);
        out.nonFiniteCount = counts.nonFinite;
        out.negativeCount = counts.negative;
        out.inactiveNonZeroCount = counts.inactiveNonZero;
        if (counts.nonFinite) {
            out.warnings.push_back(ctx + std::to_string(counts.nonFinite) +
                                   " NaN/Inf value(s) replaced by 0");
        }
        if (counts.negative) {
            out.warnings.push_back(ctx + std::to_string(counts.negative) +
                                   " negative value(s) clamped to 0 (most negative " +
                                   std::to_string(counts.mostNegative) + ")");
        }
        if (counts.inactiveNonZero) {
            out.warnings.push_back(ctx + std::to_string(counts.inactiveNonZero) +
                                   " inactive voxel/tile value(s) were not 0 and were set to 0 "
                                   "(only active values are density)");
        }

        out.activeVoxelCount = tree.activeVoxelCount();
        out.activeTileCount = tree.activeTileCount();
        out.leafCount = tree.leafCount();
        if (out.activeVoxelCount == 0) {
            out.warnings.push_back(ctx + "is empty (no active voxels): it loads as an empty "
                                         "volume");
        }

        // Transform, bounds.
        out.worldFromIndex = toGlm(m);
        out.indexFromWorld = toGlm(m.inverse());
        const openvdb::Vec3d vs = affine->voxelSize();
        out.voxelSize = glm::vec3(float(vs[0]), float(vs[1]), float(vs[2]));
        openvdb::CoordBBox bbox;
        if (tree.evalActiveVoxelBoundingBox(bbox) && !bbox.empty()) {
            out.indexMin = glm::ivec3(bbox.min()[0], bbox.min()[1], bbox.min()[2]);
            out.indexMax = glm::ivec3(bbox.max()[0], bbox.max()[1], bbox.max()[2]);
            openvdb::Vec3d lo(std::numeric_limits<double>::max());
            openvdb::Vec3d hi(-std::numeric_limits<double>::max());
            for (int corner = 0; corner < 8; ++corner) {
                openvdb::Vec3d ijk;
                for (int a = 0; a < 3; ++a) {
                    ijk[a] = (corner >> a) & 1 ? bbox.max()[a] + 0.5 : bbox.min()[a] - 0.5;
                }
                const openvdb::Vec3d w = affine->applyMap(ijk);
                lo = openvdb::math::minComponent(lo, w);
                hi = openvdb::math::maxComponent(hi, w);
            }
            out.worldBounds.lo = glm::vec3(float(lo[0]), float(lo[1]), float(lo[2]));
            out.worldBounds.hi = glm::vec3(float(hi[0]), float(hi[1]), float(hi[2]));
        }

        // One conversion to NanoVDB, with min/max/avg/stddev for every node (majorants).
        out.handle =
            nanovdb::openToNanoVDB(*grid, nanovdb::StatsMode::All, nanovdb::ChecksumMode::Partial);
        grid.reset();
        file.close();
        const nanovdb::FloatGrid* nano = out.handle.grid<float>();
        if (!nano) throw VdbError(ctx + "the conversion to NanoVDB produced no float grid");
        if (!nano->hasMinMax() || (out.activeVoxelCount > 0 && !nano->hasBBox())) {
            throw VdbError(ctx + "the NanoVDB grid lacks node statistics (min/max, bbox)");
        }
        if (out.activeVoxelCount > 0) {
            out.minValue = nano->tree().root().minimum();
            out.maxValue = nano->tree().root().maximum();
        }
        // What reaches core/ must be safe to traverse whatever the file held (a corrupted tree
        // that OpenVDB read without noticing must not become out-of-range offsets or NaNs).
        if (checkGrid) {
            const std::string problem = detail::checkNanoGrid(out);
            if (!problem.empty()) throw VdbError(detail::invalidGridMessage(out, problem));
        }
    } catch (...) {
        rethrowAsVdbError(ctx, version);
    }
    return out;
}

// ---------------------------------------------------------------------------------------------
// Velocity (vec3) grids: vdb_velocity.h.

namespace {

bool isVec3Type(const std::string& t) {
    return t == "vec3s" || t == "vec3h" || t == "vec3d";
}

/// Copies the active voxel box of @p grid into @p out.grid (scaled, NaN/Inf set to 0).
template <class GridT>
void denseVelocity(const GridT& grid, const openvdb::CoordBBox& box, float scale, bool extrapolate,
                   LoadedVelocityGrid& out) {
    sim::VelocityGrid& g = out.grid;
    const openvdb::Coord lo = box.min();
    g.res = ivec3(box.dim()[0], box.dim()[1], box.dim()[2]);
    g.v.assign(std::size_t(g.res.x) * std::size_t(g.res.y) * std::size_t(g.res.z), vec3(0.0f));
    auto acc = grid.getConstAccessor();
    std::uint64_t nonFinite = 0;
    float maxSpeed2 = 0.0f;
    for (int z = 0; z < g.res.z; ++z)
        for (int y = 0; y < g.res.y; ++y)
            for (int x = 0; x < g.res.x; ++x) {
                const auto v = acc.getValue(lo.offsetBy(x, y, z));
                vec3 w;
                for (int a = 0; a < 3; ++a) {
                    const double c = double(v[a]) * double(scale);
                    const bool ok = std::isfinite(c) && std::abs(c) <= double(FLT_MAX);
                    if (!ok) ++nonFinite;
                    w[a] = ok ? float(c) : 0.0f;
                }
                g.v[g.index(x, y, z)] = w;
                maxSpeed2 = std::max(maxSpeed2, glm::dot(w, w));
            }
    out.nonFiniteCount = nonFinite;
    out.maxSpeed = std::sqrt(maxSpeed2);
    if (!extrapolate) return;
    // inactive cells take the mean of their known face neighbours, one layer at a time outward
    // from the active voxels (each layer computed from the layers before it: deterministic)
    const std::size_t n = g.v.size();
    std::vector<std::uint8_t> known(n, 0);
    for (int z = 0; z < g.res.z; ++z)
        for (int y = 0; y < g.res.y; ++y)
            for (int x = 0; x < g.res.x; ++x)
                known[g.index(x, y, z)] = acc.isValueOn(lo.offsetBy(x, y, z)) ? 1 : 0;
    const ivec3 step[6] = {ivec3(-1, 0, 0), ivec3(1, 0, 0),  ivec3(0, -1, 0),
                           ivec3(0, 1, 0),  ivec3(0, 0, -1), ivec3(0, 0, 1)};
    auto inside = [&](ivec3 q) {
        return q.x >= 0 && q.y >= 0 && q.z >= 0 && q.x < g.res.x && q.y < g.res.y && q.z < g.res.z;
    };
    std::vector<std::size_t> frontier;
    for (int z = 0; z < g.res.z; ++z)
        for (int y = 0; y < g.res.y; ++y)
            for (int x = 0; x < g.res.x; ++x) {
                if (known[g.index(x, y, z)]) continue;
                for (const ivec3& d : step) {
                    const ivec3 q = ivec3(x, y, z) + d;
                    if (inside(q) && known[g.index(q.x, q.y, q.z)]) {
                        frontier.push_back(g.index(x, y, z));
                        break;
                    }
                }
            }
    std::vector<vec3> values;
    std::vector<std::size_t> next;
    std::uint64_t filled = 0;
    while (!frontier.empty()) {
        values.assign(frontier.size(), vec3(0.0f));
        for (std::size_t k = 0; k < frontier.size(); ++k) {
            const std::size_t i = frontier[k];
            const ivec3 c(int(i % g.res.x), int((i / g.res.x) % g.res.y),
                          int(i / (std::size_t(g.res.x) * g.res.y)));
            vec3 sum(0.0f);
            int count = 0;
            for (const ivec3& d : step) {
                const ivec3 q = c + d;
                if (!inside(q)) continue;
                const std::size_t j = g.index(q.x, q.y, q.z);
                if (known[j] == 1) {
                    sum += g.v[j];
                    ++count;
                }
            }
            values[k] = count > 0 ? sum / float(count) : vec3(0.0f);
        }
        next.clear();
        for (std::size_t k = 0; k < frontier.size(); ++k) {
            g.v[frontier[k]] = values[k];
            known[frontier[k]] = 2; // filled in this layer: known to the next
        }
        for (std::size_t k = 0; k < frontier.size(); ++k) {
            const std::size_t i = frontier[k];
            known[i] = 1;
            const ivec3 c(int(i % g.res.x), int((i / g.res.x) % g.res.y),
                          int(i / (std::size_t(g.res.x) * g.res.y)));
            for (const ivec3& d : step) {
                const ivec3 q = c + d;
                if (!inside(q)) continue;
                const std::size_t j = g.index(q.x, q.y, q.z);
                if (known[j] == 0) {
                    known[j] = 3; // queued
                    next.push_back(j);
                }
            }
        }
        filled += frontier.size();
        frontier.swap(next);
    }
    out.extrapolatedCells = filled;
}

} // namespace

LoadedVelocityGrid detail::loadVdbVelocityInProcess(const VelocityLoadOptions& options) {
    detail::initializeOpenVdb();
    const std::string& path = options.read.path;
    const std::string& name = options.read.gridName;
    const std::string ctx = gridContext(path, name);
    if (!std::isfinite(options.scale))
        throw VdbError(ctx + "the velocity scale " + std::to_string(options.scale) +
                       " is not a finite number");

    LoadedVelocityGrid out;
    out.path = path;
    out.gridName = name;

    DescriptorScan scan;
    try {
        scan = DescriptorScanner().scan(path, name);
    } catch (const VdbError&) {
        throw;
    } catch (const std::bad_alloc&) {
        throw VdbError(path + ": out of memory reading the file header (a corrupted file?)");
    } catch (const std::exception& e) {
        throw VdbError(path + ": cannot read the file header: " + e.what() +
                       " (not a VDB file, or a corrupted one)");
    }
    const std::string version = " (" + versionText(scan.fileVersion, scan.libraryVersion) + ")";
    auto found = std::find_if(scan.grids.begin(), scan.grids.end(),
                              [&](const VdbGridInfo& g) { return g.name == name; });
    if (found == scan.grids.end()) {
        std::vector<VdbGridInfo> vec3;
        for (const VdbGridInfo& g : scan.grids)
            if (isVec3Type(g.valueType)) vec3.push_back(g);
        std::string msg = ctx + "no grid of that name; ";
        if (vec3.empty()) {
            msg += "the file has no vec3 (velocity) grids; " + listGrids(scan.grids);
        } else {
            msg += "its vec3 grids: ";
            for (std::size_t i = 0; i < vec3.size(); ++i)
                msg += (i ? ", " : "") + vec3[i].name + " (" + vec3[i].valueType + ")";
        }
        throw VdbError(msg);
    }
    if (!isVec3Type(found->valueType)) {
        const bool scalar = isScalarFloatType(found->valueType);
        throw VdbError(ctx + "holds " + found->valueType + " values" +
                       (scalar ? " (a scalar grid, e.g. a density)" : "") +
                       "; a velocity grid must hold vec3s, vec3h or vec3d values");
    }
    out.sourceValueType = found->valueType;

    try {
        openvdb::io::File file(path);
        file.setCopyMaxBytes(0);
        file.open(/*delayLoad=*/true);
        openvdb::GridBase::Ptr base = file.readGrid(name);
        ++out.gridsRead;
        if (!base) throw VdbError(ctx + "OpenVDB returned no grid" + version);
        auto vs = openvdb::gridPtrCast<openvdb::Vec3SGrid>(base);
        auto vd = openvdb::gridPtrCast<openvdb::Vec3DGrid>(base);
        if (!vs && !vd) {
            throw VdbError(ctx + "has grid type " + base->type() + " (" + base->valueType() +
                           " values); a velocity grid must be a vec3s or vec3d grid with the "
                           "standard 5-4-3 tree");
        }
        out.gridClass = openvdb::GridBase::gridClassToString(base->getGridClass());
        out.vectorType = openvdb::GridBase::vecTypeToString(base->getVectorType());
        switch (options.layout) {
        case VelocityLayout::Auto:
            out.staggered = base->getGridClass() == openvdb::GRID_STAGGERED;
            break;
        case VelocityLayout::Centred:
            out.staggered = false;
            break;
        case VelocityLayout::Staggered:
            out.staggered = true;
            break;
        }

        // Axis-aligned, uniform positive scale, finite: origin + index * h.
        const openvdb::math::Transform& xform = base->transform();
        if (!xform.isLinear()) {
            throw VdbError(ctx + "has a non-linear (" + xform.mapType() +
                           ") transform; a velocity grid must be axis-aligned with one voxel "
                           "size on the three axes");
        }
        const openvdb::Mat4d m = xform.baseMap()->getAffineMap()->getMat4();
        const double h = m(0, 0);
        bool aligned = std::isfinite(h) && h > 0.0;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) {
                const double v = m(r, c);
                if (!std::isfinite(v)) aligned = false;
                if (r < 3 && c < 3 && r != c && std::abs(v) > 1e-6 * std::abs(h)) aligned = false;
                if (r < 3 && r == c && std::abs(v - h) > 1e-6 * std::abs(h)) aligned = false;
            }
        if (!aligned) {
            std::ostringstream d;
            d.precision(6);
            d << "[" << m(0, 0) << " " << m(0, 1) << " " << m(0, 2) << "; " << m(1, 0) << " "
              << m(1, 1) << " " << m(1, 2) << "; " << m(2, 0) << " " << m(2, 1) << " " << m(2, 2)
              << "]";
            throw VdbError(ctx + "has an index-to-world transform with matrix " + d.str() +
                           " (rotated, sheared, non-uniformly scaled or degenerate); a velocity "
                           "grid must be axis-aligned with one positive voxel size on the three "
                           "axes");
        }

        openvdb::CoordBBox box;
        if (!base->baseTreePtr()->evalActiveVoxelBoundingBox(box) || box.empty()) {
            throw VdbError(ctx + "is empty (no active voxels): there is no velocity to read" +
                           version);
        }
        out.indexMin = glm::ivec3(box.min()[0], box.min()[1], box.min()[2]);
        out.indexMax = glm::ivec3(box.max()[0], box.max()[1], box.max()[2]);
        const double cells = double(box.dim()[0]) * double(box.dim()[1]) * double(box.dim()[2]);
        if (cells > double(options.maxCells)) {
            throw VdbError(ctx + "its active voxels span a box of " + std::to_string(box.dim()[0]) +
                           " x " + std::to_string(box.dim()[1]) + " x " +
                           std::to_string(box.dim()[2]) + " = " +
                           std::to_string(std::uint64_t(cells)) +
                           " cells, more than the limit of " + std::to_string(options.maxCells) +
                           " cells for a dense velocity grid (12 bytes per cell)");
        }
        out.activeVoxelCount = base->activeVoxelCount();
        const openvdb::Vec3d o = xform.indexToWorld(
            openvdb::Vec3d(box.min()[0] - 0.5, box.min()[1] - 0.5, box.min()[2] - 0.5));
        out.grid.frame.origin = vec3(float(o[0]), float(o[1]), float(o[2]));
        out.grid.frame.voxelSize = float(h);
        if (vs)
            denseVelocity(*vs, box, options.scale, options.extrapolate, out);
        else
            denseVelocity(*vd, box, options.scale, options.extrapolate, out);
        file.close();
        if (out.nonFiniteCount) {
            out.warnings.push_back(ctx + std::to_string(out.nonFiniteCount) +
                                   " NaN/Inf velocity component(s) set to 0");
        }
    } catch (...) {
        rethrowAsVdbError(ctx, version);
    }
    return out;
}

void detail::recordVdbRead(const std::string& path, const std::string& gridName, int gridsRead) {
    std::lock_guard<std::mutex> lock(g_readsMutex);
    ++g_readCount;
    g_reads.push_back({path, gridName, gridsRead});
    if (g_reads.size() > kVdbRecentReads) g_reads.pop_front();
}

} // namespace nimbus::vdb
