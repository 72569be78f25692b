/// @file vdb_scene.h
/// @brief A scene for a bare VDB file: its density grid chosen, read once (in the isolated
/// child, as scenes read grids) to frame the voxels that hold density and to size the step.
/// `converge --suite` builds its VDB cases on it, `bench-vdb-render file.vdb` its scene.
#pragma once

#include <string>
#include <vector>

#include "core/geometry.h"
#include "plugin/vdb/vdb_reader.h"

namespace nimbus::cli {

/// Camera of a framed VDB: vertical field of view, and the direction from the grid's centre
/// toward the camera (from -z, 20 degrees toward +x and 10 degrees up).
constexpr float kVdbFov = 40.0f;
constexpr float kVdbAzimuth = 20.0f, kVdbElevation = 10.0f;
/// The projected bounding box fills at most this fraction of the frame's width and height.
constexpr float kFrameFill = 0.9f;

/// The density grid of a file: "density" when it is a float grid, else the only float grid;
/// empty (with @p why) when neither exists.
std::string chooseDensityGrid(const std::vector<vdb::VdbGridInfo>& grids, std::string& why);

/// Camera position that frames @p box (every corner within kFrameFill of the frame) seen from
/// direction @p toCamera (unit, from the box's centre).
vec3 framingPosition(const Box& box, vec3 toCamera, float fovY, float aspect);

std::string tomlString(const std::string& s);
std::string tomlVec(vec3 v);

/// What frameVdbFile() found and wrote.
struct VdbFraming {
    std::string grid;   ///< the grid chosen
    double voxel = 0.0; ///< its smallest voxel side (the scene's step and shadow step)
    std::string scene;  ///< scene text: frames, [camera] (w x h), [field], [render] steps
};

/// Frames @p path at @p w x @p h. False with @p skip set when the file is not a fog volume
/// that can be rendered (unreadable, a level set, no float grid, empty, no density above 0).
bool frameVdbFile(const std::string& path, int w, int h, const std::string& comment,
                  VdbFraming& out, std::string& skip);

} // namespace nimbus::cli
