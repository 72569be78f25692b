/// @file source.h
/// @brief The GLSL text of the single-source kernels, embedded in nimbus_core at build time.
///
/// core/kernels/kernels.h is the one list of kernel files: its `#include
/// "core/kernels/<name>.glsl"` lines, in order, are the dependency order. CMake reads them and
/// core/kernels/embed_kernels.cmake writes the prelude and every listed file into a generated
/// .cpp (regenerated whenever a kernel, the prelude or kernels.h changes), so the shader text a
/// GPU pass compiles is the text the C++ build compiled.
///
/// glslLibrary() is the prelude followed by the kernels; it has no `#version` line, so a pass
/// puts its own version and extension lines first and its entry point after:
/// @code
///   std::string shader = "#version 430\n" + kern::glslLibrary() + myMain;
/// @endcode
/// Before kernel i the library has `#line 1 <i + 1>`, so compiler messages name the kernel by
/// its source-string number (kernelSources()[number - 1]) and its own line number.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>

namespace nimbus::kern {

/// One embedded kernel file.
struct KernelSource {
    std::string_view name; ///< file stem, e.g. "phase"
    std::string_view path; ///< repository path, e.g. "core/kernels/phase.glsl"
    std::string_view text; ///< the file's bytes
};

/// core/kernels/prelude.glsl (the GLSL side of the IN/OUT/INOUT and NB_FN macros).
std::string_view glslPrelude();

/// Every kernel file in dependency order (the include order of core/kernels/kernels.h).
std::span<const KernelSource> kernelSources();

/// The embedded kernel called @p name ("hash", ...), or nullptr.
const KernelSource* findKernelSource(std::string_view name);

/// The shader library: the prelude, then the first @p kernelCount kernels (all by default),
/// each after a `#line 1 <index + 1>`. No `#version` line.
std::string glslLibrary(std::size_t kernelCount = static_cast<std::size_t>(-1));

} // namespace nimbus::kern
