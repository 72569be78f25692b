#include "plugin/vdb/volume_render_baseline.h"
#include "plugin/vdb/vdb_isolate.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/NanoToOpenVDB.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/RayIntersector.h>
#include <openvdb/tools/RayTracer.h>
#include <tbb/task_arena.h>

#include "core/camera.h"

namespace nimbus::vdb {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kHoudiniAperture = 41.2136; ///< mm, PerspectiveCamera's default film width

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

openvdb::Vec3R toVdb(vec3 v) {
    return openvdb::Vec3R(v.x, v.y, v.z);
}

} // namespace

std::string VolumeRenderProblem::describe() const {
    std::ostringstream o;
    o << "  PerspectiveCamera: eye (" << eye.x << ", " << eye.y << ", " << eye.z << "), lookAt ("
      << lookAt.x << ", " << lookAt.y << ", " << lookAt.z << "), up (" << up.x << ", " << up.y
      << ", " << up.z << "), aperture " << aperture << " mm, focal length " << focalLength
      << " mm\n"
      << "  light: direction (" << lightDir.x << ", " << lightDir.y << ", " << lightDir.z
      << "), colour (" << lightColor.x << ", " << lightColor.y << ", " << lightColor.z
      << ") = sun irradiance / (4 pi), gain 0\n"
      << "  per voxel (" << voxelSize << " world units): scattering (" << scattering.x << ", "
      << scattering.y << ", " << scattering.z << "), absorption (" << absorption.x << ", "
      << absorption.y << ", " << absorption.z << ")\n";
    return o.str();
}

VolumeRenderProblem volumeRenderProblem(const SceneDesc& scene, double voxelSize) {
    VolumeRenderProblem p;
    p.voxelSize = voxelSize;
    const CameraDesc& c = scene.camera;
    p.eye = c.position;
    p.lookAt = c.lookAt;
    p.up = c.up;
    // screen x = (2 px / W - 1) * aperture / (2 focal) must equal Nimbus'
    // (2 px / W - 1) * tan(fovY / 2) * W / H
    const double tanHalfY = std::tan(double(c.fovY) * kPi / 360.0);
    p.aperture = kHoudiniAperture;
    p.focalLength = p.aperture / (2.0 * tanHalfY * double(c.width) / double(c.height));
    p.lightDir = glm::normalize(scene.sun.direction);
    // Nimbus: L_s = sigma_s * E * p(cos) with p = 1 / (4 pi); VolumeRender's phase is 1
    p.lightColor = scene.sun.enabled ? scene.sun.irradiance / float(4.0 * kPi) : vec3(0.0f);
    const float perVoxel =
        float(double(scene.medium.densityScale) * scene.field.vdb.density * voxelSize);
    p.scattering = scene.medium.sigma_s * perVoxel;
    p.absorption = scene.medium.sigma_a * perVoxel;
    return p;
}

struct VolumeRenderBaseline::Impl {
    openvdb::FloatGrid::Ptr grid;
    double voxelSize = 1.0;
};

VolumeRenderBaseline::VolumeRenderBaseline(const VdbFieldDesc& vdb, const GridBinding& grid)
    : impl_(new Impl) {
    openvdb::initialize();
    const auto* nano = static_cast<const nanovdb::FloatGrid*>(grid.grid);
    if (!nano || nano->activeVoxelCount() == 0)
        throw std::runtime_error("the grid \"" + vdb.grid + "\" is empty: nothing to render");
    impl_->grid = nanovdb::nanoToOpenVDB(*nano);
    const openvdb::Vec3d vs = impl_->grid->voxelSize();
    if (!impl_->grid->hasUniformVoxels()) {
        char buf[256];
        std::snprintf(buf, sizeof buf,
                      "the grid \"%s\" has non-uniform voxels (%g x %g x %g); VolumeRender "
                      "measures its steps in voxels and supports uniform voxels only",
                      vdb.grid.c_str(), vs[0], vs[1], vs[2]);
        throw std::runtime_error(buf);
    }
    impl_->voxelSize = vs[0];
}

VolumeRenderBaseline::~VolumeRenderBaseline() = default;

double VolumeRenderBaseline::voxelSize() const {
    return impl_->voxelSize;
}

VolumeRenderTimes VolumeRenderBaseline::render(const SceneDesc& scene,
                                               const VolumeRenderSettings& settings,
                                               Framebuffer& fb) const {
    using Intersector = openvdb::tools::VolumeRayIntersector<openvdb::FloatGrid>;
    const VolumeRenderProblem p = volumeRenderProblem(scene, impl_->voxelSize);
    const int w = scene.camera.width, h = scene.camera.height;
    openvdb::tools::Film film(w, h);
    openvdb::tools::PerspectiveCamera camera(film, openvdb::Vec3R(0.0), toVdb(p.eye), p.focalLength,
                                             p.aperture);
    camera.lookAt(toVdb(p.lookAt), toVdb(p.up));

    // the two cameras must shoot the same rays: check the corners and the centre
    const Camera nimbusCamera(scene.camera);
    for (int k = 0; k < 5; ++k) {
        const int i = k == 4 ? w / 2 : (k & 1 ? w - 1 : 0);
        const int j = k == 4 ? h / 2 : (k & 2 ? h - 1 : 0);
        const openvdb::math::Ray<double> vr = camera.getRay(size_t(i), size_t(j));
        const Ray r = nimbusCamera.generate(float(i) + 0.5f, float(j) + 0.5f);
        const openvdb::Vec3R d = vr.dir(), e = toVdb(r.d);
        const double eyeError = (vr.eye() - toVdb(r.o)).length();
        if (!((d - e).length() < 1e-5) || !(eyeError < 1e-5 * (1.0 + toVdb(r.o).length()))) {
            char buf[256];
            std::snprintf(buf, sizeof buf,
                          "internal error: the VolumeRender camera's ray at pixel (%d, %d) is "
                          "(%g, %g, %g), Nimbus' is (%g, %g, %g)",
                          i, j, d[0], d[1], d[2], e[0], e[1], e[2]);
            throw std::runtime_error(buf);
        }
    }

    VolumeRenderTimes times;
    const int threads = settings.threads > 0 ? settings.threads : tbb::task_arena::automatic;
    tbb::task_arena arena(threads);
    arena.execute([&] {
        auto t0 = std::chrono::steady_clock::now();
        Intersector intersector(*impl_->grid); // as vdb_render: no dilation
        openvdb::tools::VolumeRender<Intersector> renderer(intersector, camera);
        times.setupSeconds = secondsSince(t0);
        renderer.setLightDir(p.lightDir.x, p.lightDir.y, p.lightDir.z);
        renderer.setLightColor(p.lightColor.x, p.lightColor.y, p.lightColor.z);
        renderer.setPrimaryStep(settings.primaryStep);
        renderer.setShadowStep(settings.shadowStep);
        renderer.setScattering(p.scattering.x, p.scattering.y, p.scattering.z);
        renderer.setAbsorption(p.absorption.x, p.absorption.y, p.absorption.z);
        renderer.setLightGain(settings.lightGain);
        renderer.setCutOff(settings.cutoff);
        t0 = std::chrono::steady_clock::now();
        renderer.render(/*threaded=*/true);
        times.renderSeconds = secondsSince(t0);
    });

    fb.resize(w, h, AovSet{});
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const openvdb::tools::Film::RGBA& c = film.pixel(size_t(i), size_t(j));
            float* out = &fb.rgba[4 * (size_t(j) * w + i)];
            out[0] = c.r;
            out[1] = c.g;
            out[2] = c.b;
            out[3] = c.a;
        }
    return times;
}

} // namespace nimbus::vdb
