/// @file gl_compute.h
/// @brief Headless OpenGL compute: an EGL context without a window, compute programs, shader
///        storage buffers, dispatch and read-back. Used by the real-time renderer
///        (plugin/realtime/rt_march.h, `nimbus rt`) and by the kernel parity tests (tests/gl/).
///
/// The context is OpenGL 4.5 core on EGL's surfaceless platform (EGL_PLATFORM_SURFACELESS_MESA,
/// EGL_NO_CONFIG_KHR, no surface): no X server and no GPU needed, Mesa's llvmpipe runs it on the
/// CPU (packages libegl-dev libopengl-dev libgl1-mesa-dri; link -lEGL -lOpenGL). Every call
/// reports failure as text (which step, the EGL or GL error, the info log); nothing throws.
///
/// @code
///   std::string error;
///   auto context = gl::ComputeContext::create(&error);     // null on failure, see error
///   gl::ComputeProgram program("#version 430\n" + text);   // program.log() on failure
///   std::vector<std::uint32_t> out(n);
///   if (!gl::runCompute(program, in, out, n, &error)) ...  // SSBO 0 in, SSBO 1 out
/// @endcode
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>

namespace nimbus::gl {

/// A headless OpenGL 4.5 core context, current on the thread that created it. One per process
/// is enough; it must outlive the programs and buffers made while it is current.
class ComputeContext {
  public:
    /// Creates the context and makes it current; null on failure, with *error naming the EGL
    /// call that failed and the EGL error (e.g. "eglInitialize: EGL_NOT_INITIALIZED (0x3001)").
    static std::unique_ptr<ComputeContext> create(std::string* error);
    /// The process's context, made (and made current) on first use and kept to the end of the
    /// process; null with *error (the first failure's text) when it cannot be made. Parts of one
    /// process that each need GL share this one: destroying a second context would terminate
    /// the EGL display under the first.
    static ComputeContext* shared(std::string* error);
    ~ComputeContext();
    ComputeContext(const ComputeContext&) = delete;
    ComputeContext& operator=(const ComputeContext&) = delete;

    /// GL_RENDERER and GL_VERSION, e.g. "llvmpipe (LLVM 15.0.6, 256 bits); 4.5 (Core Profile)
    /// Mesa 22.3.6".
    std::string renderer() const;

  private:
    ComputeContext() = default;
    void* display_ = nullptr; // EGLDisplay
    void* context_ = nullptr; // EGLContext
};

/// A compiled and linked compute shader (needs a current context).
class ComputeProgram {
  public:
    /// Compiles and links @p source (with its own #version line). On failure valid() is false
    /// and log() holds the compiler's or linker's info log.
    explicit ComputeProgram(std::string_view source);
    ~ComputeProgram();
    ComputeProgram(const ComputeProgram&) = delete;
    ComputeProgram& operator=(const ComputeProgram&) = delete;

    bool valid() const { return id_ != 0; }
    const std::string& log() const { return log_; }
    unsigned id() const { return id_; }
    /// layout(local_size_x = ...) of the shader (0 if not valid).
    unsigned localSizeX() const { return localSizeX_; }

    /// Uses the program, dispatches the groups and waits for the buffer writes
    /// (glMemoryBarrier). Buffers must be bound before.
    void dispatch(unsigned groupsX, unsigned groupsY = 1, unsigned groupsZ = 1) const;

  private:
    unsigned id_ = 0;
    unsigned localSizeX_ = 0;
    std::string log_;
};

/// A shader storage buffer (immutable size; needs a current context).
class StorageBuffer {
  public:
    /// @p bytes of storage, initialised from @p data when not null (else zeros).
    explicit StorageBuffer(std::size_t bytes, const void* data = nullptr);
    ~StorageBuffer();
    StorageBuffer(const StorageBuffer&) = delete;
    StorageBuffer& operator=(const StorageBuffer&) = delete;

    /// Binds to `layout(std430, binding = @p binding) buffer`.
    void bind(unsigned binding) const;
    /// Copies @p bytes from @p offset into @p dst. Reads of a megabyte or more go through a
    /// staging buffer in the host's memory (GL_CLIENT_STORAGE_BIT, mapped for reading), kept
    /// for the next read: a GPU driver copies to it at the bus' speed.
    void read(void* dst, std::size_t bytes, std::size_t offset = 0) const;
    /// Sets every byte to 0 (on the GL's side: nothing crosses from the host; a size that is a
    /// multiple of 4 is cleared as 32-bit words).
    void clear();
    std::size_t size() const { return bytes_; }

  private:
    unsigned id_ = 0;
    std::size_t bytes_ = 0;
    mutable unsigned staging_ = 0; ///< read()'s staging buffer (0 until a large read)
    mutable std::size_t stagingBytes_ = 0;
};

/// A periodic RGBA8 3D texture of res^3 texels (x fastest, then y, then z; 4 bytes a texel),
/// filtered by the texture unit: GL_LINEAR, GL_REPEAT on every axis, no mipmaps.
class Texture3D {
  public:
    Texture3D(int res, const std::uint8_t* rgba);
    ~Texture3D();
    Texture3D(const Texture3D&) = delete;
    Texture3D& operator=(const Texture3D&) = delete;
    /// Binds to `layout(binding = @p unit) uniform sampler3D`.
    void bind(unsigned unit) const;

  private:
    unsigned id_ = 0;
};

/// The pending GL errors as text ("" when there is none); clears them.
std::string glErrors();

/// The common case: @p in as the buffer at binding 0, @p out at binding 1, @p invocations
/// threads (rounded up to whole groups of the program's local size x; the shader skips the
/// extra ones), then @p out read back. False with *error on an invalid program or a GL error.
bool runCompute(const ComputeProgram& program, std::span<const std::uint32_t> in,
                std::span<std::uint32_t> out, std::size_t invocations, std::string* error);

} // namespace nimbus::gl
