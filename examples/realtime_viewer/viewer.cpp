/// @file viewer.cpp
/// @brief nimbus_viewer: flies a camera through the clouds of a `nimbus export-glsl` folder.
///
/// Each frame: the camera members of the parameter block (found by name in params.json, written
/// at the offsets it gives) are updated from the mouse and keys, the pass's work buffers are
/// zeroed, march.comp is dispatched `dispatch.passes` times (sampleIndex = pass number), a
/// fragment pass resolves the output buffer (RGBA = sums / sum w, the layout named by
/// output.floats) into a float texture at the export's size, and a second fragment pass shows it
/// in the window (ACEScg to sRGB, exposure). The frame time goes to the window title and to
/// stdout once a second. See README.md for building, running and the controls.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <string>
#include <vector>

#include "export_folder.h"
#include "export_pass.h"

namespace {

constexpr int kExitUsage = 2; // bad arguments or a bad export folder
constexpr int kExitGl = 3;    // no window / GL 4.3 core context, a shader that does not compile

const char* const kUsage =
    "usage: nimbus_viewer EXPORT_DIR [--frames N] [--screenshot FILE.pfm|FILE.ppm]...\n"
    "                     [--window WxH] [--move RIGHT,UP,FORWARD] [--turn YAW,PITCH]\n"
    "                     [--accumulate N]\n"
    "  EXPORT_DIR     a folder written by `nimbus export-glsl scene.toml -o EXPORT_DIR`\n"
    "  --frames N     render N frames (1..100000000), write the screenshots of the last one, exit\n"
    "  --screenshot   .pfm: the resolved linear RGB at the export's size (working space);\n"
    "                 .ppm: the window as shown (8-bit sRGB). Key P writes them too\n"
    "  --window WxH   window size (default: the export's image, scaled up to >= 960 wide)\n"
    "  --move R,U,F   move the camera before the first frame (world units: along its right,\n"
    "                 the world's up, its forward), as the keys do\n"
    "  --turn Y,P     turn the camera before the first frame (degrees: yaw left, pitch up)\n"
    "  --accumulate N temporal accumulation: while the camera stands still each frame adds one\n"
    "                 pass with its own jitter (the keys of `nimbus rt --accumulate`) until N\n"
    "                 are summed, then the march rests; a move starts again (default 1: every\n"
    "                 frame one pass, nothing kept)\n"
    "controls: mouse drag (left button) look; W/S forward/back; A/D left/right; Q/E down/up;\n"
    "  Shift x5 speed, Ctrl x0.2; +/- (or wheel) double/halve the speed; [/] exposure;\n"
    "  R reset the camera; P screenshots; Esc quit\n";

// --- the camera, edited in the parameter block at params.json's offsets ------------------------

struct Camera {
    glm::vec3 origin, forward, right, up;
    float yaw = 0.0f, pitch = 0.0f; // radians, of forward: yaw about +y from +z, pitch up

    /// Forward from the angles; right and up as core/camera.h makes them for world up +y.
    void turnTo(float newYaw, float newPitch) {
        yaw = newYaw;
        pitch = std::clamp(newPitch, -1.55f, 1.55f);
        forward = glm::vec3(std::cos(pitch) * std::sin(yaw), std::sin(pitch),
                            std::cos(pitch) * std::cos(yaw));
        right = glm::normalize(glm::cross(forward, glm::vec3(0.0f, 1.0f, 0.0f)));
        up = glm::cross(right, forward);
    }
    /// Along the camera's right, the world's up and the camera's forward.
    void move(const glm::vec3& d) {
        origin += d.x * right + d.y * glm::vec3(0.0f, 1.0f, 0.0f) + d.z * forward;
    }
};

struct CameraMembers {
    const viewer::Member *origin, *forward, *right, *up;
};

glm::vec3 getVec3(const std::vector<std::uint8_t>& block, const viewer::Member& m) {
    float f[3];
    std::memcpy(f, block.data() + m.offset, sizeof f);
    return {f[0], f[1], f[2]};
}

void putVec3(std::vector<std::uint8_t>& block, const viewer::Member& m, const glm::vec3& v) {
    const float f[3] = {v.x, v.y, v.z}; // w (unused by the pass) stays as exported
    std::memcpy(block.data() + m.offset, f, sizeof f);
}

Camera readCamera(const std::vector<std::uint8_t>& block, const CameraMembers& cm) {
    Camera c;
    c.origin = getVec3(block, *cm.origin);
    c.forward = getVec3(block, *cm.forward);
    c.right = getVec3(block, *cm.right);
    c.up = getVec3(block, *cm.up);
    c.yaw = std::atan2(c.forward.x, c.forward.z);
    c.pitch = std::asin(std::clamp(c.forward.y, -1.0f, 1.0f));
    return c;
}

void writeCamera(std::vector<std::uint8_t>& block, const CameraMembers& cm, const Camera& c) {
    putVec3(block, *cm.origin, c.origin);
    putVec3(block, *cm.forward, c.forward);
    putVec3(block, *cm.right, c.right);
    putVec3(block, *cm.up, c.up);
}

// --- GL helpers --------------------------------------------------------------------------------

// Premultiplied RGBA over black, ACEScg (the working space unless $OCIO changed it) to linear
// Rec.709 (the usual AP1-to-sRGB matrix, Bradford D60 to D65), times the exposure, sRGB-encoded.
// A preview, not nimbus rt's OpenColorIO output transform.
const char* const kDisplayFragment = R"(#version 430
in vec2 uv;
uniform sampler2D image;
uniform float exposure;
out vec4 color;
const mat3 kAp1ToRec709 = mat3( 1.70505, -0.62179, -0.08326,   // rows, applied as v * M
                               -0.13026,  1.14080, -0.01055,
                               -0.02400, -0.12897,  1.15297);
void main() {
    vec3 c = clamp((texture(image, uv).rgb * kAp1ToRec709) * exposure, 0.0, 1.0);
    vec3 srgb = mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
    color = vec4(srgb, 1.0);
}
)";

bool writePpm(const std::string& path, int w, int h, const std::vector<std::uint8_t>& rgbBottomUp) {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    std::fprintf(f, "P6\n%d %d\n255\n", w, h);
    bool ok = true;
    for (int y = h - 1; y >= 0; --y) // PPM rows top to bottom
        ok = ok && std::fwrite(&rgbBottomUp[std::size_t(y) * std::size_t(w) * 3], 1,
                               std::size_t(w) * 3, f) == std::size_t(w) * 3;
    return std::fclose(f) == 0 && ok;
}

bool endsWith(const std::string& s, const char* suffix) {
    const std::size_t n = std::strlen(suffix);
    return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

bool parseFloats(const char* text, float* out, int n) {
    char* end = nullptr;
    for (int k = 0; k < n; ++k) {
        out[k] = std::strtof(text, &end);
        if (end == text || !std::isfinite(out[k])) return false;
        text = end;
        if (k + 1 < n && *text++ != ',') return false;
    }
    return *end == '\0';
}

// --- input -------------------------------------------------------------------------------------

// Taps (P, R, Esc) come from the key callback: at a few frames per second a press and its
// release can both fall between two polls, which glfwGetKey would miss. Held keys are polled.
struct Input {
    double scroll = 0.0;
    bool screenshot = false, reset = false, quit = false;
    bool dragging = false;
    double lastX = 0.0, lastY = 0.0;
    std::string glfwError;
};
Input gInput;

void onScroll(GLFWwindow*, double, double dy) {
    gInput.scroll += dy;
}

void onKey(GLFWwindow*, int key, int, int action, int) {
    if (action != GLFW_PRESS) return;
    if (key == GLFW_KEY_P) gInput.screenshot = true;
    if (key == GLFW_KEY_R) gInput.reset = true;
    if (key == GLFW_KEY_ESCAPE) gInput.quit = true;
}

} // namespace

int main(int argc, char** argv) {
    std::string dir;
    int frames = 0;
    std::vector<std::string> screenshots;
    int windowW = 0, windowH = 0;
    float move[3] = {0.0f, 0.0f, 0.0f}, turn[2] = {0.0f, 0.0f};
    int accumulate = 1;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const bool hasValue = i + 1 < argc;
        if (a == "-h" || a == "--help") {
            std::fputs(kUsage, stdout);
            return 0;
        } else if (a == "--frames" && hasValue) {
            if (!viewer::parseCount(argv[++i], 1, 100000000, &frames)) {
                std::fprintf(stderr, "nimbus_viewer: --frames wants a count in 1..100000000\n");
                return kExitUsage;
            }
        } else if (a == "--screenshot" && hasValue) {
            screenshots.push_back(argv[++i]);
            if (!endsWith(screenshots.back(), ".pfm") && !endsWith(screenshots.back(), ".ppm")) {
                std::fprintf(stderr, "nimbus_viewer: --screenshot wants a .pfm or .ppm file\n");
                return kExitUsage;
            }
        } else if (a == "--window" && hasValue) {
            if (std::sscanf(argv[++i], "%dx%d", &windowW, &windowH) != 2 || windowW < 1 ||
                windowH < 1) {
                std::fprintf(stderr, "nimbus_viewer: --window wants WxH, e.g. 1280x720\n");
                return kExitUsage;
            }
        } else if (a == "--accumulate" && hasValue) {
            if (!viewer::parseCount(argv[++i], 1, 4096, &accumulate)) {
                std::fprintf(stderr, "nimbus_viewer: --accumulate wants a count in 1..4096\n");
                return kExitUsage;
            }
        } else if (a == "--move" && hasValue) {
            if (!parseFloats(argv[++i], move, 3)) {
                std::fprintf(stderr, "nimbus_viewer: --move wants RIGHT,UP,FORWARD\n");
                return kExitUsage;
            }
        } else if (a == "--turn" && hasValue) {
            if (!parseFloats(argv[++i], turn, 2)) {
                std::fprintf(stderr, "nimbus_viewer: --turn wants YAW,PITCH in degrees\n");
                return kExitUsage;
            }
        } else if (a[0] != '-' && dir.empty()) {
            dir = a;
        } else {
            std::fprintf(stderr, "nimbus_viewer: unknown or incomplete argument %s\n%s", a.c_str(),
                         kUsage);
            return kExitUsage;
        }
    }
    if (dir.empty()) {
        std::fputs(kUsage, stderr);
        return kExitUsage;
    }

    // --- the export, before any window ---
    viewer::ExportFolder ex;
    std::string error;
    if (!viewer::loadExport(dir, ex, &error)) {
        std::fprintf(stderr, "nimbus_viewer: %s\n", error.c_str());
        return kExitUsage;
    }
    CameraMembers cm{viewer::findMember(ex, "camOrigin", "vec4", &error),
                     viewer::findMember(ex, "camForward", "vec4", &error),
                     viewer::findMember(ex, "camRight", "vec4", &error),
                     viewer::findMember(ex, "camUp", "vec4", &error)};
    const viewer::Member* sampleIndex =
        ex.passes > 1 ? viewer::findMember(ex, "sampleIndex", "int", &error) : nullptr;
    const viewer::Member* frameKey =
        accumulate > 1 ? viewer::findMember(ex, "frameKey", "uint", &error) : nullptr;
    if (!cm.origin || !cm.forward || !cm.right || !cm.up || (ex.passes > 1 && !sampleIndex) ||
        (accumulate > 1 && !frameKey)) {
        std::fprintf(stderr, "nimbus_viewer: %s/%s\n", dir.c_str(), error.c_str());
        return kExitUsage;
    }
    const Camera exported = readCamera(ex.params, cm);
    Camera camera = exported;
    bool cameraChanged = false;
    if (turn[0] != 0.0f || turn[1] != 0.0f) {
        camera.turnTo(camera.yaw + glm::radians(turn[0]), camera.pitch + glm::radians(turn[1]));
        cameraChanged = true;
    }
    if (move[0] != 0.0f || move[1] != 0.0f || move[2] != 0.0f) {
        camera.move(glm::vec3(move[0], move[1], move[2]));
        cameraChanged = true;
    }
    // speed: a twentieth of the field's box per second when the block has it, else 1 unit/s
    float speed = 1.0f;
    {
        std::string unused;
        const viewer::Member* lo = viewer::findMember(ex, "boundsLo", "vec4", &unused);
        const viewer::Member* hi = viewer::findMember(ex, "boundsHi", "vec4", &unused);
        if (lo && hi) {
            const float size = glm::length(getVec3(ex.params, *hi) - getVec3(ex.params, *lo));
            if (std::isfinite(size) && size > 0.0f) speed = size / 20.0f;
        }
    }

    // --- window and GL 4.3 core context ---
    glfwSetErrorCallback([](int code, const char* text) {
        gInput.glfwError = "GLFW error " + std::to_string(code) + ": " + text;
    });
    if (!glfwInit()) {
        std::fprintf(stderr, "nimbus_viewer: cannot start GLFW: %s\n", gInput.glfwError.c_str());
        return kExitGl;
    }
    if (windowW == 0) {
        const int scale = std::max(1, 960 / ex.width);
        windowW = ex.width * scale;
        windowH = ex.height * scale;
    }
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    GLFWwindow* window = glfwCreateWindow(windowW, windowH, "nimbus_viewer", nullptr, nullptr);
    if (!window) {
        std::fprintf(stderr, "nimbus_viewer: no window with an OpenGL 4.3 core context: %s\n",
                     gInput.glfwError.c_str());
        glfwTerminate();
        return kExitGl;
    }
    glfwMakeContextCurrent(window);
    glfwSwapInterval(0); // no vsync: the frame time is the renderer's
    glfwSetScrollCallback(window, onScroll);
    glfwSetKeyCallback(window, onKey);
    std::printf("GL: %s; %s\n", reinterpret_cast<const char*>(glGetString(GL_RENDERER)),
                reinterpret_cast<const char*>(glGetString(GL_VERSION)));

    std::string log;
    viewer::ExportPass pass;
    const GLuint display = viewer::linkProgram(
        {viewer::compileShader(GL_VERTEX_SHADER, viewer::kFullscreenVertex,
                               "the fullscreen vertex shader", &log),
         viewer::compileShader(GL_FRAGMENT_SHADER, kDisplayFragment, "the display shader", &log)},
        "the display program", &log);
    if (!display || !viewer::createExportPass(ex, pass, &log)) {
        std::fprintf(stderr, "nimbus_viewer: %s\n", log.c_str());
        glfwTerminate();
        return kExitGl;
    }
    GLuint timer = 0;
    glGenQueries(1, &timer);

    float exposure = 1.0f;
    bool timerPending = false;
    int accumulated = 0; // passes in the sums since the camera last moved
    double lastTime = glfwGetTime(), reportStart = lastTime, marchSeconds = 0.0;
    int reportFrames = 0, marchFrames = 0;
    std::vector<double> frameMs;
    bool saveNow = false;
    int exitCode = 0;
    for (int frame = 0; frames == 0 || frame < frames; ++frame) {
        glfwPollEvents();
        if (glfwWindowShouldClose(window)) break;
        const double now = glfwGetTime();
        const float dt = float(now - lastTime);

        // --- input (not in --frames runs: their camera is the export's, --move, --turn) ---
        if (frames == 0) {
            auto down = [&](int key) { return glfwGetKey(window, key) == GLFW_PRESS; };
            if (gInput.quit) break;
            if (gInput.scroll != 0.0) {
                speed *= std::pow(2.0f, float(gInput.scroll));
                gInput.scroll = 0.0;
            }
            if (down(GLFW_KEY_EQUAL) || down(GLFW_KEY_KP_ADD)) speed *= std::pow(2.0f, dt);
            if (down(GLFW_KEY_MINUS) || down(GLFW_KEY_KP_SUBTRACT)) speed /= std::pow(2.0f, dt);
            if (down(GLFW_KEY_RIGHT_BRACKET)) exposure *= std::pow(2.0f, dt);
            if (down(GLFW_KEY_LEFT_BRACKET)) exposure /= std::pow(2.0f, dt);
            if (gInput.reset) {
                camera = exported;
                cameraChanged = true;
            }
            saveNow = gInput.screenshot;
            gInput.reset = gInput.screenshot = false;
            glm::vec3 d(0.0f);
            if (down(GLFW_KEY_W)) d.z += 1.0f;
            if (down(GLFW_KEY_S)) d.z -= 1.0f;
            if (down(GLFW_KEY_D)) d.x += 1.0f;
            if (down(GLFW_KEY_A)) d.x -= 1.0f;
            if (down(GLFW_KEY_E)) d.y += 1.0f;
            if (down(GLFW_KEY_Q)) d.y -= 1.0f;
            if (d != glm::vec3(0.0f)) {
                float s = speed * dt;
                if (down(GLFW_KEY_LEFT_SHIFT) || down(GLFW_KEY_RIGHT_SHIFT)) s *= 5.0f;
                if (down(GLFW_KEY_LEFT_CONTROL) || down(GLFW_KEY_RIGHT_CONTROL)) s *= 0.2f;
                camera.move(d * s);
                cameraChanged = true;
            }
            double mx = 0.0, my = 0.0;
            glfwGetCursorPos(window, &mx, &my);
            const bool button = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
            if (button && gInput.dragging && (mx != gInput.lastX || my != gInput.lastY)) {
                const float radiansPerPixel = 0.004f;
                camera.turnTo(camera.yaw - float(mx - gInput.lastX) * radiansPerPixel,
                              camera.pitch - float(my - gInput.lastY) * radiansPerPixel);
                cameraChanged = true;
            }
            gInput.dragging = button;
            gInput.lastX = mx;
            gInput.lastY = my;
        }
        if (cameraChanged) {
            writeCamera(ex.params, cm, camera);
            viewer::uploadParams(ex, pass);
            cameraChanged = false;
            accumulated = 0; // the sums restart at the new view
        }

        // --- the march: one pass per frame (one dispatch per pixel sample); without
        // accumulation into zeroed sums every frame, with it into the sums of the frames since
        // the camera stopped, until `accumulate` passes are in ---
        if (timerPending) {
            GLuint64 ns = 0;
            glGetQueryObjectui64v(timer, GL_QUERY_RESULT, &ns);
            marchSeconds += double(ns) * 1e-9;
            ++marchFrames;
            timerPending = false;
        }
        if (accumulate == 1 || accumulated < accumulate) {
            glBeginQuery(GL_TIME_ELAPSED, timer);
            if (accumulate == 1 || accumulated == 0) viewer::zeroWorkBuffers(ex, pass);
            viewer::dispatchPass(ex, pass, accumulate == 1 ? 0 : accumulated);
            glEndQuery(GL_TIME_ELAPSED);
            timerPending = true;
            accumulated = std::min(accumulated + 1, accumulate);
        }

        // --- resolve into the float image, then show it letterboxed ---
        viewer::resolveFrame(ex, pass);
        int fbW = 0, fbH = 0;
        glfwGetFramebufferSize(window, &fbW, &fbH);
        glClearColor(0.1f, 0.1f, 0.1f, 1.0f);
        glClear(GL_COLOR_BUFFER_BIT);
        const double aspect = double(ex.width) / double(ex.height);
        int vw = fbW, vh = int(std::lround(fbW / aspect));
        if (vh > fbH) {
            vh = fbH;
            vw = int(std::lround(fbH * aspect));
        }
        glViewport((fbW - vw) / 2, (fbH - vh) / 2, vw, vh);
        glUseProgram(display);
        glUniform1f(glGetUniformLocation(display, "exposure"), exposure);
        glBindTexture(GL_TEXTURE_2D, pass.image);
        glDrawArrays(GL_TRIANGLES, 0, 3);

        // --- screenshots: --frames' last frame, or key P ---
        if (saveNow || (frames > 0 && frame == frames - 1 && !screenshots.empty())) {
            const std::vector<std::string> files =
                screenshots.empty() ? std::vector<std::string>{"nimbus_viewer.pfm"} : screenshots;
            for (const std::string& file : files) {
                bool ok = false;
                if (endsWith(file, ".pfm")) {
                    ok = viewer::writePfm(file, ex.width, ex.height, viewer::readImage(ex, pass));
                } else {
                    std::vector<std::uint8_t> rgb(std::size_t(fbW) * std::size_t(fbH) * 3);
                    glReadBuffer(GL_BACK);
                    glPixelStorei(GL_PACK_ALIGNMENT, 1);
                    glReadPixels(0, 0, fbW, fbH, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
                    ok = writePpm(file, fbW, fbH, rgb);
                }
                std::printf("%s %s\n", ok ? "wrote" : "could not write", file.c_str());
                if (!ok) exitCode = kExitUsage;
            }
        }
        glfwSwapBuffers(window);
        if (const GLenum e = glGetError(); e != GL_NO_ERROR) {
            std::fprintf(stderr, "nimbus_viewer: GL error 0x%04X in frame %d\n", e, frame + 1);
            exitCode = kExitGl;
            break;
        }

        // --- frame time: the title and stdout once a second ---
        const double end = glfwGetTime();
        frameMs.push_back((end - lastTime) * 1e3);
        lastTime = end;
        ++reportFrames;
        if (end - reportStart >= 1.0 || (frames > 0 && frame == frames - 1)) {
            const double ms = (end - reportStart) * 1e3 / reportFrames;
            char march[96] = "march: no timer result yet";
            if (marchFrames > 0) // (the timer is read one frame late)
                std::snprintf(march, sizeof march, "march %.1f ms on the GPU",
                              marchSeconds * 1e3 / marchFrames);
            else if (accumulate > 1 && accumulated == accumulate)
                std::snprintf(march, sizeof march, "march at rest");
            if (accumulate > 1) {
                const std::size_t used = std::strlen(march);
                std::snprintf(march + used, sizeof march - used, ", %d/%d passes accumulated",
                              accumulated, accumulate);
            }
            char text[256];
            std::snprintf(text, sizeof text,
                          "%.1f ms per frame (%.2f fps), %s, %dx%d, %d pass(es), speed %.3g/s", ms,
                          1e3 / ms, march, ex.width, ex.height, ex.passes, speed);
            std::printf("%s\n", text);
            std::fflush(stdout);
            glfwSetWindowTitle(window, (std::string("nimbus_viewer: ") + text).c_str());
            reportStart = end;
            reportFrames = 0;
            marchSeconds = 0.0;
            marchFrames = 0;
        }
    }
    if (frames > 0) {
        std::printf("frame times (ms):");
        for (double ms : frameMs) std::printf(" %.1f", ms);
        std::printf("\n");
    }
    glfwDestroyWindow(window);
    glfwTerminate();
    return exitCode;
}
