/// @file image_module.h
/// @brief The boundary between nimbus_io and OpenImageIO: the few calls that read and write
///        image files live in a shared object of their own, libnimbus_image.so
///        (plugin/io/image_oiio.cpp), loaded on the first image read or write.
///
/// OpenImageIO brings about 260 shared libraries on Debian 12 (OpenCV, GDAL, FFmpeg, DCMTK, ...)
/// whose relocations cost a process about 0.27 s at start: a host that renders to memory (the
/// C ABI, Python, Blender), a command that stops on bad input, and each test process would pay
/// it for nothing. Both sides are built together by this project with the same compiler and
/// standard library, so the table passes C++ types and the module's errors come back as
/// std::runtime_error.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace nimbus::io {
struct ExrImage;
}

namespace nimbus::io::detail {

/// One header attribute of a file to write.
struct ImageAttribute {
    enum class Kind { String, Int, Double, Float8 } kind = Kind::String;
    std::string name;
    std::string text;                  ///< Kind::String
    int integer = 0;                   ///< Kind::Int
    double real = 0.0;                 ///< Kind::Double
    std::array<float, 8> floats8 = {}; ///< Kind::Float8 (EXR chromaticities)
};

/// An image to write: @p pixels interleaved, rows top to bottom, float or 8-bit.
struct ImageWrite {
    std::string tempPath;  ///< where to write (writeAtomically's temp file)
    std::string finalPath; ///< the name the file will have: its extension picks the format
    int width = 0, height = 0;
    std::vector<std::string> channels; ///< names (empty: OpenImageIO's defaults)
    int alphaChannel = -1;
    bool uint8 = false; ///< 8-bit values, else 32-bit float
    const void* pixels = nullptr;
    std::vector<ImageAttribute> attributes;
};

/// The module's table. Bump kImageModuleVersion when a signature or a struct above changes.
struct ImageModule {
    int version;
    /// Writes the image; throws std::runtime_error naming finalPath on failure.
    void (*write)(const ImageWrite& w);
    /// Reads the first subimage as float; throws std::runtime_error naming the path.
    void (*read)(const std::string& path, ExrImage& out);
};
inline constexpr int kImageModuleVersion = 1;
inline constexpr const char* kImageModuleLibrary = "libnimbus_image.so";
inline constexpr const char* kImageModuleSymbol = "nimbus_image_module";

/// The loaded module: on the first call, libnimbus_image.so beside the object this code is
/// linked into (the executable or the shared library), else wherever the dynamic loader finds it
/// (RUNPATH, LD_LIBRARY_PATH). @throws std::runtime_error saying where it looked and why it failed.
const ImageModule& imageModule();

} // namespace nimbus::io::detail
