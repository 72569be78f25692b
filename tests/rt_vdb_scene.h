/// @file rt_vdb_scene.h
/// @brief A VDB scene the GLSL pass tests write themselves (tests/test_rt_march.cpp,
/// tests/test_export_glsl.cpp), so that the VDB path is tested without the shared data folder:
/// a sparse fog volume of three soft blobs with a hashed texture per voxel (every voxel its own
/// value, so the trilinear weights matter), 136 x 40 x 40 voxels of 0.25 units: its index box
/// crosses the border of two lower internal nodes (x = 128) and holds empty leaves between the
/// blobs, and a scene that looks at it with the sun, a gradient sky and field.density = 1.5.
#pragma once

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "core/kernels/kernels.h"
#include "plugin/vdb/vdb_writer.h"

/// Writes `dir`/blobs.vdb and `dir`/blobs.toml; returns the scene's path.
inline std::string writeRtVdbScene(const std::string& dir) {
    const int nx = 136, ny = 40, nz = 40;
    const glm::vec3 voxel(0.25f);
    const glm::vec3 origin(-17.0f + 0.125f, 0.125f, -5.0f + 0.125f); // voxel (0,0,0)'s centre
    const glm::vec3 centres[3] = {{-9.0f, 4.5f, 0.0f}, {0.5f, 5.0f, 0.5f}, {9.5f, 4.0f, -0.5f}};
    const float radii[3] = {5.0f, 4.5f, 4.0f};
    std::vector<float> dense(std::size_t(nx) * ny * nz, 0.0f);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                const glm::vec3 p = origin + glm::vec3(float(i), float(j), float(k)) * voxel;
                float d = 0.0f;
                for (int b = 0; b < 3; ++b) {
                    const glm::vec3 q = (p - centres[b]) / radii[b];
                    d += std::max(0.0f, 1.0f - glm::dot(q, q));
                }
                if (d <= 0.0f) continue;
                const std::uint32_t h = nimbus::kern::pcg(
                    std::uint32_t(i) ^
                    nimbus::kern::pcg(std::uint32_t(j) ^ nimbus::kern::pcg(std::uint32_t(k))));
                dense[std::size_t(i) + std::size_t(nx) * (std::size_t(j) + std::size_t(ny) * k)] =
                    d * (0.6f + 0.8f * nimbus::kern::hashToUnit(h));
            }
    nimbus::vdb::writeFogVdb(dir + "/blobs.vdb", "density", nx, ny, nz, dense.data(), origin,
                             voxel);
    const std::string scene = dir + "/blobs.toml";
    std::ofstream(scene) << R"(frames = "1"

[camera]
position = [0.0, 5.0, -30.0]
look_at = [0.0, 5.0, 0.0]
fov = 40.0
width = 160
height = 90

[sun]
elevation = 30.0
azimuth = 60.0
intensity = 3.0

[sky]
kind = "gradient"

[medium]
sigma_s = 1.0
g = 0.6

[field]
kind = "vdb"
path = "blobs.vdb"
grid = "density"
density = 1.5

[render]
step = 0.2
shadow_step = 0.4
multiple_scattering = "none"

[output]
path = "out/blobs.####.exr"
aovs = ["transmittance", "depth"]
)";
    return scene;
}
