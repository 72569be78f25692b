/// @file gl_context.h
/// @brief The GPU tests' shared headless OpenGL 4.5 context (gl::ComputeContext::shared), with a
///        test failure naming the packages when none can be made.
#pragma once

#include <string>

#include <gtest/gtest.h>

#include "plugin/realtime/gl_compute.h"

namespace nimbus {

/// The shared context, or nullptr with a failure of the calling test (EGL's error included).
inline gl::ComputeContext* requireContext() {
    std::string error;
    gl::ComputeContext* c = gl::ComputeContext::shared(&error);
    EXPECT_NE(c, nullptr) << "no headless OpenGL 4.5 context (EGL surfaceless, Mesa llvmpipe; "
                             "packages libegl-dev libopengl-dev libgl1-mesa-dri): "
                          << error;
    return c;
}

} // namespace nimbus
