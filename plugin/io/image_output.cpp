/// @file image_output.cpp
/// @brief OpenEXR / PNG output through OpenImageIO, colour managed through ColorSystem.
#include "plugin/io/image_output.h"

#include "plugin/io/atomic_file.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace nimbus::io {

namespace {

void checkFramebuffer(const nimbus::Framebuffer& fb, const std::string& path) {
    const auto fail = [&](const std::string& why) {
        throw std::runtime_error("cannot write '" + path + "': invalid framebuffer (" + why + ")");
    };
    if (fb.width <= 0 || fb.height <= 0)
        fail("size " + std::to_string(fb.width) + "x" + std::to_string(fb.height));
    const size_t n = size_t(fb.width) * size_t(fb.height);
    if (fb.rgba.size() != n * 4) fail("rgba has " + std::to_string(fb.rgba.size()) + " floats");
    if (fb.aovs.transmittance && fb.transmittance.size() != n * 3)
        fail("transmittance has " + std::to_string(fb.transmittance.size()) + " floats");
    if (fb.aovs.depth && fb.depth.size() != n)
        fail("depth has " + std::to_string(fb.depth.size()) + " floats");
}

/// Replaces NaN/Inf by 0; returns how many were replaced.
size_t sanitize(float* v, size_t n) {
    size_t bad = 0;
    for (size_t i = 0; i < n; ++i)
        if (!std::isfinite(v[i])) {
            v[i] = 0.0f;
            ++bad;
        }
    return bad;
}

/// OIIO's message with the file system's state when that explains it: OpenEXR reports a full
/// disk as "Failed to write pixel data" without the reason.
std::string withDiskState(const std::string& err, const std::string& path) {
    std::error_code ec;
    const auto dir = std::filesystem::path(path).has_parent_path()
                         ? std::filesystem::path(path).parent_path()
                         : std::filesystem::path(".");
    const std::filesystem::space_info sp = std::filesystem::space(dir, ec);
    if (!ec && sp.available < (std::uintmax_t(1) << 20))
        return err + " (" + std::strerror(ENOSPC) + ": " + std::to_string(sp.available) +
               " bytes free in " + dir.string() + ")";
    return err;
}

void writeWithOiio(const std::string& tempPath, const std::string& finalPath,
                   const OIIO::ImageSpec& spec, OIIO::TypeDesc format, const void* pixels) {
    // the format from the final name (the temp name does not end in the extension)
    const std::string ext = std::filesystem::path(finalPath).extension().string();
    auto out = OIIO::ImageOutput::create(ext.empty() ? finalPath : ext.substr(1));
    if (!out) throw std::runtime_error("cannot write '" + finalPath + "': " + OIIO::geterror());
    if (!out->open(tempPath, spec))
        throw std::runtime_error("cannot write '" + finalPath + "': " + out->geterror());
    if (!out->write_image(format, pixels)) {
        const std::string err = out->geterror();
        out->close();
        throw std::runtime_error("cannot write '" + finalPath +
                                 "': " + withDiskState(err, finalPath));
    }
    if (!out->close())
        throw std::runtime_error("cannot write '" + finalPath +
                                 "': " + withDiskState(out->geterror(), finalPath));
}

} // namespace

std::size_t writeExr(const std::string& path, const nimbus::Framebuffer& fb, const ColorSystem& cs,
                     const std::string& workingSpace, const std::string& outputSpace,
                     const ExrMetadata& md) {
    checkFramebuffer(fb, path);
    const std::string working = cs.canonicalName(workingSpace);
    const std::string output = cs.canonicalName(outputSpace);
    if (!md.colorSpace.empty() && cs.canonicalName(md.colorSpace) != output)
        throw std::runtime_error("cannot write '" + path + "': metadata colour space '" +
                                 md.colorSpace + "' is not the output colour space '" + output +
                                 "'");

    const size_t n = size_t(fb.width) * size_t(fb.height);
    std::vector<float> rgba(fb.rgba);
    size_t bad = sanitize(rgba.data(), rgba.size());
    if (working != output) {
        cs.convertPixels(rgba.data(), fb.width, fb.height, 4, working, output, true);
        bad += sanitize(rgba.data(), rgba.size());
    }

    // The order OpenImageIO reports when reading back (OpenEXR itself stores channels sorted by
    // name): the default layer R G B A first, then `depth`, then the `transmittance` layer.
    std::vector<std::string> names{"R", "G", "B", "A"};
    if (fb.aovs.depth) names.emplace_back("depth");
    if (fb.aovs.transmittance)
        for (const char* c : {"transmittance.R", "transmittance.G", "transmittance.B"})
            names.emplace_back(c);
    const size_t nch = names.size();

    std::vector<float> pixels(n * nch);
    for (size_t i = 0; i < n; ++i) {
        float* px = &pixels[i * nch];
        for (int c = 0; c < 4; ++c) px[c] = rgba[i * 4 + c];
        size_t k = 4;
        if (fb.aovs.depth) px[k++] = fb.depth[i];
        if (fb.aovs.transmittance)
            for (int c = 0; c < 3; ++c) px[k++] = fb.transmittance[i * 3 + c];
    }
    // AOVs were copied unsanitised: sanitise them now (RGBA are already finite).
    for (size_t i = 0; i < n; ++i) bad += sanitize(&pixels[i * nch + 4], nch - 4);

    OIIO::ImageSpec spec(fb.width, fb.height, int(nch), OIIO::TypeDesc::FLOAT);
    spec.channelnames = names;
    spec.alpha_channel = 3;
    spec.attribute("compression", "zip");
    spec.attribute("Software", "Nimbus " + md.version);
    if (auto chroma = cs.chromaticities(output))
        spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), chroma->data());
    spec.attribute("nimbus/colorSpace", output);
    spec.attribute("nimbus/ocioConfig", cs.description());
    spec.attribute("nimbus/version", md.version);
    spec.attribute("nimbus/seed", std::to_string(md.seed));
    spec.attribute("nimbus/renderTime", OIIO::TypeDesc::DOUBLE, &md.renderSeconds);
    spec.attribute("nimbus/frame", md.frame);
    if (!md.sceneHash.empty()) spec.attribute("nimbus/sceneHash", md.sceneHash);
    if (bad > 0) spec.attribute("nimbus/nonFiniteReplaced", int(std::min<size_t>(bad, 0x7fffffff)));
    for (const auto& [key, value] : md.settings) spec.attribute("nimbus/settings/" + key, value);

    writeAtomically(path, [&](const std::string& temp) {
        writeWithOiio(temp, path, spec, OIIO::TypeDesc::FLOAT, pixels.data());
    });
    return bad;
}

std::vector<float> previewLinearRgb(const std::string& path, const nimbus::Framebuffer& fb,
                                    std::size_t* bad) {
    checkFramebuffer(fb, path);
    const size_t n = size_t(fb.width) * size_t(fb.height);
    // Premultiplied RGBA over black = its premultiplied RGB.
    std::vector<float> rgb(n * 3);
    for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) rgb[i * 3 + c] = fb.rgba[i * 4 + c];
    const size_t replaced = sanitize(rgb.data(), rgb.size());
    if (bad) *bad = replaced;
    return rgb;
}

void writeEncodedPreviewPng(const std::string& path, int width, int height,
                            const std::vector<float>& displayRgb, const std::string& display,
                            const std::string& view) {
    if (width <= 0 || height <= 0 || displayRgb.size() != size_t(width) * size_t(height) * 3)
        throw std::runtime_error("preview '" + path + "': " + std::to_string(displayRgb.size()) +
                                 " values for " + std::to_string(width) + "x" +
                                 std::to_string(height) + " RGB pixels");
    std::vector<unsigned char> bytes(displayRgb.size());
    for (size_t i = 0; i < bytes.size(); ++i) {
        float v = displayRgb[i];
        v = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
        bytes[i] = static_cast<unsigned char>(std::lround(v * 255.0f));
    }

    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("Software", std::string("Nimbus preview: ") + display + " / " + view);
    writeAtomically(path, [&](const std::string& temp) {
        writeWithOiio(temp, path, spec, OIIO::TypeDesc::UINT8, bytes.data());
    });
}

std::size_t writePreviewPng(const std::string& path, const nimbus::Framebuffer& fb,
                            const ColorSystem& cs, const std::string& workingSpace,
                            const std::string& display, const std::string& view) {
    size_t bad = 0;
    std::vector<float> rgb = previewLinearRgb(path, fb, &bad);
    cs.applyDisplayView(rgb.data(), fb.width, fb.height, 3, workingSpace, display, view);
    writeEncodedPreviewPng(path, fb.width, fb.height, rgb, display, view);
    return bad;
}

int ExrImage::channelIndex(const std::string& name) const {
    auto it = std::find(channels.begin(), channels.end(), name);
    return it == channels.end() ? -1 : int(it - channels.begin());
}

ExrImage readExr(const std::string& path) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) throw std::runtime_error("cannot read '" + path + "': " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    ExrImage img;
    img.width = spec.width;
    img.height = spec.height;
    img.channels = spec.channelnames;
    for (int c = 0; c < spec.nchannels; ++c)
        img.channelFormats.push_back(spec.channelformat(c).c_str());
    for (const auto& p : spec.extra_attribs) {
        img.attributes[p.name().string()] = p.get_string(1024);
        if (p.name() == "chromaticities" && p.type() == OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8)) {
            Chromaticities ch;
            const float* v = static_cast<const float*>(p.data());
            std::copy(v, v + 8, ch.begin());
            img.chromaticities = ch;
        }
    }
    img.pixels.resize(size_t(spec.width) * spec.height * spec.nchannels);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, img.pixels.data())) {
        const std::string err = in->geterror();
        throw std::runtime_error("cannot read '" + path + "': " + err);
    }
    in->close();
    return img;
}

} // namespace nimbus::io
