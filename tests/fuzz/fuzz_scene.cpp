/// @file fuzz_scene.cpp
/// @brief libFuzzer harness: the strict TOML scene parser with `--set` overrides
/// (plugin/io/scene_file.h). Input: scene text, then optionally a NUL byte followed by
/// newline-separated overrides (`section.key=value`). Accepted outcomes are a SceneFile or a
/// SceneError whose message names the source (`fuzz.toml:` or `--set `); anything else (a crash,
/// a sanitizer report, another exception type) is a bug.
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "plugin/io/scene_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const char* text = reinterpret_cast<const char*>(data);
    const void* nul = std::memchr(text, 0, size);
    const std::size_t textSize = nul ? std::size_t(static_cast<const char*>(nul) - text) : size;
    std::vector<std::string> overrides;
    if (nul) {
        std::string rest(text + textSize + 1, size - textSize - 1);
        std::size_t start = 0;
        while (start <= rest.size() && overrides.size() < 8) {
            const std::size_t end = std::min(rest.find('\n', start), rest.size());
            if (end > start) overrides.push_back(rest.substr(start, end - start));
            start = end + 1;
        }
    }
    try {
        const nimbus::io::SceneFile f =
            nimbus::io::parseSceneText(std::string(text, textSize), "fuzz.toml", overrides);
        (void)f;
    } catch (const nimbus::io::SceneError& e) {
        const char* w = e.what();
        if (std::strncmp(w, "fuzz.toml", 9) != 0 && std::strncmp(w, "--set ", 6) != 0)
            __builtin_trap(); // an error that does not say where
    }
    return 0;
}
