/// @file image_oiio.cpp
/// @brief libnimbus_image.so: the image files' reads and writes through OpenImageIO, behind the
///        table of plugin/io/image_module.h (loaded on first use by plugin/io/image_output.cpp).
#include "plugin/io/image_module.h"
#include "plugin/io/image_output.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace nimbus::io::detail {
namespace {

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

void writeImage(const ImageWrite& w) {
    const OIIO::TypeDesc format = w.uint8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT;
    OIIO::ImageSpec spec(w.width, w.height, int(w.channels.size()), format);
    spec.channelnames = w.channels;
    spec.alpha_channel = w.alphaChannel;
    for (const ImageAttribute& a : w.attributes) switch (a.kind) {
        case ImageAttribute::Kind::String:
            spec.attribute(a.name, a.text);
            break;
        case ImageAttribute::Kind::Int:
            spec.attribute(a.name, a.integer);
            break;
        case ImageAttribute::Kind::Double:
            spec.attribute(a.name, OIIO::TypeDesc::DOUBLE, &a.real);
            break;
        case ImageAttribute::Kind::Float8:
            spec.attribute(a.name, OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), a.floats8.data());
            break;
        }
    // the format from the final name (the temp name does not end in the extension)
    const std::string ext = std::filesystem::path(w.finalPath).extension().string();
    auto out = OIIO::ImageOutput::create(ext.empty() ? w.finalPath : ext.substr(1));
    if (!out) throw std::runtime_error("cannot write '" + w.finalPath + "': " + OIIO::geterror());
    if (!out->open(w.tempPath, spec))
        throw std::runtime_error("cannot write '" + w.finalPath + "': " + out->geterror());
    if (!out->write_image(format, w.pixels)) {
        const std::string err = out->geterror();
        out->close();
        throw std::runtime_error("cannot write '" + w.finalPath +
                                 "': " + withDiskState(err, w.finalPath));
    }
    if (!out->close())
        throw std::runtime_error("cannot write '" + w.finalPath +
                                 "': " + withDiskState(out->geterror(), w.finalPath));
}

void readImage(const std::string& path, ExrImage& img) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) throw std::runtime_error("cannot read '" + path + "': " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    img = ExrImage{};
    img.width = spec.width;
    img.height = spec.height;
    img.fileFormat = in->format_name();
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
}

const ImageModule kModule{kImageModuleVersion, &writeImage, &readImage};

} // namespace
} // namespace nimbus::io::detail

extern "C" __attribute__((visibility("default"))) const nimbus::io::detail::ImageModule*
nimbus_image_module() {
    return &nimbus::io::detail::kModule;
}
