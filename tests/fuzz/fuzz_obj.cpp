/// @file fuzz_obj.cpp
/// @brief libFuzzer harness: OBJ mesh loading (plugin/geom, tinyobjloader underneath). Accepted
/// outcomes are a mesh whose vertices are all finite and whose triangles index existing
/// vertices, or a GeometryError; anything else is a bug.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "plugin/geom/embree_geometry.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    nimbus::MeshDesc mesh;
    mesh.path = nimbus::fuzz::scratchFile(data, size, ".obj");
    std::vector<std::string> warnings;
    try {
        const nimbus::geom::TriangleMesh m = nimbus::geom::loadObjMesh(mesh, "", warnings);
        for (const auto& v : m.vertices)
            if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) __builtin_trap();
        for (const auto& t : m.triangles)
            for (int k = 0; k < 3; ++k)
                if (std::size_t(t[k]) >= m.vertices.size()) __builtin_trap();
    } catch (const nimbus::geom::GeometryError&) {
    }
    return 0;
}
