/// @file embree_geometry.h
/// @brief Embree behind core/accel.h: the instance boxes of a frame's volumes (user geometry,
/// every box a ray crosses is collected) and the scene's opaque surfaces (a ground plane and OBJ
/// meshes as triangles).
///
/// @code
///   std::vector<std::string> warnings;
///   auto geometry = geom::makeEmbreeGeometry(scene, "/path/of/scene/dir", warnings);
///   bindings.geometry = geometry; // FrameBindings (core/bindings.h); surfaces() is null when
///                                // the scene has none
/// @endcode
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/accel.h"
#include "core/scene.h"

namespace nimbus::geom {

/// A mesh that cannot be read, or an Embree failure. what() names the file.
class GeometryError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// A triangle mesh in world space (after the mesh's transform).
struct TriangleMesh {
    std::vector<vec3> vertices;
    std::vector<glm::uvec3> triangles;
};

/// Reads an OBJ file's triangles (polygons are triangulated; materials and normals ignored) and
/// applies the mesh's transform. @throws GeometryError naming the file for a missing or
/// unreadable file, a parse error, non-finite vertices or no triangles at all.
TriangleMesh loadObjMesh(const MeshDesc& mesh, const std::string& sceneDir,
                         std::vector<std::string>& warnings);

/// The scene's surfaces (ground, meshes; paths relative to sceneDir) in one Embree scene, and
/// instance queries built per frame. @throws GeometryError.
std::shared_ptr<const GeometryBackend> makeEmbreeGeometry(const SceneDesc& scene,
                                                          const std::string& sceneDir,
                                                          std::vector<std::string>& warnings);

/// Embree devices this process has created (one per makeEmbreeGeometry call): a scene without
/// surfaces or instances never creates one (tests/test_plan_obeyed.cpp).
int embreeDevicesCreated();

} // namespace nimbus::geom
