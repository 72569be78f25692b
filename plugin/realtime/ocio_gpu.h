/// @file ocio_gpu.h
/// @brief OpenColorIO's display/view transform on the GPU: the GLSL that OCIO's GpuShaderDesc
/// generates (io::ColorSystem::displayViewGpuShader, GLSL 4.0) wrapped in a compute shader, its
/// LUT textures uploaded, applied to an RGB image in the headless GL context. `nimbus rt
/// --gpu-display` transforms its previews with it; `nimbus render` keeps OCIO's CPU processor.
///
/// The textures are float (GL_R32F / GL_RGB32F), filtered as OCIO asks (linear or nearest),
/// clamped to the edge: what OCIO's own GL helper (oglapphelpers) does. Uniforms (dynamic
/// properties) are set once, to their values when the shader was made.
///
/// @code
///   io::GpuDisplayShader s = colors.displayViewGpuShader("ACEScg", "sRGB", "ACES 1.0 SDR-video");
///   rt::GpuDisplayTransform t(s);                       // needs a current gl::ComputeContext
///   if (!t.valid()) ... t.error();
///   if (!t.apply(rgb, width, height, &error)) ...       // 3 floats per pixel, in place
/// @endcode
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "plugin/io/color.h"
#include "plugin/realtime/gl_compute.h"

namespace nimbus::rt {

/// The compute shader around OCIO's function: one invocation per pixel, RGB from binding 0,
/// `function(vec4(rgb, 1))`'s RGB to binding 1 (std430 float arrays).
std::string displayComputeSource(const io::GpuDisplayShader& shader);

/// An OCIO display/view transform compiled for the GPU, with its textures uploaded.
class GpuDisplayTransform {
  public:
    /// Compiles the shader and uploads its textures (a current GL context is needed). valid()
    /// is false on failure, with error() saying why (the compiler's log, a GL error).
    explicit GpuDisplayTransform(const io::GpuDisplayShader& shader);
    ~GpuDisplayTransform();
    GpuDisplayTransform(const GpuDisplayTransform&) = delete;
    GpuDisplayTransform& operator=(const GpuDisplayTransform&) = delete;

    bool valid() const { return program_ && program_->valid() && error_.empty(); }
    const std::string& error() const { return error_; }
    /// The number of LUT textures uploaded (1D, 2D and 3D).
    std::size_t textureCount() const { return textures_.size(); }

    /// Transforms @p rgb (3 floats per pixel, width * height pixels) in place; *seconds (when not
    /// null) gets the upload, dispatch and read-back time. False with *error on a GL error or a
    /// wrong size.
    bool apply(std::vector<float>& rgb, int width, int height, std::string* error,
               double* seconds = nullptr) const;

  private:
    std::unique_ptr<gl::ComputeProgram> program_;
    std::vector<unsigned> textures_;     // GL texture names
    std::vector<unsigned> targets_;      // their targets (GL_TEXTURE_1D/2D/3D)
    int locWidth_ = -1, locHeight_ = -1; // the size uniforms
    std::string error_;
};

} // namespace nimbus::rt
