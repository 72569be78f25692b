/// @file fuzz_frames.cpp
/// @brief libFuzzer harness: the frame-spec parser and the frame-pattern expander
/// (plugin/io/frames.h). Input: a spec; its first byte also picks a frame for the pattern.
/// Accepted outcomes are a sorted, duplicate-free, non-empty frame list within kMaxFrames, or
/// std::invalid_argument (the pattern: only for a `$F<N>` or `${F<N>}` width above 32); anything else (a crash, a
/// sanitizer report, another exception) is a bug.
#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "plugin/io/frames.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string spec(reinterpret_cast<const char*>(data), size);
    try {
        const std::vector<int> frames = nimbus::io::parseFrameSpec(spec);
        if (frames.empty() || frames.size() > std::size_t(nimbus::io::kMaxFrames) ||
            !std::is_sorted(frames.begin(), frames.end()) ||
            std::adjacent_find(frames.begin(), frames.end()) != frames.end())
            __builtin_trap();
    } catch (const std::invalid_argument&) {
    }
    // The spec as a file pattern: any text is a legal pattern (tokens or not).
    const int frame = size ? int(static_cast<std::int8_t>(data[0])) * 1000003 : 0;
    try {
        const std::string out = nimbus::io::expandFramePattern(spec, frame);
        if (!nimbus::io::patternHasFrameToken(spec) && out != spec) __builtin_trap();
    } catch (const std::invalid_argument&) {
        // Documented only for a `$F<N>` or `${F<N>}` width above 32.
        if (spec.find("$F") == std::string::npos && spec.find("${F") == std::string::npos)
            __builtin_trap();
    }
    return 0;
}
