/// @file gl_compute.cpp
/// @brief Headless OpenGL compute over EGL (see gl_compute.h).
#include "plugin/realtime/gl_compute.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <vector>

namespace nimbus::gl {
namespace {

std::string hex(unsigned v) {
    char buf[16];
    std::snprintf(buf, sizeof(buf), "0x%04X", v);
    return buf;
}

std::string eglErrorText(EGLint e) {
    const char* name = "unknown EGL error";
    switch (e) {
    case EGL_SUCCESS:
        name = "EGL_SUCCESS";
        break;
    case EGL_NOT_INITIALIZED:
        name = "EGL_NOT_INITIALIZED";
        break;
    case EGL_BAD_ACCESS:
        name = "EGL_BAD_ACCESS";
        break;
    case EGL_BAD_ALLOC:
        name = "EGL_BAD_ALLOC";
        break;
    case EGL_BAD_ATTRIBUTE:
        name = "EGL_BAD_ATTRIBUTE";
        break;
    case EGL_BAD_CONFIG:
        name = "EGL_BAD_CONFIG";
        break;
    case EGL_BAD_CONTEXT:
        name = "EGL_BAD_CONTEXT";
        break;
    case EGL_BAD_CURRENT_SURFACE:
        name = "EGL_BAD_CURRENT_SURFACE";
        break;
    case EGL_BAD_DISPLAY:
        name = "EGL_BAD_DISPLAY";
        break;
    case EGL_BAD_MATCH:
        name = "EGL_BAD_MATCH";
        break;
    case EGL_BAD_NATIVE_PIXMAP:
        name = "EGL_BAD_NATIVE_PIXMAP";
        break;
    case EGL_BAD_NATIVE_WINDOW:
        name = "EGL_BAD_NATIVE_WINDOW";
        break;
    case EGL_BAD_PARAMETER:
        name = "EGL_BAD_PARAMETER";
        break;
    case EGL_BAD_SURFACE:
        name = "EGL_BAD_SURFACE";
        break;
    case EGL_CONTEXT_LOST:
        name = "EGL_CONTEXT_LOST";
        break;
    default:
        break;
    }
    return std::string(name) + " (" + hex(unsigned(e)) + ")";
}

std::string glErrorName(GLenum e) {
    switch (e) {
    case GL_INVALID_ENUM:
        return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE:
        return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION:
        return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION:
        return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY:
        return "GL_OUT_OF_MEMORY";
    case GL_STACK_UNDERFLOW:
        return "GL_STACK_UNDERFLOW";
    case GL_STACK_OVERFLOW:
        return "GL_STACK_OVERFLOW";
    default:
        return hex(e);
    }
}

bool fail(std::string* error, const std::string& what) {
    if (error) *error = what;
    return false;
}

} // namespace

std::unique_ptr<ComputeContext> ComputeContext::create(std::string* error) {
    auto eglFail = [&](const char* call) {
        fail(error, std::string(call) + ": " + eglErrorText(eglGetError()));
        return nullptr;
    };
    auto getPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (!getPlatformDisplay) return eglFail("eglGetProcAddress(eglGetPlatformDisplayEXT)");
    EGLDisplay display =
        getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display == EGL_NO_DISPLAY)
        return eglFail("eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA)");
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) return eglFail("eglInitialize");
    std::unique_ptr<ComputeContext> c(new ComputeContext());
    c->display_ = display; // from here on the destructor terminates the display
    if (!eglBindAPI(EGL_OPENGL_API)) return eglFail("eglBindAPI(EGL_OPENGL_API)");
    const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                                 4,
                                 EGL_CONTEXT_MINOR_VERSION,
                                 5,
                                 EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                 EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                 EGL_NONE};
    EGLContext context = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attributes);
    if (context == EGL_NO_CONTEXT)
        return eglFail("eglCreateContext(OpenGL 4.5 core, EGL_NO_CONFIG_KHR)");
    c->context_ = context;
    if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context))
        return eglFail("eglMakeCurrent(EGL_NO_SURFACE)");
    return c;
}

ComputeContext* ComputeContext::shared(std::string* error) {
    static std::string failure;
    static const std::unique_ptr<ComputeContext> context = create(&failure);
    if (error) *error = failure;
    return context.get();
}

ComputeContext::~ComputeContext() {
    EGLDisplay display = static_cast<EGLDisplay>(display_);
    if (context_) {
        eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(display, static_cast<EGLContext>(context_));
    }
    if (display) eglTerminate(display);
}

std::string ComputeContext::renderer() const {
    const GLubyte* r = glGetString(GL_RENDERER);
    const GLubyte* v = glGetString(GL_VERSION);
    return std::string(r ? reinterpret_cast<const char*>(r) : "?") + "; " +
           (v ? reinterpret_cast<const char*>(v) : "?");
}

ComputeProgram::ComputeProgram(std::string_view source) {
    const GLuint shader = glCreateShader(GL_COMPUTE_SHADER);
    if (shader == 0) {
        log_ = "glCreateShader(GL_COMPUTE_SHADER) failed: " + glErrors();
        return;
    }
    const GLchar* text = source.data();
    const GLint length = GLint(source.size());
    glShaderSource(shader, 1, &text, &length);
    glCompileShader(shader);
    auto infoLog = [](GLuint object, bool isProgram) {
        GLint n = 0;
        if (isProgram)
            glGetProgramiv(object, GL_INFO_LOG_LENGTH, &n);
        else
            glGetShaderiv(object, GL_INFO_LOG_LENGTH, &n);
        std::string s(std::size_t(n > 0 ? n : 0), '\0');
        if (n > 0) {
            if (isProgram)
                glGetProgramInfoLog(object, n, nullptr, s.data());
            else
                glGetShaderInfoLog(object, n, nullptr, s.data());
            s.resize(s.find('\0') == std::string::npos ? s.size() : s.find('\0'));
        }
        return s;
    };
    GLint ok = GL_FALSE;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) {
        log_ = "compile failed:\n" + infoLog(shader, false);
        glDeleteShader(shader);
        return;
    }
    const GLuint program = glCreateProgram();
    glAttachShader(program, shader);
    glLinkProgram(program);
    glDeleteShader(shader); // flagged; freed with the program
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok != GL_TRUE) {
        log_ = "link failed:\n" + infoLog(program, true);
        glDeleteProgram(program);
        return;
    }
    GLint size[3] = {0, 0, 0};
    glGetProgramiv(program, GL_COMPUTE_WORK_GROUP_SIZE, size);
    id_ = program;
    localSizeX_ = unsigned(size[0]);
}

ComputeProgram::~ComputeProgram() {
    if (id_) glDeleteProgram(id_);
}

void ComputeProgram::dispatch(unsigned groupsX, unsigned groupsY, unsigned groupsZ) const {
    glUseProgram(id_);
    glDispatchCompute(groupsX, groupsY, groupsZ);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
}

StorageBuffer::StorageBuffer(std::size_t bytes, const void* data) : bytes_(bytes) {
    glCreateBuffers(1, &id_);
    glNamedBufferStorage(id_, GLsizeiptr(bytes), data, GL_DYNAMIC_STORAGE_BIT);
    // zeros written by the GL where the buffer lives, not copied from the host
    if (!data) clear();
}

void StorageBuffer::clear() {
    if (bytes_ % 4 == 0)
        glClearNamedBufferData(id_, GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, nullptr);
    else
        glClearNamedBufferData(id_, GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, nullptr);
}

StorageBuffer::~StorageBuffer() {
    if (id_) glDeleteBuffers(1, &id_);
    if (staging_) glDeleteBuffers(1, &staging_);
}

void StorageBuffer::bind(unsigned binding) const {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, id_);
}

void StorageBuffer::read(void* dst, std::size_t bytes, std::size_t offset) const {
    constexpr std::size_t kStaged = std::size_t(1) << 20;
    if (bytes < kStaged) {
        glGetNamedBufferSubData(id_, GLintptr(offset), GLsizeiptr(bytes), dst);
        return;
    }
    if (stagingBytes_ < bytes) {
        if (staging_) glDeleteBuffers(1, &staging_);
        glCreateBuffers(1, &staging_);
        glNamedBufferStorage(staging_, GLsizeiptr(bytes), nullptr,
                             GL_MAP_READ_BIT | GL_CLIENT_STORAGE_BIT);
        stagingBytes_ = bytes;
    }
    glCopyNamedBufferSubData(id_, staging_, GLintptr(offset), 0, GLsizeiptr(bytes));
    // mapping waits for the copy
    const void* p = glMapNamedBufferRange(staging_, 0, GLsizeiptr(bytes), GL_MAP_READ_BIT);
    if (!p) { // the GL refused the map (its error stays pending for the caller): the plain read
        glGetNamedBufferSubData(id_, GLintptr(offset), GLsizeiptr(bytes), dst);
        return;
    }
    std::memcpy(dst, p, bytes);
    glUnmapNamedBuffer(staging_);
}

Texture3D::Texture3D(int res, const std::uint8_t* rgba) {
    glCreateTextures(GL_TEXTURE_3D, 1, &id_);
    glTextureStorage3D(id_, 1, GL_RGBA8, res, res, res);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4); // rows of 4 res bytes
    glTextureSubImage3D(id_, 0, 0, 0, 0, res, res, res, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    glTextureParameteri(id_, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(id_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(id_, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(id_, GL_TEXTURE_WRAP_T, GL_REPEAT);
    glTextureParameteri(id_, GL_TEXTURE_WRAP_R, GL_REPEAT);
}

Texture3D::~Texture3D() {
    if (id_) glDeleteTextures(1, &id_);
}

void Texture3D::bind(unsigned unit) const {
    glBindTextureUnit(unit, id_);
}

std::string glErrors() {
    std::string s;
    for (int i = 0; i < 16; ++i) {
        const GLenum e = glGetError();
        if (e == GL_NO_ERROR) break;
        if (!s.empty()) s += ", ";
        s += glErrorName(e);
    }
    return s;
}

bool runCompute(const ComputeProgram& program, std::span<const std::uint32_t> in,
                std::span<std::uint32_t> out, std::size_t invocations, std::string* error) {
    if (!program.valid()) return fail(error, "invalid program: " + program.log());
    if (program.localSizeX() == 0) return fail(error, "program has no local size");
    glErrors(); // drop stale errors
    // zero-sized buffers are not allowed: keep at least one word
    StorageBuffer input(std::max<std::size_t>(in.size_bytes(), 4), in.data());
    StorageBuffer output(std::max<std::size_t>(out.size_bytes(), 4));
    input.bind(0);
    output.bind(1);
    const std::size_t groups = (invocations + program.localSizeX() - 1) / program.localSizeX();
    program.dispatch(unsigned(groups));
    output.read(out.data(), out.size_bytes());
    const std::string e = glErrors();
    if (!e.empty()) return fail(error, "GL error during dispatch or read-back: " + e);
    return true;
}

} // namespace nimbus::gl
