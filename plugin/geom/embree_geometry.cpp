#include "plugin/geom/embree_geometry.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <limits>

#include <embree3/rtcore.h>
#include <tiny_obj_loader.h>

#include "core/tracking/volumes.h"

namespace nimbus::geom {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

void onEmbreeError(void*, RTCError code, const char* message) {
    // reported through rtcGetDeviceError where it matters; keep the last message
    (void)code;
    (void)message;
}

std::atomic<int> g_devicesCreated{0}; // embreeDevicesCreated()

/// Owns a device; shared by the surface scene and every instance query made from it.
struct Device {
    RTCDevice device = nullptr;
    Device() {
        device = rtcNewDevice(nullptr);
        if (!device) throw GeometryError("Embree: cannot create a device");
        ++g_devicesCreated;
        rtcSetDeviceErrorFunction(device, onEmbreeError, nullptr);
    }
    ~Device() { rtcReleaseDevice(device); }
    void check(const char* what) const {
        const RTCError e = rtcGetDeviceError(device);
        if (e != RTC_ERROR_NONE)
            throw GeometryError(std::string("Embree: ") + what + " failed (error " +
                                std::to_string(int(e)) + ")");
    }
};

// ---- instance boxes: user geometry whose intersector records every box and never reports a
// hit, so traversal goes on to the next box

struct BoxContext {
    RTCIntersectContext base; // first member: Embree hands back a pointer to it
    std::vector<InstanceHit>* out;
};

void boxBounds(const RTCBoundsFunctionArguments* args) {
    const Box& b = static_cast<const Box*>(args->geometryUserPtr)[args->primID];
    args->bounds_o->lower_x = b.lo.x;
    args->bounds_o->lower_y = b.lo.y;
    args->bounds_o->lower_z = b.lo.z;
    args->bounds_o->upper_x = b.hi.x;
    args->bounds_o->upper_y = b.hi.y;
    args->bounds_o->upper_z = b.hi.z;
}

void boxIntersect(const RTCIntersectFunctionNArguments* args) {
    if (args->N != 1 || !args->valid[0]) return;
    const Box& b = static_cast<const Box*>(args->geometryUserPtr)[args->primID];
    const RTCRay& r = reinterpret_cast<const RTCRayHit*>(args->rayhit)->ray;
    const Ray ray{vec3(r.org_x, r.org_y, r.org_z), vec3(r.dir_x, r.dir_y, r.dir_z)};
    float t0, t1;
    if (!intersectBox(ray, b, r.tnear, r.tfar, t0, t1)) return;
    auto* ctx = reinterpret_cast<BoxContext*>(args->context);
    ctx->out->push_back({int(args->primID), t0, t1});
}

class EmbreeInstanceQuery final : public InstanceQuery {
  public:
    EmbreeInstanceQuery(std::shared_ptr<const Device> device, const std::vector<Box>& boxes)
        : device_(std::move(device)), boxes_(boxes) {
        scene_ = rtcNewScene(device_->device);
        RTCGeometry g = rtcNewGeometry(device_->device, RTC_GEOMETRY_TYPE_USER);
        rtcSetGeometryUserPrimitiveCount(g, unsigned(boxes_.size()));
        rtcSetGeometryUserData(g, boxes_.data());
        rtcSetGeometryBoundsFunction(g, boxBounds, nullptr);
        rtcSetGeometryIntersectFunction(g, boxIntersect);
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene_, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(scene_);
        device_->check("building the instance boxes");
    }
    ~EmbreeInstanceQuery() override { rtcReleaseScene(scene_); }

    void find(const Ray& ray, float tmin, float tmax,
              std::vector<InstanceHit>& out) const override {
        BoxContext ctx;
        rtcInitIntersectContext(&ctx.base);
        ctx.out = &out;
        const size_t first = out.size();
        RTCRayHit rh;
        rh.ray.org_x = ray.o.x;
        rh.ray.org_y = ray.o.y;
        rh.ray.org_z = ray.o.z;
        rh.ray.dir_x = ray.d.x;
        rh.ray.dir_y = ray.d.y;
        rh.ray.dir_z = ray.d.z;
        rh.ray.tnear = tmin;
        rh.ray.tfar = tmax;
        rh.ray.mask = ~0u;
        rh.ray.flags = 0;
        rh.ray.time = 0.0f;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene_, &ctx.base, &rh);
        // a box referenced from two BVH leaves would be reported twice
        if (out.size() - first > 1) {
            std::sort(
                out.begin() + long(first), out.end(),
                [](const InstanceHit& a, const InstanceHit& b) { return a.instance < b.instance; });
            out.erase(std::unique(out.begin() + long(first), out.end(),
                                  [](const InstanceHit& a, const InstanceHit& b) {
                                      return a.instance == b.instance;
                                  }),
                      out.end());
        }
    }

  private:
    std::shared_ptr<const Device> device_;
    std::vector<Box> boxes_;
    RTCScene scene_ = nullptr;
};

// ---- surfaces

class EmbreeSurfaces final : public SurfaceQuery {
  public:
    explicit EmbreeSurfaces(std::shared_ptr<const Device> device) : device_(std::move(device)) {
        scene_ = rtcNewScene(device_->device);
    }
    ~EmbreeSurfaces() override { rtcReleaseScene(scene_); }

    void add(const TriangleMesh& mesh, const SurfaceMaterialDesc& material) {
        RTCGeometry g = rtcNewGeometry(device_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0,
                                                              RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                              mesh.vertices.size()));
        auto* ix = static_cast<unsigned*>(
            rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                    3 * sizeof(unsigned), mesh.triangles.size()));
        if (!v || !ix) {
            rtcReleaseGeometry(g);
            throw GeometryError("Embree: out of memory for a mesh of " +
                                std::to_string(mesh.triangles.size()) + " triangles");
        }
        for (size_t i = 0; i < mesh.vertices.size(); ++i)
            for (int a = 0; a < 3; ++a) v[3 * i + size_t(a)] = mesh.vertices[i][a];
        for (size_t i = 0; i < mesh.triangles.size(); ++i)
            for (int a = 0; a < 3; ++a) ix[3 * i + size_t(a)] = mesh.triangles[i][a];
        rtcCommitGeometry(g);
        const unsigned id = rtcAttachGeometry(scene_, g);
        rtcReleaseGeometry(g);
        if (materials_.size() <= id) materials_.resize(id + 1);
        materials_[id] = material;
        device_->check("adding a mesh");
    }
    void commit() {
        rtcCommitScene(scene_);
        device_->check("building the surfaces");
    }

    bool intersect(const Ray& ray, float tmin, float tmax, SurfaceHit& hit) const override {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRayHit rh;
        fill(rh.ray, ray, tmin, tmax);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene_, &ctx, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
        vec3 n(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
        const float len = glm::length(n);
        if (!(len > 0.0f)) return false; // degenerate triangle
        n /= len;
        if (glm::dot(n, ray.d) > 0.0f) n = -n; // face the viewer: surfaces are two-sided
        hit.t = rh.ray.tfar;
        hit.normal = n;
        const SurfaceMaterialDesc& m = materials_[rh.hit.geomID];
        hit.albedo = m.albedo;
        hit.holdout = m.holdout;
        return true;
    }
    bool occluded(const Ray& ray, float tmin, float tmax) const override {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRay r;
        fill(r, ray, tmin, tmax);
        rtcOccluded1(scene_, &ctx, &r);
        return r.tfar == -kInf;
    }

  private:
    static void fill(RTCRay& r, const Ray& ray, float tmin, float tmax) {
        r.org_x = ray.o.x;
        r.org_y = ray.o.y;
        r.org_z = ray.o.z;
        r.dir_x = ray.d.x;
        r.dir_y = ray.d.y;
        r.dir_z = ray.d.z;
        r.tnear = tmin;
        r.tfar = std::min(tmax, std::numeric_limits<float>::max());
        r.mask = ~0u;
        r.flags = 0;
        r.time = 0.0f;
    }
    std::shared_ptr<const Device> device_;
    RTCScene scene_ = nullptr;
    std::vector<SurfaceMaterialDesc> materials_;
};

class EmbreeGeometry final : public GeometryBackend {
  public:
    EmbreeGeometry(std::shared_ptr<const Device> device, std::unique_ptr<EmbreeSurfaces> s)
        : device_(std::move(device)), surfaces_(std::move(s)) {}
    std::unique_ptr<InstanceQuery> instances(const std::vector<Box>& boxes) const override {
        return std::make_unique<EmbreeInstanceQuery>(device_, boxes);
    }
    const SurfaceQuery* surfaces() const override { return surfaces_.get(); }

  private:
    std::shared_ptr<const Device> device_;
    std::unique_ptr<EmbreeSurfaces> surfaces_;
};

} // namespace

TriangleMesh loadObjMesh(const MeshDesc& desc, const std::string& sceneDir,
                         std::vector<std::string>& warnings) {
    std::filesystem::path path(desc.path);
    if (path.is_relative() && !sceneDir.empty()) path = std::filesystem::path(sceneDir) / path;
    const std::string file = path.string();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        throw GeometryError(file + ": mesh file not found");
    tinyobj::ObjReaderConfig config;
    config.triangulate = true;
    config.vertex_color = false;
    config.mtl_search_path = path.parent_path().string();
    tinyobj::ObjReader reader;
    if (!reader.ParseFromFile(file, config)) {
        std::string err = reader.Error();
        while (!err.empty() && err.back() == '\n') err.pop_back();
        throw GeometryError(file + ": not a readable OBJ file" + (err.empty() ? "" : ": " + err));
    }
    if (!reader.Warning().empty()) {
        std::string w = reader.Warning();
        while (!w.empty() && w.back() == '\n') w.pop_back();
        // material libraries are not used: their absence is no news
        if (w.find("material") == std::string::npos) warnings.push_back(file + ": " + w);
    }
    const auto& attrib = reader.GetAttrib();
    const size_t nv = attrib.vertices.size() / 3;
    InstanceDesc xf;
    xf.translate = desc.translate;
    xf.rotate = desc.rotate;
    xf.scale = desc.scale;
    const glm::mat4 m = instanceTransform(xf);
    TriangleMesh mesh;
    mesh.vertices.resize(nv);
    for (size_t i = 0; i < nv; ++i) {
        const vec3 p(attrib.vertices[3 * i], attrib.vertices[3 * i + 1],
                     attrib.vertices[3 * i + 2]);
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            throw GeometryError(file + ": vertex " + std::to_string(i + 1) +
                                " is not a finite number");
        mesh.vertices[i] = vec3(m * vec4(p, 1.0f));
    }
    for (const auto& shape : reader.GetShapes()) {
        const auto& idx = shape.mesh.indices;
        for (size_t f = 0; f + 2 < idx.size(); f += 3) {
            glm::uvec3 t;
            for (int k = 0; k < 3; ++k) {
                const int vi = idx[f + size_t(k)].vertex_index;
                if (vi < 0 || size_t(vi) >= nv)
                    throw GeometryError(file + ": shape \"" + shape.name + "\" refers to vertex " +
                                        std::to_string(vi + 1) + " of " + std::to_string(nv));
                t[k] = unsigned(vi);
            }
            mesh.triangles.push_back(t);
        }
    }
    if (mesh.triangles.empty()) throw GeometryError(file + ": the OBJ file holds no faces");
    return mesh;
}

std::shared_ptr<const GeometryBackend> makeEmbreeGeometry(const SceneDesc& scene,
                                                          const std::string& sceneDir,
                                                          std::vector<std::string>& warnings) {
    auto device = std::make_shared<const Device>();
    std::unique_ptr<EmbreeSurfaces> surfaces;
    if (scene.ground.enabled || !scene.meshes.empty()) {
        surfaces = std::make_unique<EmbreeSurfaces>(device);
        if (scene.ground.enabled) {
            // a square centred under the camera, two triangles
            const float e = scene.ground.extent, y = scene.ground.height;
            const vec3 c(scene.camera.position.x, y, scene.camera.position.z);
            TriangleMesh g;
            g.vertices = {c + vec3(-e, 0, -e), c + vec3(e, 0, -e), c + vec3(e, 0, e),
                          c + vec3(-e, 0, e)};
            g.triangles = {{0, 1, 2}, {0, 2, 3}};
            surfaces->add(g, scene.ground.material);
        }
        for (const MeshDesc& m : scene.meshes)
            surfaces->add(loadObjMesh(m, sceneDir, warnings), m.material);
        surfaces->commit();
    }
    return std::make_shared<EmbreeGeometry>(std::move(device), std::move(surfaces));
}

int embreeDevicesCreated() {
    return g_devicesCreated.load();
}

} // namespace nimbus::geom
