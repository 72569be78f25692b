/// @file ocio_gpu.cpp
/// @brief OpenColorIO's display/view transform on the GPU (see ocio_gpu.h).
#include "plugin/realtime/ocio_gpu.h"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <chrono>

namespace nimbus::rt {

std::string displayComputeSource(const io::GpuDisplayShader& shader) {
    std::string s = "#version 430\n";
    s += "// OpenColorIO's display/view transform (GpuShaderDesc, GLSL 4.0), cache ID " +
         shader.cacheId + "\n";
    s += shader.text;
    s += R"(
// one invocation per pixel: RGB in (binding 0), the transform's RGB out (binding 1)
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer RtDisplayIn { float rgbIn[]; };
layout(std430, binding = 1) writeonly buffer RtDisplayOut { float rgbOut[]; };
uniform int rtDisplayWidth;
uniform int rtDisplayHeight;
void main() {
    int x = int(gl_GlobalInvocationID.x);
    int y = int(gl_GlobalInvocationID.y);
    if (x >= rtDisplayWidth || y >= rtDisplayHeight) return;
    int i = 3 * (y * rtDisplayWidth + x);
    vec4 c = )" +
         shader.function +
         R"((vec4(rgbIn[i], rgbIn[i + 1], rgbIn[i + 2], 1.0));
    rgbOut[i] = c.r;
    rgbOut[i + 1] = c.g;
    rgbOut[i + 2] = c.b;
}
)";
    return s;
}

GpuDisplayTransform::GpuDisplayTransform(const io::GpuDisplayShader& shader) {
    gl::glErrors(); // drop stale errors
    program_ = std::make_unique<gl::ComputeProgram>(displayComputeSource(shader));
    if (!program_->valid()) {
        error_ = "the display transform's shader does not compile: " + program_->log();
        return;
    }
    const GLuint prog = program_->id();
    locWidth_ = glGetUniformLocation(prog, "rtDisplayWidth");
    locHeight_ = glGetUniformLocation(prog, "rtDisplayHeight");
    // the LUTs: one texture unit each, in OCIO's order
    for (std::size_t k = 0; k < shader.textures.size(); ++k) {
        const io::GpuDisplayShader::Texture& t = shader.textures[k];
        const GLenum target = t.depth > 0    ? GL_TEXTURE_3D
                              : t.height > 1 ? GL_TEXTURE_2D
                                             : GL_TEXTURE_1D;
        const GLenum internal = t.channels == 1 ? GL_R32F : GL_RGB32F;
        const GLenum format = t.channels == 1 ? GL_RED : GL_RGB;
        const GLint filter = t.linear ? GL_LINEAR : GL_NEAREST;
        GLuint id = 0;
        glGenTextures(1, &id);
        textures_.push_back(id);
        targets_.push_back(target);
        glActiveTexture(GL_TEXTURE0 + GLenum(k));
        glBindTexture(target, id);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        if (target == GL_TEXTURE_3D)
            glTexImage3D(target, 0, GLint(internal), t.width, t.height, t.depth, 0, format,
                         GL_FLOAT, t.values.data());
        else if (target == GL_TEXTURE_2D)
            glTexImage2D(target, 0, GLint(internal), t.width, t.height, 0, format, GL_FLOAT,
                         t.values.data());
        else
            glTexImage1D(target, 0, GLint(internal), t.width, 0, format, GL_FLOAT, t.values.data());
        glTexParameteri(target, GL_TEXTURE_MIN_FILTER, filter);
        glTexParameteri(target, GL_TEXTURE_MAG_FILTER, filter);
        glTexParameteri(target, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTexParameteri(target, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        glTexParameteri(target, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
        glTexParameteri(target, GL_TEXTURE_BASE_LEVEL, 0);
        glTexParameteri(target, GL_TEXTURE_MAX_LEVEL, 0);
        const GLint loc = glGetUniformLocation(prog, t.sampler.c_str());
        if (loc < 0) {
            error_ = "the display transform's shader has no sampler '" + t.sampler + "'";
            return;
        }
        glProgramUniform1i(prog, loc, GLint(k));
    }
    for (const io::GpuDisplayShader::Uniform& u : shader.uniforms) {
        const GLint loc = glGetUniformLocation(prog, u.name.c_str());
        if (loc < 0) continue; // declared but optimised away by the compiler
        using K = io::GpuDisplayShader::Uniform::Kind;
        switch (u.kind) {
        case K::Float:
            glProgramUniform1f(prog, loc, u.values.at(0));
            break;
        case K::Bool:
            glProgramUniform1i(prog, loc, u.values.at(0) != 0.0f ? 1 : 0);
            break;
        case K::Float3:
            glProgramUniform3fv(prog, loc, 1, u.values.data());
            break;
        case K::FloatArray:
            glProgramUniform1fv(prog, loc, GLsizei(u.values.size()), u.values.data());
            break;
        case K::IntArray:
            glProgramUniform1iv(prog, loc, GLsizei(u.ints.size()), u.ints.data());
            break;
        }
    }
    const std::string e = gl::glErrors();
    if (!e.empty()) error_ = "GL error while uploading the display transform's LUTs: " + e;
}

GpuDisplayTransform::~GpuDisplayTransform() {
    if (!textures_.empty()) glDeleteTextures(GLsizei(textures_.size()), textures_.data());
}

bool GpuDisplayTransform::apply(std::vector<float>& rgb, int width, int height, std::string* error,
                                double* seconds) const {
    if (!valid()) {
        if (error) *error = error_.empty() ? "the display transform is not valid" : error_;
        return false;
    }
    const std::size_t n = std::size_t(width) * std::size_t(height);
    if (width <= 0 || height <= 0 || rgb.size() != 3 * n) {
        if (error)
            *error = std::to_string(rgb.size()) + " values for " + std::to_string(width) + "x" +
                     std::to_string(height) + " RGB pixels";
        return false;
    }
    const auto t0 = std::chrono::steady_clock::now();
    gl::glErrors();
    const GLuint prog = program_->id();
    glProgramUniform1i(prog, locWidth_, width);
    glProgramUniform1i(prog, locHeight_, height);
    for (std::size_t k = 0; k < textures_.size(); ++k) {
        glActiveTexture(GL_TEXTURE0 + GLenum(k));
        glBindTexture(targets_[k], textures_[k]);
    }
    const gl::StorageBuffer in(rgb.size() * sizeof(float), rgb.data());
    const gl::StorageBuffer out(rgb.size() * sizeof(float));
    in.bind(0);
    out.bind(1);
    program_->dispatch(unsigned((width + 7) / 8), unsigned((height + 7) / 8));
    out.read(rgb.data(), rgb.size() * sizeof(float));
    if (seconds)
        *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string e = gl::glErrors();
    if (!e.empty()) {
        if (error) *error = "GL error during the display transform: " + e;
        return false;
    }
    return true;
}

} // namespace nimbus::rt
