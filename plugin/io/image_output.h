/// @file image_output.h
/// @brief Writing frames: colour-managed 32-bit float OpenEXR with chromaticities and Nimbus
///        metadata, display-referred 8-bit PNG previews, and reading EXRs back.
///
/// Both writers go through writeAtomically() (temp file, fsync, rename), so a frame file either
/// exists complete or not at all. Non-finite values (NaN/Inf) never reach a file: they are
/// replaced by 0 and counted (a last line of defence; the renderer should never produce them).
///
/// EXR layout (one part, scanline, ZIP compression, all channels 32-bit float), channels in the
/// order OpenImageIO reports them when reading back (the file itself stores them sorted by name):
///   `R G B A` — premultiplied colour in the output colour space, alpha,
///   `depth` — if the Framebuffer has that AOV,
///   `transmittance.R transmittance.G transmittance.B` — if the Framebuffer has that AOV.
/// AOVs are data and are never colour converted. Header attributes:
///   `chromaticities` (standard EXR, when the output space is identifiable, see
///   ColorSystem::chromaticities()), `nimbus/colorSpace` (canonical OCIO name of the output
///   space), `nimbus/ocioConfig` (ColorSystem::description()), `nimbus/version`, `nimbus/seed`
///   (decimal string: a uint32 does not fit an EXR int), `nimbus/renderTime` (double, seconds),
///   `nimbus/frame` (int), `nimbus/sceneHash` (string, when given: docs/farm_cli.md),
///   `nimbus/nonFiniteReplaced` (int, only when > 0),
///   `nimbus/settings/<key>` (string, one per settings entry), `Software` ("Nimbus <version>").
/// All are listed by `oiiotool --info -v frame.exr`.
///
/// OpenImageIO itself is in libnimbus_image.so, loaded on the first read or write
/// (plugin/io/image_module.h): a process that writes no file does not load its ~260 libraries.
#pragma once

#include <cstddef> // before core/image.h, which uses size_t without including it
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "plugin/io/color.h"

namespace nimbus::io {

/// Metadata written into the EXR header (see the file comment for the attribute names).
struct ExrMetadata {
    /// Optional consistency check: if non-empty it must name (or alias) the same colour space as
    /// writeExr()'s outputSpace, else writeExr() throws. `nimbus/colorSpace` always records the
    /// canonical name of outputSpace.
    std::string colorSpace;
    /// Render settings, one `nimbus/settings/<key>` string attribute each.
    std::map<std::string, std::string> settings;
    uint32_t seed = 0;        ///< random seed of the frame
    double renderSeconds = 0; ///< wall-clock render time of the frame
    int frame = 0;            ///< frame number
    /// `nimbus/sceneHash` when non-empty: what --resume compares (host::Session::sceneHash()).
    std::string sceneHash;
#ifdef NIMBUS_VERSION
    std::string version = NIMBUS_VERSION; ///< Nimbus version
#else
    std::string version = "unknown"; ///< Nimbus version
#endif
};

/// Writes @p fb as a 32-bit float OpenEXR (atomically). The Framebuffer's RGBA is premultiplied
/// scene-linear colour in @p workingSpace; RGB is converted to @p outputSpace through OCIO when the
/// two differ (unpremultiplied around the conversion if it is not linear). AOVs are written
/// unconverted.
/// @return the number of non-finite float values (input or after conversion) replaced by 0.
/// @throws std::runtime_error on unknown colour spaces, an inconsistent Framebuffer (buffer sizes
///         not matching width/height/AOVs), or any I/O error (the message names the path).
std::size_t writeExr(const std::string& path, const nimbus::Framebuffer& fb, const ColorSystem& cs,
                     const std::string& workingSpace, const std::string& outputSpace,
                     const ExrMetadata& md);

/// Writes an 8-bit RGB PNG preview (atomically): the premultiplied RGBA is composited over black
/// (i.e. its premultiplied RGB is used; alpha is not written), then the OCIO display/view
/// transform (e.g. display `sRGB`, view `ACES 1.0 SDR-video`) gives display-encoded values,
/// clamped to [0,1] and rounded to 8 bits. No dithering (deterministic output).
/// @return the number of non-finite input values replaced by 0.
/// @throws std::runtime_error on unknown colour space/display/view or I/O errors.
std::size_t writePreviewPng(const std::string& path, const nimbus::Framebuffer& fb,
                            const ColorSystem& cs, const std::string& workingSpace,
                            const std::string& display, const std::string& view);

/// The linear RGB a preview starts from (writePreviewPng's first step): the premultiplied RGBA
/// composited over black (its premultiplied RGB), 3 floats per pixel, non-finite values replaced
/// by 0 (counted in *bad when not null). @throws std::runtime_error on an inconsistent
/// Framebuffer (the message names @p path).
std::vector<float> previewLinearRgb(const std::string& path, const nimbus::Framebuffer& fb,
                                    std::size_t* bad = nullptr);

/// writePreviewPng's last step: display-encoded RGB (3 floats per pixel, e.g. the GPU's display
/// transform of previewLinearRgb) clamped to [0,1], rounded to 8 bits and written as the PNG
/// (atomically). @throws std::runtime_error on I/O errors or a wrong size.
void writeEncodedPreviewPng(const std::string& path, int width, int height,
                            const std::vector<float>& displayRgb, const std::string& display,
                            const std::string& view);

/// An image read back from a file: all channels as float, interleaved, rows top to bottom.
struct ExrImage {
    int width = 0;
    int height = 0;
    std::string fileFormat;            ///< OpenImageIO's name of the format: "openexr", "png", ...
    std::vector<std::string> channels; ///< channel names, in the order OIIO reports them
    std::vector<std::string>
        channelFormats;        ///< per channel pixel type in the file ("float", "half", ...)
    std::vector<float> pixels; ///< width * height * channels.size() floats
    std::map<std::string, std::string> attributes; ///< every header attribute, as text
    std::optional<Chromaticities> chromaticities;  ///< the `chromaticities` attribute, if any

    /// Index of channel @p name, or -1.
    int channelIndex(const std::string& name) const;
    /// Value of channel @p c at pixel (x, y).
    float at(int x, int y, int c) const {
        return pixels[(size_t(y) * width + x) * channels.size() + size_t(c)];
    }
};

/// Reads an EXR (or any image OpenImageIO can read: first subimage, top MIP level) as float.
/// Used by tests and by `nimbus converge`.
/// @throws std::runtime_error naming the path if it cannot be opened or read.
ExrImage readExr(const std::string& path);

} // namespace nimbus::io
