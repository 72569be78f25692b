/// @file vdb_scene.cpp
/// @brief frameVdbFile() and its pieces (see vdb_scene.h).
#include "plugin/cli/vdb_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "core/fields/field.h"
#include "plugin/vdb/vdb_error.h"
#include "plugin/vdb/vdb_field.h"

namespace nimbus::cli {

std::string chooseDensityGrid(const std::vector<vdb::VdbGridInfo>& grids, std::string& why) {
    std::vector<std::string> scalar;
    std::string all;
    for (const auto& g : grids) {
        all += (all.empty() ? "" : ", ") + g.name + " (" + g.valueType + ")";
        if (g.valueType == "float" || g.valueType == "half" || g.valueType == "double")
            scalar.push_back(g.name);
    }
    if (std::find(scalar.begin(), scalar.end(), "density") != scalar.end()) return "density";
    if (scalar.size() == 1) return scalar[0];
    why = scalar.empty() ? "no float grid (" + (all.empty() ? std::string("no grids") : all) + ")"
                         : "several float grids and none named density (" + all + ")";
    return {};
}

vec3 framingPosition(const Box& box, vec3 toCamera, float fovY, float aspect) {
    const vec3 c = 0.5f * (box.lo + box.hi);
    const vec3 f = -toCamera;
    const vec3 r = glm::normalize(glm::cross(f, vec3(0.0f, 1.0f, 0.0f)));
    const vec3 u = glm::cross(r, f);
    const float tanY = std::tan(glm::radians(fovY) * 0.5f) * kFrameFill;
    const float tanX = tanY * aspect;
    float d = 0.0f;
    for (int k = 0; k < 8; ++k) {
        const vec3 p = vec3(k & 1 ? box.hi.x : box.lo.x, k & 2 ? box.hi.y : box.lo.y,
                            k & 4 ? box.hi.z : box.lo.z) -
                       c;
        const float need =
            std::max(std::abs(glm::dot(p, r)) / tanX, std::abs(glm::dot(p, u)) / tanY);
        d = std::max(d, need - glm::dot(p, f));
    }
    d = std::max(d, 0.01f * glm::length(box.extent())); // never inside the box
    return c + toCamera * d;
}

std::string tomlString(const std::string& s) {
    std::string out = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') out += '\\';
        out += c;
    }
    return out + "\"";
}

std::string tomlVec(vec3 v) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "[%.9g, %.9g, %.9g]", v.x, v.y, v.z);
    return buf;
}

bool frameVdbFile(const std::string& path, int w, int h, const std::string& comment,
                  VdbFraming& out, std::string& skip) {
    std::vector<vdb::VdbGridInfo> grids;
    try {
        grids = vdb::listVdbGrids(path);
    } catch (const std::exception& e) {
        skip = e.what();
        return false;
    }
    std::string why;
    out.grid = chooseDensityGrid(grids, why);
    if (out.grid.empty()) {
        skip = why;
        return false;
    }
    vdb::LoadedVdbGrid g;
    try {
        vdb::VdbLoadOptions opt;
        opt.path = path;
        opt.gridName = out.grid;
        vdb::applyVdbEnvironment(opt);
        g = vdb::loadVdbGrid(opt);
    } catch (const vdb::VdbError& e) {
        skip = e.what(); // a level set, a corrupt file, ...
        return false;
    }
    if (g.empty()) {
        skip = "grid \"" + out.grid + "\" is empty (0 active voxels)";
        return false;
    }
    out.voxel = double(std::min(g.voxelSize.x, std::min(g.voxelSize.y, g.voxelSize.z)));
    const float el = glm::radians(kVdbElevation), az = glm::radians(kVdbAzimuth);
    const vec3 toCamera(std::sin(az) * std::cos(el), std::sin(el), -std::cos(az) * std::cos(el));
    // frame the voxels that hold density: the active ones (a dense grid's zeros are active
    // too), within the tree nodes whose largest value is above 0
    GridBinding binding;
    binding.grid = g.grid();
    binding.bounds = g.worldBounds;
    FieldDesc fd;
    fd.kind = FieldKind::Vdb;
    const Field field = makeField(fd, 0.0f, binding);
    Box nodes{vec3(std::numeric_limits<float>::max()), vec3(-std::numeric_limits<float>::max())};
    field.forEachDensityNode([&](const Box& b, float maxDensity) {
        if (!(maxDensity > 0.0f)) return;
        nodes.lo = glm::min(nodes.lo, b.lo);
        nodes.hi = glm::max(nodes.hi, b.hi);
    });
    if (nodes.empty()) {
        skip = "grid \"" + out.grid + "\" holds no density above 0";
        return false;
    }
    const Box box{glm::max(g.worldBounds.lo, nodes.lo), glm::min(g.worldBounds.hi, nodes.hi)};
    const vec3 centre = 0.5f * (box.lo + box.hi);
    const vec3 eye = framingPosition(box, toCamera, kVdbFov, float(w) / float(h));
    char step[64];
    std::snprintf(step, sizeof step, "%.9g", out.voxel);
    std::ostringstream t;
    t << "# " << comment << ": " << path << ", grid " << out.grid << "\n"
      << "frames = \"1\"\n[camera]\nposition = " << tomlVec(eye)
      << "\nlook_at = " << tomlVec(centre) << "\nup = [0, 1, 0]\nfov = " << kVdbFov
      << "\nwidth = " << w << "\nheight = " << h
      << "\n[field]\nkind = \"vdb\"\npath = " << tomlString(path)
      << "\ngrid = " << tomlString(out.grid) << "\n[render]\nstep = " << step
      << "\nshadow_step = " << step << "\n";
    out.scene = t.str();
    return true;
}

} // namespace nimbus::cli
