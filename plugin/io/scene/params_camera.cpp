/// @file params_camera.cpp
/// @brief Scene-file parameter table: the rows of [camera] (see table.h).
#include "plugin/io/scene/table.h"

namespace nimbus::io::scene {

void addCameraParams(std::vector<Param>& t) {
    const Section<CameraDesc> cam{"camera",
                                  [](Staging& s) -> CameraDesc& { return s.file.scene.camera; }};
    t.push_back(cam.param("position", {}, "Camera position (world units).", &CameraDesc::position));
    t.push_back(cam.param("look_at", {}, "Point the camera looks at; must differ from `position`.",
                          &CameraDesc::lookAt));
    t.push_back(cam.param("up", {},
                          "Up direction of the image; must not be parallel to the view direction.",
                          &CameraDesc::up)
                    .checkedBy(nonZero));
    t.push_back(
        cam.param("fov", open(0, 180), "Vertical field of view in degrees.", &CameraDesc::fovY));
    t.push_back(cam.param("width", closed(1, 16384), "Image width in pixels.", &CameraDesc::width));
    t.push_back(
        cam.param("height", closed(1, 16384), "Image height in pixels.", &CameraDesc::height));
}

} // namespace nimbus::io::scene
