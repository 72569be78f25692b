/// @file export_pass.cpp
/// @brief The GL side of running an export (see export_pass.h).
#include "export_pass.h"

#include <algorithm>
#include <cstdio>
#include <cstring>

namespace viewer {
namespace {

// The export's resolve (params.json output.resolve), per pixel of the export's image; row 0 of
// the output buffer is the top of the image, row 0 of the texture its bottom.
const char* const kResolveFragment = R"(#version 430
layout(std430) readonly buffer Pixels { float sums[]; };
uniform int width;
uniform int height;
uniform int stride;       // output.floats_per_pixel
uniform ivec4 rgbaIndex;  // of "sum w*R", "sum w*G", "sum w*B", "sum w*alpha"
uniform int weightIndex;  // of "sum w"
out vec4 color;
void main() {
    int x = int(gl_FragCoord.x), y = height - 1 - int(gl_FragCoord.y);
    int i = stride * (y * width + x);
    float w = sums[i + weightIndex];
    vec4 s = vec4(sums[i + rgbaIndex.x], sums[i + rgbaIndex.y], sums[i + rgbaIndex.z],
                  sums[i + rgbaIndex.w]);
    color = w > 0.0 ? s / w : vec4(0.0);
}
)";

} // namespace

const char* const kFullscreenVertex = R"(#version 430
out vec2 uv;
void main() { // one triangle over the viewport
    vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
    uv = 0.5 * p + 0.5;
    gl_Position = vec4(p, 0.0, 1.0);
}
)";

namespace {

std::uint32_t pcg(std::uint32_t v) {
    const std::uint32_t state = v * 747796405u + 2891336453u;
    const std::uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

} // namespace

std::uint32_t accumulationKey(std::uint32_t frameKey, int pass) {
    if (pass <= 0) return frameKey;
    return pcg(frameKey ^ pcg(std::uint32_t(pass) ^ 0x68e31da4u));
}

GLuint compileShader(GLenum kind, const std::string& source, const char* name, std::string* log) {
    const GLuint shader = glCreateShader(kind);
    const char* text = source.c_str();
    glShaderSource(shader, 1, &text, nullptr);
    glCompileShader(shader);
    GLint ok = 0, length = 0;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
    if (!ok) {
        std::string info(std::size_t(std::max(length, 1)), '\0');
        glGetShaderInfoLog(shader, length, nullptr, info.data());
        *log = std::string(name) + " does not compile:\n" + info;
        glDeleteShader(shader);
        return 0;
    }
    return shader;
}

GLuint linkProgram(std::initializer_list<GLuint> shaders, const char* name, std::string* log) {
    for (GLuint s : shaders)
        if (!s) return 0;
    const GLuint program = glCreateProgram();
    for (GLuint s : shaders) glAttachShader(program, s);
    glLinkProgram(program);
    for (GLuint s : shaders) glDeleteShader(s);
    GLint ok = 0, length = 0;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (!ok) {
        glGetProgramiv(program, GL_INFO_LOG_LENGTH, &length);
        std::string info(std::size_t(std::max(length, 1)), '\0');
        glGetProgramInfoLog(program, length, nullptr, info.data());
        *log = std::string(name) + " does not link:\n" + info;
        glDeleteProgram(program);
        return 0;
    }
    return program;
}

bool createExportPass(ExportFolder& ex, ExportPass& p, std::string* log) {
    std::string unused;
    p.sampleIndex = ex.passes > 1 ? findMember(ex, "sampleIndex", "int", log) : nullptr;
    if (ex.passes > 1 && !p.sampleIndex) return false;
    p.frameKey = findMember(ex, "frameKey", "uint", &unused);
    if (p.frameKey) std::memcpy(&p.exportedKey, ex.params.data() + p.frameKey->offset, 4);
    p.glFailure = true; // from here on every failure is GL's

    p.march = linkProgram({compileShader(GL_COMPUTE_SHADER, ex.shader, "march.comp", log)},
                          "march.comp", log);
    p.resolve = linkProgram(
        {compileShader(GL_VERTEX_SHADER, kFullscreenVertex, "the fullscreen vertex shader", log),
         compileShader(GL_FRAGMENT_SHADER, kResolveFragment, "the resolve shader", log)},
        "the resolve program", log);
    if (!p.march || !p.resolve) return false;

    // the parameter block and the work buffers of params.json
    glGenBuffers(1, &p.paramBuffer);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, p.paramBuffer);
    glBufferData(GL_SHADER_STORAGE_BUFFER, GLsizeiptr(ex.params.size()), ex.params.data(),
                 GL_DYNAMIC_DRAW);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, ex.paramBinding, p.paramBuffer);
    p.work.assign(ex.buffers.size(), 0);
    glGenBuffers(GLsizei(p.work.size()), p.work.data());
    for (std::size_t k = 0; k < p.work.size(); ++k) {
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, p.work[k]);
        const bool data = !ex.buffers[k].data.empty(); // a data buffer: its file, once
        glBufferData(GL_SHADER_STORAGE_BUFFER, GLsizeiptr(ex.buffers[k].bytes),
                     data ? ex.buffers[k].data.data() : nullptr,
                     data ? GL_STATIC_DRAW : GL_DYNAMIC_COPY);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, ex.buffers[k].binding, p.work[k]);
    }
    // the 3D textures of params.json (the noise tiles of field.evaluation = "rgba")
    p.textures.assign(ex.textures.size(), 0);
    for (std::size_t k = 0; k < ex.textures.size(); ++k) {
        const TextureFile& t = ex.textures[k];
        glCreateTextures(GL_TEXTURE_3D, 1, &p.textures[k]);
        glTextureStorage3D(p.textures[k], 1, GL_RGBA8, t.size[0], t.size[1], t.size[2]);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        glTextureSubImage3D(p.textures[k], 0, 0, 0, 0, t.size[0], t.size[1], t.size[2], GL_RGBA,
                            GL_UNSIGNED_BYTE, t.data.data());
        for (GLenum e : {GL_TEXTURE_MIN_FILTER, GL_TEXTURE_MAG_FILTER})
            glTextureParameteri(p.textures[k], e, GL_LINEAR);
        for (GLenum e : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
            glTextureParameteri(p.textures[k], e, GL_REPEAT);
        glBindTextureUnit(t.unit, p.textures[k]);
    }
    // the resolve pass reads the output buffer at output.buffer_binding
    glShaderStorageBlockBinding(
        p.resolve, glGetProgramResourceIndex(p.resolve, GL_SHADER_STORAGE_BLOCK, "Pixels"),
        ex.outputBinding);
    glUseProgram(p.resolve);
    glUniform1i(glGetUniformLocation(p.resolve, "width"), ex.width);
    glUniform1i(glGetUniformLocation(p.resolve, "height"), ex.height);
    glUniform1i(glGetUniformLocation(p.resolve, "stride"), ex.floatsPerPixel);
    glUniform4i(glGetUniformLocation(p.resolve, "rgbaIndex"), ex.rgbaIndex[0], ex.rgbaIndex[1],
                ex.rgbaIndex[2], ex.rgbaIndex[3]);
    glUniform1i(glGetUniformLocation(p.resolve, "weightIndex"), ex.weightIndex);

    // the resolved image: RGBA32F at the export's size
    glGenTextures(1, &p.image);
    glBindTexture(GL_TEXTURE_2D, p.image);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, ex.width, ex.height);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glGenFramebuffers(1, &p.framebuffer);
    glBindFramebuffer(GL_FRAMEBUFFER, p.framebuffer);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, p.image, 0);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        *log = "an RGBA32F framebuffer is not complete";
        return false;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glGenVertexArrays(1, &p.vao);
    glBindVertexArray(p.vao);
    if (const GLenum e = glGetError(); e != GL_NO_ERROR) {
        char text[64];
        std::snprintf(text, sizeof text, "GL error 0x%04X while setting up", e);
        *log = text;
        return false;
    }
    return true;
}

void uploadParams(const ExportFolder& ex, const ExportPass& p) {
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, p.paramBuffer);
    glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(ex.params.size()), ex.params.data());
}

namespace {
void putMember(ExportFolder& ex, const ExportPass& p, const Member& m, const void* value) {
    std::memcpy(ex.params.data() + m.offset, value, 4);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, p.paramBuffer);
    glBufferSubData(GL_SHADER_STORAGE_BUFFER, GLintptr(m.offset), 4, value);
}
} // namespace

void zeroWorkBuffers(const ExportFolder& ex, const ExportPass& p) {
    for (std::size_t k = 0; k < p.work.size(); ++k) {
        if (!ex.buffers[k].data.empty()) continue; // data the pass reads
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, p.work[k]);
        glClearBufferData(GL_SHADER_STORAGE_BUFFER, GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT,
                          nullptr);
    }
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
}

void dispatchPass(ExportFolder& ex, const ExportPass& p, int a) {
    glUseProgram(p.march);
    if (p.frameKey) {
        const std::uint32_t key = accumulationKey(p.exportedKey, a);
        putMember(ex, p, *p.frameKey, &key);
    }
    for (int pass = 0; pass < ex.passes; ++pass) {
        if (p.sampleIndex) {
            const std::int32_t k = pass;
            putMember(ex, p, *p.sampleIndex, &k);
        }
        glDispatchCompute(ex.groups[0], ex.groups[1], ex.groups[2]);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    }
}

void dispatchFrame(ExportFolder& ex, const ExportPass& p, int accumulate) {
    dispatchFrame(ex, p, accumulate, [](int) {});
}

void resolveFrame(const ExportFolder& ex, const ExportPass& p) {
    glBindFramebuffer(GL_FRAMEBUFFER, p.framebuffer);
    glViewport(0, 0, ex.width, ex.height);
    glUseProgram(p.resolve);
    glBindVertexArray(p.vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

std::vector<float> readImage(const ExportFolder& ex, const ExportPass& p) {
    std::vector<float> rgba(std::size_t(ex.width) * std::size_t(ex.height) * 4);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, p.framebuffer);
    glReadPixels(0, 0, ex.width, ex.height, GL_RGBA, GL_FLOAT, rgba.data());
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    return rgba;
}

bool writePfm(const std::string& path, int w, int h, const std::vector<float>& rgbaBottomUp) {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    std::fprintf(f, "PF\n%d %d\n-1.0\n", w, h); // little-endian, rows bottom to top
    std::vector<float> rgb(std::size_t(w) * std::size_t(h) * 3);
    for (std::size_t i = 0; i < rgb.size() / 3; ++i)
        for (int c = 0; c < 3; ++c)
            rgb[3 * i + std::size_t(c)] = rgbaBottomUp[4 * i + std::size_t(c)];
    const bool ok = std::fwrite(rgb.data(), sizeof(float), rgb.size(), f) == rgb.size();
    return std::fclose(f) == 0 && ok;
}

} // namespace viewer
