/// @file headless.cpp
/// @brief nimbus_headless: runs a `nimbus export-glsl` folder without a window, as an engine
///        would, and measures its frame time on the GPU. An OpenGL 4.3 core context through EGL
///        (Mesa's surfaceless platform, else the first EGL device that gives one: a GPU server
///        without a display), the export's pass dispatched --frames times after --warmup frames,
///        each frame timed by GL timestamp queries (every accumulation pass apart) and by the
///        wall clock around the frame and a glFinish; the last frame's resolved image written as
///        PFM. No Nimbus library and no window system: it needs EGL, libOpenGL and the export.
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "export_folder.h"
#include "export_pass.h"

namespace {

constexpr int kExitUsage = 2; // bad arguments or a bad export folder
constexpr int kExitGl = 3;    // no OpenGL 4.3 core context, a shader that does not compile

const char* const kUsage =
    "usage: nimbus_headless EXPORT_DIR [--frames N] [--warmup N] [--accumulate N] [--pfm FILE]\n"
    "  EXPORT_DIR      a folder written by `nimbus export-glsl scene.toml -o EXPORT_DIR`\n"
    "  --frames N      timed frames (default 20)\n"
    "  --warmup N      untimed frames first (default 3)\n"
    "  --accumulate N  each frame is N passes with their own jitter (the keys of `nimbus rt\n"
    "                  --accumulate`); the time of one pass is what an engine that spreads\n"
    "                  the passes over displayed frames spends per frame (default 1)\n"
    "  --pfm FILE      the last frame's resolved linear RGB (working space), rows bottom up\n"
    "prints the GL renderer, the EGL platform, and per frame the GPU time (timestamp queries)\n"
    "and the wall time (dispatch to glFinish): median, min and max over the timed frames.\n"
    "exit 0; 2 bad arguments or export; 3 no context or a shader that does not compile\n";

struct Egl {
    EGLDisplay display = EGL_NO_DISPLAY;
    EGLContext context = EGL_NO_CONTEXT;
    std::string platform;
};

/// An OpenGL 4.3 core context on @p display (initialised here), current without a surface.
bool makeContext(EGLDisplay display, Egl& egl) {
    EGLint major = 0, minor = 0;
    if (display == EGL_NO_DISPLAY || !eglInitialize(display, &major, &minor)) return false;
    if (!eglBindAPI(EGL_OPENGL_API)) return false;
    const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION,
                                 4,
                                 EGL_CONTEXT_MINOR_VERSION,
                                 3,
                                 EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                 EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                 EGL_NONE};
    const EGLContext c = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attributes);
    if (c == EGL_NO_CONTEXT) {
        eglTerminate(display);
        return false;
    }
    if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, c)) {
        eglDestroyContext(display, c);
        eglTerminate(display);
        return false;
    }
    egl.display = display;
    egl.context = c;
    return true;
}

/// Mesa's surfaceless platform first (what `nimbus rt` uses), then each EGL device in turn.
bool openContext(Egl& egl, std::string* error) {
    auto getPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (!getPlatformDisplay) {
        *error = "EGL has no eglGetPlatformDisplayEXT";
        return false;
    }
    if (makeContext(getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr),
                    egl)) {
        egl.platform = "surfaceless (EGL_MESA_platform_surfaceless)";
        return true;
    }
    auto queryDevices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    EGLDeviceEXT devices[16];
    EGLint count = 0;
    if (queryDevices && queryDevices(16, devices, &count)) {
        for (EGLint k = 0; k < count; ++k)
            if (makeContext(getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[k], nullptr),
                            egl)) {
                egl.platform = "device " + std::to_string(k) + " of " + std::to_string(count) +
                               " (EGL_EXT_platform_device)";
                return true;
            }
    }
    *error =
        "no OpenGL 4.3 core context through EGL: neither the surfaceless platform nor any of " +
        std::to_string(count) + " EGL device(s) gave one (last EGL error 0x" +
        [] {
            char hex[16];
            std::snprintf(hex, sizeof hex, "%04X", unsigned(eglGetError()));
            return std::string(hex);
        }() +
        ")";
    return false;
}

struct Summary {
    double median = 0.0, min = 0.0, max = 0.0;
};

Summary summarise(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    Summary s;
    if (v.empty()) return s;
    const std::size_t n = v.size();
    s.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    s.min = v.front();
    s.max = v.back();
    return s;
}

} // namespace

int main(int argc, char** argv) {
    std::string dir, pfm;
    int frames = 20, warmup = 3, accumulate = 1;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const bool hasValue = i + 1 < argc;
        if (a == "-h" || a == "--help") {
            std::fputs(kUsage, stdout);
            return 0;
        } else if (a == "--frames" && hasValue) {
            if (!viewer::parseCount(argv[++i], 1, 100000, &frames)) {
                std::fprintf(stderr, "nimbus_headless: --frames wants a count in 1..100000\n");
                return kExitUsage;
            }
        } else if (a == "--warmup" && hasValue) {
            if (!viewer::parseCount(argv[++i], 0, 100000, &warmup)) {
                std::fprintf(stderr, "nimbus_headless: --warmup wants a count in 0..100000\n");
                return kExitUsage;
            }
        } else if (a == "--accumulate" && hasValue) {
            if (!viewer::parseCount(argv[++i], 1, 4096, &accumulate)) {
                std::fprintf(stderr, "nimbus_headless: --accumulate wants a count in 1..4096\n");
                return kExitUsage;
            }
        } else if (a == "--pfm" && hasValue) {
            pfm = argv[++i];
        } else if (a[0] != '-' && dir.empty()) {
            dir = a;
        } else {
            std::fprintf(stderr, "nimbus_headless: unknown or incomplete argument %s\n%s",
                         a.c_str(), kUsage);
            return kExitUsage;
        }
    }
    if (dir.empty()) {
        std::fputs(kUsage, stderr);
        return kExitUsage;
    }

    viewer::ExportFolder ex;
    std::string error;
    if (!viewer::loadExport(dir, ex, &error)) {
        std::fprintf(stderr, "nimbus_headless: %s\n", error.c_str());
        return kExitUsage;
    }
    Egl egl;
    if (!openContext(egl, &error)) {
        std::fprintf(stderr, "nimbus_headless: %s\n", error.c_str());
        return kExitGl;
    }
    std::printf("GL: %s; %s; EGL platform: %s\n",
                reinterpret_cast<const char*>(glGetString(GL_RENDERER)),
                reinterpret_cast<const char*>(glGetString(GL_VERSION)), egl.platform.c_str());
    viewer::ExportPass pass;
    const auto compileStart = std::chrono::steady_clock::now();
    if (!viewer::createExportPass(ex, pass, &error)) {
        std::fprintf(stderr, "nimbus_headless: %s/%s\n", dir.c_str(), error.c_str());
        return pass.glFailure ? kExitGl : kExitUsage;
    }
    if (accumulate > 1 && !pass.frameKey) {
        std::fprintf(stderr,
                     "nimbus_headless: %s: the parameter block has no uint frameKey, so "
                     "--accumulate cannot re-key its passes\n",
                     dir.c_str());
        return kExitUsage;
    }
    glFinish();
    const double compileMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - compileStart)
            .count();
    std::printf("export: %s, %dx%d, %d pixel-sample pass(es), accumulate %d; setup (compile, "
                "upload) %.1f ms\n",
                dir.c_str(), ex.width, ex.height, ex.passes, accumulate, compileMs);

    std::vector<GLuint> stamps(std::size_t(accumulate) + 1);
    glGenQueries(GLsizei(stamps.size()), stamps.data());
    std::vector<double> gpuFrame, gpuPass, wallFrame;
    for (int f = 0; f < warmup + frames; ++f) {
        const auto start = std::chrono::steady_clock::now();
        viewer::dispatchFrame(ex, pass, accumulate,
                              [&](int a) { glQueryCounter(stamps[std::size_t(a)], GL_TIMESTAMP); });
        glFinish();
        const double wall =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count();
        std::vector<GLuint64> t(stamps.size());
        for (std::size_t k = 0; k < stamps.size(); ++k)
            glGetQueryObjectui64v(stamps[k], GL_QUERY_RESULT, &t[k]);
        if (f < warmup) continue;
        wallFrame.push_back(wall);
        gpuFrame.push_back(double(t.back() - t.front()) * 1e-6);
        for (int a = 0; a < accumulate; ++a)
            gpuPass.push_back(double(t[std::size_t(a) + 1] - t[std::size_t(a)]) * 1e-6);
    }
    if (const GLenum e = glGetError(); e != GL_NO_ERROR) {
        std::fprintf(stderr, "nimbus_headless: GL error 0x%04X while rendering\n", e);
        return kExitGl;
    }
    const Summary g = summarise(gpuFrame), p = summarise(gpuPass), w = summarise(wallFrame);
    std::printf("frame GPU ms: median %.3f, min %.3f, max %.3f over %d frames\n", g.median, g.min,
                g.max, frames);
    std::printf("pass GPU ms: median %.3f, min %.3f, max %.3f over %zu accumulation passes\n",
                p.median, p.min, p.max, gpuPass.size());
    std::printf("frame wall ms: median %.3f, min %.3f, max %.3f\n", w.median, w.min, w.max);
    if (!pfm.empty()) {
        viewer::resolveFrame(ex, pass);
        const std::vector<float> rgba = viewer::readImage(ex, pass);
        std::size_t bad = 0;
        for (float v : rgba) bad += !std::isfinite(v);
        if (!viewer::writePfm(pfm, ex.width, ex.height, rgba)) {
            std::fprintf(stderr, "nimbus_headless: could not write %s\n", pfm.c_str());
            return kExitUsage;
        }
        std::printf("wrote %s (%zu non-finite values)\n", pfm.c_str(), bad);
    }
    eglMakeCurrent(egl.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(egl.display, egl.context);
    eglTerminate(egl.display);
    return 0;
}
