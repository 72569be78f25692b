/// @file vdb_velocity.cpp
/// @brief loadVdbVelocity() through the child process of vdb_isolate.cpp, and
///        bindVdbVelocity() (vdb_velocity.h). The OpenVDB reading itself is in vdb_reader.cpp
///        (detail::loadVdbVelocityInProcess); no OpenVDB headers here.
#include "plugin/vdb/vdb_velocity.h"

#include <cmath>
#include <cstring>
#include <filesystem>

#include "plugin/vdb/vdb_field.h"
#include "plugin/vdb/vdb_isolate.h"

namespace nimbus::vdb {

namespace {

// A tripwire: a field added to LoadedVelocityGrid must also be sent (encode/decode below).
static_assert(sizeof(LoadedVelocityGrid) == 304 || sizeof(void*) != 8,
              "LoadedVelocityGrid changed: send the new field in encodeVelocityMeta() and "
              "decodeVelocityMeta(), then update this size");

/// Everything but the velocity values (they travel as the bulk buffer).
std::string encodeVelocityMeta(const LoadedVelocityGrid& g) {
    detail::Encoder e;
    e.pod(g.grid.res);
    e.pod(g.grid.frame);
    e.pod(g.staggered);
    e.str(g.path);
    e.str(g.gridName);
    e.str(g.sourceValueType);
    e.str(g.gridClass);
    e.str(g.vectorType);
    e.pod(g.indexMin);
    e.pod(g.indexMax);
    e.pod(g.activeVoxelCount);
    e.pod(g.nonFiniteCount);
    e.pod(g.extrapolatedCells);
    e.pod(g.maxSpeed);
    e.pod(g.gridsRead);
    e.pod(std::uint64_t(g.warnings.size()));
    for (const std::string& w : g.warnings) e.str(w);
    return std::move(e.bytes);
}

bool decodeVelocityMeta(const std::string& bytes, LoadedVelocityGrid& g) {
    detail::Decoder d(bytes);
    g.grid.res = d.pod<ivec3>();
    g.grid.frame = d.pod<sim::GridFrame>();
    g.staggered = d.pod<bool>();
    g.path = d.str();
    g.gridName = d.str();
    g.sourceValueType = d.str();
    g.gridClass = d.str();
    g.vectorType = d.str();
    g.indexMin = d.pod<glm::ivec3>();
    g.indexMax = d.pod<glm::ivec3>();
    g.activeVoxelCount = d.pod<std::uint64_t>();
    g.nonFiniteCount = d.pod<std::uint64_t>();
    g.extrapolatedCells = d.pod<std::uint64_t>();
    g.maxSpeed = d.pod<float>();
    g.gridsRead = d.pod<int>();
    const auto warnings = d.pod<std::uint64_t>();
    if (warnings > bytes.size() / 8) return false;
    g.warnings.resize(std::size_t(warnings));
    for (std::string& w : g.warnings) w = d.str();
    return d.complete();
}

LoadedVelocityGrid loadIsolated(const VelocityLoadOptions& options) {
    detail::IsolatedReply reply = detail::runIsolated(
        options.read, detail::velocityRequest(options), sizeof(vec3), "a velocity grid");
    const std::string ctx = options.read.path + ": grid \"" + options.read.gridName +
                            "\": the process reading the "
                            "grid sent an invalid reply: ";
    LoadedVelocityGrid out;
    if (!decodeVelocityMeta(reply.meta, out)) throw VdbError(ctx + "its metadata does not decode");
    const ivec3 r = out.grid.res;
    const double cells = double(r.x) * double(r.y) * double(r.z);
    if (r.x <= 0 || r.y <= 0 || r.z <= 0 || cells > double(options.maxCells) ||
        double(reply.bulk.size()) != cells * double(sizeof(vec3)))
        throw VdbError(ctx + "a grid of " + std::to_string(r.x) + " x " + std::to_string(r.y) +
                       " x " + std::to_string(r.z) + " cells in " +
                       std::to_string(reply.bulk.size()) + " bytes");
    if (!(out.grid.frame.voxelSize > 0.0f) || !std::isfinite(out.grid.frame.voxelSize) ||
        !std::isfinite(out.grid.frame.origin.x) || !std::isfinite(out.grid.frame.origin.y) ||
        !std::isfinite(out.grid.frame.origin.z))
        throw VdbError(ctx + "a non-finite or non-positive placement");
    out.grid.v.resize(std::size_t(cells));
    std::memcpy(out.grid.v.data(), reply.bulk.data(), reply.bulk.size());
    for (const vec3& v : out.grid.v)
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
            throw VdbError(ctx + "a non-finite velocity");
    return out;
}

} // namespace

detail::ChildReply detail::velocityChildReply(const VelocityLoadOptions& options) {
    auto g = std::make_shared<LoadedVelocityGrid>(detail::loadVdbVelocityInProcess(options));
    return detail::ChildReply{encodeVelocityMeta(*g), g, g->grid.v.data(),
                              g->grid.v.size() * sizeof(vec3)};
}

LoadedVelocityGrid loadVdbVelocity(const VelocityLoadOptions& options) {
    LoadedVelocityGrid g =
        options.read.isolate ? loadIsolated(options) : detail::loadVdbVelocityInProcess(options);
    detail::recordVdbRead(g.path, g.gridName, g.gridsRead);
    return g;
}

void bindVdbVelocity(const FieldDesc& field, const std::string& sceneDir, int frame,
                     std::shared_ptr<const sim::VelocityGrid>& velocity, bool& staggered,
                     std::vector<std::string>& warnings) {
    velocity.reset();
    staggered = false;
    const AdvectDesc& a = field.advect;
    if (!a.enabled || a.wind != AdvectWind::Grid) return; // never read
    if (a.velocityPath.empty())
        throw VdbError("field.advect.velocity: a VDB file is required for wind = \"grid\"");
    std::filesystem::path pattern(a.velocityPath);
    if (pattern.is_relative() && !sceneDir.empty())
        pattern = std::filesystem::path(sceneDir) / pattern;
    const VdbFrameFile file = resolveVdbFrame(pattern.string(), frame, field.vdb.hold);
    if (!file.warning.empty()) warnings.push_back(file.warning);

    VelocityLoadOptions o;
    o.read.path = file.path;
    o.read.gridName = a.velocityGrid;
    applyVdbEnvironment(o.read);
    o.layout = a.layout;
    o.scale = a.velocityScale;
    o.extrapolate = a.velocityExtrapolate;
    LoadedVelocityGrid g = loadVdbVelocity(o);
    for (const std::string& w : g.warnings) warnings.push_back(w);
    staggered = g.staggered;
    velocity = std::make_shared<const sim::VelocityGrid>(std::move(g.grid));
}

} // namespace nimbus::vdb
