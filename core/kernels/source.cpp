/// @file source.cpp
/// @brief Assembles the embedded kernel text (the text itself is generated, see source.h).
#include "core/kernels/source.h"

#include <algorithm>

namespace nimbus::kern {

const KernelSource* findKernelSource(std::string_view name) {
    for (const KernelSource& k : kernelSources())
        if (k.name == name) return &k;
    return nullptr;
}

std::string glslLibrary(std::size_t kernelCount) {
    const std::span<const KernelSource> kernels = kernelSources();
    const std::size_t n = std::min(kernelCount, kernels.size());
    std::string text(glslPrelude());
    if (!text.empty() && text.back() != '\n') text += '\n';
    for (std::size_t i = 0; i < n; ++i) {
        text += "#line 1 ";
        text += std::to_string(i + 1);
        text += '\n';
        text += kernels[i].text;
        if (!kernels[i].text.empty() && kernels[i].text.back() != '\n') text += '\n';
    }
    return text;
}

} // namespace nimbus::kern
