/// @file frames.h
/// @brief Frame specs (`1-100x2,150`) and frame-numbered file patterns (`out.####.exr`, `$F4`).
///
/// A frame is the unit of distribution (see DESIGN.md, "Distribution"): a farm runs
/// `nimbus render scene.toml --frames 101-110`, so the spec grammar follows the one render
/// managers use (Deadline, OpenCue, Houdini's hbatch):
///
/// @code
///   parseFrameSpec("1-10x3, 20")   // {1, 4, 7, 10, 20}
///   parseFrameSpec("-5--3")        // {-5, -4, -3}
///   expandFramePattern("out/beauty.####.exr", 7)   // "out/beauty.0007.exr"
///   expandFramePattern("out/beauty.$F4.exr", -7)   // "out/beauty.-007.exr"
/// @endcode
///
/// The help texts below are the single description of both grammars: error messages, the
/// scene-file reference and the CLI's --help all print them.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace nimbus::io {

/// Most frames one spec may name (a guard against typos such as `1-10000000`).
inline constexpr int kMaxFrames = 1000000;
/// Most frames one spec may list counting repeats (`1-1000000,1-1000000` lists 2000000 and names
/// 1000000): bounds the parser's work on specs that repeat large ranges many times.
inline constexpr std::int64_t kMaxListedFrames = 8 * std::int64_t(kMaxFrames);

/// One-paragraph description of the frame-spec grammar (Markdown-friendly plain text).
std::string_view frameSpecSyntax();

/// One-paragraph description of the frame tokens in file patterns.
std::string_view framePatternSyntax();

/// Parses a frame spec: a comma-separated list of `N`, `A-B` or `A-BxS` (S >= 1), whitespace
/// allowed around every number and separator. Negative frames are written with a leading minus
/// (`-5`, `-5--1`, `-3-2`): after a number, `-` is the range separator, before a number it is a
/// sign, so the grammar stays unambiguous.
/// @return the frames, sorted ascending, without duplicates (never empty).
/// @throws std::invalid_argument quoting the spec and naming what was expected (empty spec or
///         element, descending range, step < 1, junk, a number outside int, more than kMaxFrames,
///         more than kMaxListedFrames counting repeats).
std::vector<int> parseFrameSpec(const std::string& spec);

/// True when @p pattern contains a frame token: a run of `#`, or `$F` / `$F<digits>` (a `$F`
/// followed by a letter or `_`, such as `$FPS`, is another variable and not a frame token).
bool patternHasFrameToken(const std::string& pattern);

/// Replaces every frame token of @p pattern by @p frame:
///  - a run of N `#` -> the frame zero-padded to width N (`####`, 7 -> `0007`);
///  - `$F<N>` (Houdini) -> the same with width N; `$F` -> the frame without padding.
/// The width counts a minus sign, as printf's `%04d` and Houdini's padzero do (`####`, -7 ->
/// `-007`); a frame wider than the token is written in full (`##`, 1234 -> `1234`).
/// A pattern without tokens is returned unchanged: whether that is an error depends on how many
/// frames are rendered, which the caller knows (see patternHasFrameToken).
/// @throws std::invalid_argument when a `$F<N>` or `${F<N>}` width is larger than 32.
std::string expandFramePattern(const std::string& pattern, int frame);

} // namespace nimbus::io
