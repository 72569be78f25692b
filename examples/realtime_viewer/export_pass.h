/// @file export_pass.h
/// @brief The GL side of running an export (docs/realtime.md, "Export for engines"), shared by
///        the window (viewer.cpp) and the headless runner (headless.cpp): march.comp compiled,
///        the parameter block and the work buffers of params.json made, a frame dispatched
///        (work buffers zeroed, one dispatch per pixel-sample pass, optionally several
///        accumulation passes with their own frame keys), the output resolved into an RGBA32F
///        image at the export's size. Needs a current OpenGL 4.3 core context.
#pragma once

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

#include "export_folder.h"

namespace viewer {

/// A vertex shader drawing one triangle over the viewport, `out vec2 uv` in [0,1].
extern const char* const kFullscreenVertex;

/// A shader of @p kind from @p source; 0 with *log (naming @p name) when it does not compile.
GLuint compileShader(GLenum kind, const std::string& source, const char* name, std::string* log);

/// Links the shaders (0 = missing: the compile failed); 0 with *log on failure.
GLuint linkProgram(std::initializer_list<GLuint> shaders, const char* name, std::string* log);

/// The key of accumulation pass @p pass of a frame whose key is @p frameKey: the frame's own
/// for pass 0, pcg(frameKey ^ pcg(pass ^ 0x68e31da4)) after it (what `nimbus rt --accumulate`
/// gives its passes, docs/realtime.md "Temporal accumulation"; pcg: Jarzynski & Olano 2020).
std::uint32_t accumulationKey(std::uint32_t frameKey, int pass);

/// What the GL side of an export holds once made.
struct ExportPass {
    GLuint march = 0, resolve = 0;
    GLuint paramBuffer = 0;
    std::vector<GLuint> work;     ///< one per ExportFolder::buffers
    std::vector<GLuint> textures; ///< one per ExportFolder::textures
    GLuint image = 0, framebuffer = 0, vao = 0;
    const Member* sampleIndex = nullptr; ///< when the export has more than one pass
    const Member* frameKey = nullptr;    ///< when present: accumulation passes re-key it
    std::uint32_t exportedKey = 0;       ///< the frame key params.bin was written with
    /// after a failed createExportPass: true when GL failed (a shader that does not compile or
    /// link, a GL error, an incomplete framebuffer), false when the export lacks a member
    bool glFailure = false;
};

/// Compiles march.comp and the resolve program, uploads the block and the data buffers, makes
/// the RGBA32F image. False with *log (the compiler's log, a missing member, a GL error).
bool createExportPass(ExportFolder& ex, ExportPass& p, std::string* log);

/// Uploads ex.params whole (after the host edited members, e.g. the camera).
void uploadParams(const ExportFolder& ex, const ExportPass& p);

/// Zeroes the buffers the pass writes (the output sums, the counters): the start of a frame or
/// of an accumulation.
void zeroWorkBuffers(const ExportFolder& ex, const ExportPass& p);

/// Accumulation pass @p a of a frame into the current sums: the frame key
/// accumulationKey(exported key, a) (when the block has frameKey; pass 0 keeps the exported
/// key), then every pixel-sample pass dispatched.
void dispatchPass(ExportFolder& ex, const ExportPass& p, int a);

/// One frame's march: the work buffers zeroed, then @p accumulate passes (dispatchPass 0 ..
/// accumulate - 1; needs the frameKey member when > 1) into the same sums. @p passMarker, when
/// given, is called before each pass and once after the last (accumulate + 1 calls, for
/// timers).
template <class Marker>
void dispatchFrame(ExportFolder& ex, const ExportPass& p, int accumulate, Marker&& passMarker) {
    zeroWorkBuffers(ex, p);
    for (int a = 0; a < accumulate; ++a) {
        passMarker(a);
        dispatchPass(ex, p, a);
    }
    passMarker(accumulate);
}
void dispatchFrame(ExportFolder& ex, const ExportPass& p, int accumulate);

/// Resolves the output buffer (RGBA = sums / sum w) into p.image (binds p.framebuffer and sets
/// the viewport to the export's size).
void resolveFrame(const ExportFolder& ex, const ExportPass& p);

/// The resolved image, RGBA floats, rows bottom to top.
std::vector<float> readImage(const ExportFolder& ex, const ExportPass& p);

/// A PFM (linear RGB, little-endian, rows bottom to top) of @p rgbaBottomUp.
bool writePfm(const std::string& path, int w, int h, const std::vector<float>& rgbaBottomUp);

} // namespace viewer
