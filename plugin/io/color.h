/// @file color.h
/// @brief Colour management (OpenColorIO): colour-space conversions, display/view transforms for
///        previews and CIE xy chromaticities for EXR headers.
///
/// Nimbus renders in a scene-linear working space (default `ACEScg`). Like every VFX tool it
/// honours `$OCIO`; without it, it uses its own small built-in config made only of OCIO 2.1
/// BuiltinTransforms (Debian ships no OCIO config and OCIO 2.1 has no `ocio://default`).
///
/// Built-in config (see ColorSystem::builtinConfigText()), colour spaces (aliases in brackets):
///  - `ACEScg` [lin_ap1]: AP1 primaries, linear; roles default, scene_linear, rendering.
///  - `ACES2065-1` [lin_ap0]: AP0 primaries, linear; roles reference, aces_interchange.
///  - `lin_rec709` [lin_srgb]: Rec.709/sRGB primaries, D65 white, linear.
///  - `sRGB` [srgb_texture]: Rec.709 primaries with the piecewise sRGB encoding (display-encoded,
///    no tone mapping; like "sRGB - Texture" of the ACES configs).
///  - `CIE-XYZ-D65`: CIE XYZ, D65 white; role cie_xyz_d65_interchange.
///  - `raw`: data, never converted; role data.
///  - `sRGB - Display`: the display-referred colour space of the `sRGB` display.
/// Display `sRGB` with the views `ACES 1.0 SDR-video` (ACES 1.0 output transform, tone mapped)
/// and `Un-tone-mapped` (plain sRGB encoding, clips above 1).
///
/// Every name argument accepts a colour-space name, one of its aliases or a role name
/// (e.g. `scene_linear`). Unknown names throw std::runtime_error naming the unknown space and
/// listing the valid ones. A ColorSystem is cheap to copy (shared, immutable state) and all its
/// methods are thread-safe.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

namespace nimbus::io {

/// CIE xy chromaticities in the order of the OpenEXR `chromaticities` attribute:
/// red x, red y, green x, green y, blue x, blue y, white x, white y.
using Chromaticities = std::array<float, 8>;

/// A display/view transform as a GPU shader (OpenColorIO's GpuShaderDesc, GLSL 4.0), with the
/// LUT textures and uniform values it reads; plain data, no OCIO types (the GL side is
/// plugin/realtime/ocio_gpu.h). The text declares its samplers and uniforms and defines
/// `vec4 <function>(vec4 inPixel)` (RGB in, alpha passed through).
struct GpuDisplayShader {
    std::string text;     ///< GLSL 4.0 (no #version line)
    std::string function; ///< the function's name, e.g. "OCIODisplay"
    std::string cacheId;  ///< OCIO's cache ID of the shader
    /// A LUT texture: 1D (height 1, depth 0), 2D (a long 1D LUT folded into rows; depth 0) or 3D
    /// (width = height = depth = the edge length). Values are float, `channels` per texel, x
    /// fastest (3D: then y, then z).
    struct Texture {
        std::string sampler; ///< the sampler uniform's name in `text`
        int width = 0, height = 0, depth = 0;
        int channels = 3;   ///< 1 (red only) or 3 (RGB)
        bool linear = true; ///< linear filtering (else nearest)
        std::vector<float> values;
    };
    std::vector<Texture> textures;
    /// A uniform the text declares (dynamic properties, e.g. an exposure), its value when the
    /// shader was made.
    struct Uniform {
        enum class Kind { Float, Bool, Float3, FloatArray, IntArray };
        std::string name;
        Kind kind = Kind::Float;
        std::vector<float> values; ///< Float, Bool (0/1), Float3, FloatArray
        std::vector<int> ints;     ///< IntArray
    };
    std::vector<Uniform> uniforms;
};

/// An OpenColorIO configuration plus the few operations Nimbus needs from it.
class ColorSystem {
  public:
    /// `$OCIO` when set and non-empty (like every VFX tool), else the built-in Nimbus config.
    /// @throws std::runtime_error if `$OCIO` names a file OCIO cannot load (message names it).
    static ColorSystem load();
    /// The built-in Nimbus config (independent of the working directory and of `$OCIO`).
    static ColorSystem builtin();
    /// An OCIO config file. @throws std::runtime_error naming the path.
    static ColorSystem fromFile(const std::string& path);
    /// The YAML text of the built-in config (e.g. to write it out: `nimbus` users can start their
    /// own config from it).
    static const char* builtinConfigText();

    /// "$OCIO=<path>", "OCIO config <path>" (fromFile) or
    /// "built-in Nimbus config (OCIO 2.1 BuiltinTransforms)".
    const std::string& description() const;
    /// True for the built-in config.
    bool isBuiltin() const;

    /// True if @p name is a colour space, an alias of one or a role.
    bool hasColorSpace(const std::string& name) const;
    /// Names of all colour spaces (scene- and display-referred, canonical names only).
    std::vector<std::string> colorSpaceNames() const;
    /// Canonical colour-space name for a name, alias or role. @throws std::runtime_error if
    /// unknown.
    std::string canonicalName(const std::string& name) const;
    /// The colour space of the `scene_linear` role (the default working space), or "" if the
    /// config defines no such role.
    std::string sceneLinearSpace() const;

    /// Converts one RGB triple. @throws std::runtime_error on unknown names.
    glm::vec3 convert(glm::vec3 rgb, const std::string& from, const std::string& to) const;
    /// Converts an interleaved image in place. @p channels is 3 (RGB) or 4 (RGBA); alpha is
    /// never modified. With @p premultiplied (RGBA only) and a conversion that is not linear
    /// (e.g. to `sRGB`), colours are unpremultiplied before and premultiplied after the
    /// conversion (pixels with alpha <= 0 are converted as they are); linear conversions (matrices)
    /// commute with premultiplication and are applied directly.
    /// @throws std::runtime_error on unknown names or bad arguments.
    void convertPixels(float* data, int width, int height, int channels, const std::string& from,
                       const std::string& to, bool premultiplied = false) const;
    /// True if the conversion from @p from to @p to is linear (a 3x3 matrix or the identity),
    /// determined numerically.
    bool isLinearConversion(const std::string& from, const std::string& to) const;

    /// Display names of the config.
    std::vector<std::string> displays() const;
    /// View names of @p display. @throws std::runtime_error if the display is unknown.
    std::vector<std::string> views(const std::string& display) const;
    /// The config's default display.
    std::string defaultDisplay() const;
    /// The default view of @p display.
    std::string defaultView(const std::string& display) const;
    /// Applies the OCIO display/view transform from colour space @p from in place (RGB of RGB or
    /// RGBA, alpha untouched; the data are treated as straight, i.e. not premultiplied, colour —
    /// composite premultiplied images over a background first). The result is display-encoded.
    /// @throws std::runtime_error naming an unknown colour space, display or view (with the valid
    /// ones).
    void applyDisplayView(float* data, int width, int height, int channels, const std::string& from,
                          const std::string& display, const std::string& view) const;
    /// The same display/view transform as a GLSL 4.0 shader for the GPU (OCIO's
    /// getDefaultGPUProcessor and GpuShaderDesc; function `OCIODisplay`), for previews rendered
    /// on the GPU (`nimbus rt --gpu-display`). @throws std::runtime_error as applyDisplayView.
    GpuDisplayShader displayViewGpuShader(const std::string& from, const std::string& display,
                                          const std::string& view) const;

    /// CIE xy chromaticities (R, G, B, white) of a colour space when Nimbus can identify it:
    /// every space of the built-in config except `raw` (ACEScg = AP1, ACES2065-1 = AP0,
    /// lin_rec709/sRGB = Rec.709 D65, CIE-XYZ-D65 = XYZ). For a user ($OCIO) config a space is
    /// identified numerically when the config has the `aces_interchange` role (its conversion to
    /// ACES2065-1 must match one of the built-in spaces within 1e-4), otherwise by well-known names
    /// (ACEScg, "ACES - ACEScg", ACES2065-1, lin_rec709, lin_srgb, "Linear Rec.709 (sRGB)",
    /// sRGB, "sRGB - Texture", ...). Data spaces and spaces it cannot identify give std::nullopt.
    /// @throws std::runtime_error if @p name is not a colour space of the config.
    std::optional<Chromaticities> chromaticities(const std::string& name) const;

  private:
    struct Impl;
    explicit ColorSystem(std::shared_ptr<const Impl> impl);
    static ColorSystem fromFileWithDescription(const std::string& path, const std::string& what);
    std::shared_ptr<const Impl> impl_;
};

/// Well-known chromaticities.
namespace chroma {
/// ACES AP1 (ACEScg), ACES white (~D60).
inline constexpr Chromaticities AP1{0.713f, 0.293f, 0.165f,   0.830f,
                                    0.128f, 0.044f, 0.32168f, 0.33767f};
/// ACES AP0 (ACES2065-1), ACES white (~D60).
inline constexpr Chromaticities AP0{0.7347f, 0.2653f, 0.0f,     1.0f,
                                    0.0001f, -0.077f, 0.32168f, 0.33767f};
/// ITU-R BT.709 / sRGB primaries, D65 white.
inline constexpr Chromaticities Rec709{0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f};
/// CIE XYZ with the white of X=Y=Z (how OpenEXR expresses XYZ data).
inline constexpr Chromaticities XYZ{1.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 1.0f / 3.0f, 1.0f / 3.0f};
} // namespace chroma

} // namespace nimbus::io
