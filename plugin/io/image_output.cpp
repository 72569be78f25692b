/// @file image_output.cpp
/// @brief OpenEXR / PNG output, colour managed through ColorSystem; the files themselves are
///        read and written by OpenImageIO in libnimbus_image.so (plugin/io/image_module.h).
#include "plugin/io/image_output.h"

#include "plugin/io/atomic_file.h"
#include "plugin/io/image_module.h"
#include "plugin/io/object_folder.h"

#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <type_traits>

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

using detail::ImageAttribute;

/// A header attribute: an int, a double, or text.
template <class T> ImageAttribute attribute(const std::string& name, const T& value) {
    ImageAttribute a;
    a.name = name;
    if constexpr (std::is_same_v<T, int>) {
        a.kind = ImageAttribute::Kind::Int;
        a.integer = value;
    } else if constexpr (std::is_same_v<T, double>) {
        a.kind = ImageAttribute::Kind::Double;
        a.real = value;
    } else {
        a.text = value;
    }
    return a;
}

const detail::ImageModule* loadImageModule() {
    std::string tried;
    void* lib = nullptr;
    // beside the executable or shared object this code was linked into
    const std::string folder = objectFolder(reinterpret_cast<const void*>(&loadImageModule));
    if (!folder.empty()) {
        const std::string path = folder + "/" + detail::kImageModuleLibrary;
        lib = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!lib) tried = path + ": " + dlerror() + "; ";
    }
    if (!lib) {
        lib = dlopen(detail::kImageModuleLibrary, RTLD_NOW | RTLD_LOCAL);
        if (!lib)
            throw std::runtime_error(std::string("cannot load OpenImageIO's module (") + tried +
                                     "the library path: " + dlerror() + ")");
    }
    using Entry = const detail::ImageModule* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(lib, detail::kImageModuleSymbol));
    const detail::ImageModule* m = entry ? entry() : nullptr;
    if (!m || m->version != detail::kImageModuleVersion)
        throw std::runtime_error(std::string(detail::kImageModuleLibrary) +
                                 " is not this build's (no " + detail::kImageModuleSymbol +
                                 " of version " + std::to_string(detail::kImageModuleVersion) +
                                 "): rebuild Nimbus");
    return m;
}

} // namespace

namespace detail {
const ImageModule& imageModule() {
    // loaded once, thread-safely; a load that throws leaves it unset, and the next call tries again
    static const ImageModule* const module = loadImageModule();
    return *module;
}
} // namespace detail

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

    detail::ImageWrite w;
    w.finalPath = path;
    w.width = fb.width;
    w.height = fb.height;
    w.channels = names;
    w.alphaChannel = 3;
    w.pixels = pixels.data();
    auto& at = w.attributes;
    at.push_back(attribute("compression", "zip"));
    at.push_back(attribute("Software", "Nimbus " + md.version));
    if (auto chroma = cs.chromaticities(output)) {
        ImageAttribute a;
        a.kind = ImageAttribute::Kind::Float8;
        a.name = "chromaticities";
        std::copy(chroma->begin(), chroma->end(), a.floats8.begin());
        at.push_back(a);
    }
    at.push_back(attribute("nimbus/colorSpace", output));
    at.push_back(attribute("nimbus/ocioConfig", cs.description()));
    at.push_back(attribute("nimbus/version", md.version));
    at.push_back(attribute("nimbus/seed", std::to_string(md.seed)));
    at.push_back(attribute("nimbus/renderTime", md.renderSeconds));
    at.push_back(attribute("nimbus/frame", md.frame));
    if (!md.sceneHash.empty()) at.push_back(attribute("nimbus/sceneHash", md.sceneHash));
    if (bad > 0)
        at.push_back(attribute("nimbus/nonFiniteReplaced", int(std::min<size_t>(bad, 0x7fffffff))));
    for (const auto& [key, value] : md.settings)
        at.push_back(attribute("nimbus/settings/" + key, value));

    const detail::ImageModule& module = detail::imageModule();
    writeAtomically(path, [&](const std::string& temp) {
        w.tempPath = temp;
        module.write(w);
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

    detail::ImageWrite w;
    w.finalPath = path;
    w.width = width;
    w.height = height;
    w.channels = {"R", "G", "B"};
    w.uint8 = true;
    w.pixels = bytes.data();
    w.attributes.push_back(
        attribute("Software", std::string("Nimbus preview: ") + display + " / " + view));
    const detail::ImageModule& module = detail::imageModule();
    writeAtomically(path, [&](const std::string& temp) {
        w.tempPath = temp;
        module.write(w);
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
    ExrImage img;
    detail::imageModule().read(path, img);
    return img;
}

} // namespace nimbus::io
