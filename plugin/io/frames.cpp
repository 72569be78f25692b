/// @file frames.cpp
/// @brief Frame-spec parsing and frame-pattern expansion (see frames.h).
#include "plugin/io/frames.h"

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace nimbus::io {

namespace {

constexpr std::string_view kSpecExpected =
    "expected N, A-B or A-BxS (step S >= 1), or a comma-separated list of these, "
    "such as \"7\", \"1-24\", \"1-100x2\" or \"1,5,7-9\"";

[[noreturn]] void specError(const std::string& spec, const std::string& problem) {
    throw std::invalid_argument("invalid frame spec \"" + spec + "\": " + problem + "; " +
                                std::string(kSpecExpected));
}

bool isSpace(char c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}
bool isDigit(char c) {
    return c >= '0' && c <= '9';
}

/// Cursor over one spec; every error names the 1-based character position.
struct SpecReader {
    const std::string& spec;
    size_t pos = 0;

    bool atEnd() const { return pos >= spec.size(); }
    char peek() const { return atEnd() ? '\0' : spec[pos]; }
    void skipSpace() {
        while (!atEnd() && isSpace(spec[pos])) ++pos;
    }
    std::string where() const {
        if (atEnd()) return "at the end";
        return "at position " + std::to_string(pos + 1) + " ('" + std::string(1, spec[pos]) + "')";
    }

    /// [-]digits, the value must fit an int.
    int number(bool allowSign, const char* what) {
        skipSpace();
        size_t start = pos;
        if (allowSign && peek() == '-') ++pos;
        size_t digits = pos;
        while (!atEnd() && isDigit(spec[pos])) ++pos;
        if (pos == digits) {
            pos = start;
            if (!allowSign && peek() == '-')
                specError(spec, std::string("the ") + what + " may not be negative");
            specError(spec, std::string("expected the ") + what + " (a whole number) " + where());
        }
        std::int64_t v = 0;
        auto [end, ec] = std::from_chars(spec.data() + start, spec.data() + pos, v);
        constexpr std::int64_t lo = std::numeric_limits<int>::min();
        constexpr std::int64_t hi = std::numeric_limits<int>::max();
        if (ec != std::errc() || end != spec.data() + pos || v < lo || v > hi)
            specError(spec, "number " + spec.substr(start, pos - start) +
                                " is outside the range of frame numbers [" + std::to_string(lo) +
                                ", " + std::to_string(hi) + "]");
        return int(v);
    }
};

void appendPadded(std::string& out, int frame, int width) {
    std::int64_t v = frame;
    bool negative = v < 0;
    std::string digits = std::to_string(negative ? -v : v);
    int len = int(digits.size()) + (negative ? 1 : 0);
    if (negative) out += '-';
    if (len < width) out.append(size_t(width - len), '0');
    out += digits;
}

/// A frame token at @p i: returns its length (0 = none) and its width (0 = no padding).
size_t frameTokenAt(const std::string& p, size_t i, int& width) {
    width = 0;
    if (p[i] == '#') {
        size_t j = i;
        while (j < p.size() && p[j] == '#') ++j;
        width = int(j - i);
        return j - i;
    }
    if (p[i] != '$' || i + 1 >= p.size()) return 0;
    bool braced = p[i + 1] == '{';
    size_t j = i + (braced ? 2 : 1);
    if (j >= p.size() || p[j] != 'F') return 0;
    ++j;
    size_t digits = j;
    while (j < p.size() && isDigit(p[j])) ++j;
    if (braced) {
        if (j >= p.size() || p[j] != '}') return 0;
    } else if (j == digits && j < p.size()) {
        char c = p[j];
        if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_') return 0; // $FPS etc.
    }
    if (j - digits > 2 || (j > digits && std::stoi(p.substr(digits, j - digits)) > 32))
        throw std::invalid_argument("frame pattern \"" + p + "\": the width of $F" +
                                    p.substr(digits, j - digits) +
                                    " is too large; expected $F or $F<N> with N <= 32");
    if (j > digits) width = std::stoi(p.substr(digits, j - digits));
    return j + (braced ? 1 : 0) - i;
}

} // namespace

std::string_view frameSpecSyntax() {
    return "A frame spec is a comma-separated list of `N` (one frame), `A-B` (A to B inclusive) "
           "and `A-BxS` (every S-th frame from A up to B, S >= 1); whitespace is allowed, the "
           "result is sorted and duplicates are dropped: `1-100x2,150`. Negative frames carry a "
           "leading minus (`-5--1`, `-3-3`). At most 1000000 frames.";
}

std::string_view framePatternSyntax() {
    return "In output paths a run of N `#` is replaced by the frame number zero-padded to N "
           "characters (`####` gives `0007`), `$F<N>` or `${F<N>}` likewise (Houdini style) and "
           "`$F` by the unpadded number. A minus sign counts towards the width (`-007`); wider "
           "numbers are written in full. A path without a frame token is only allowed when a "
           "single frame is rendered.";
}

std::vector<int> parseFrameSpec(const std::string& spec) {
    SpecReader in{spec};
    in.skipSpace();
    if (in.atEnd()) specError(spec, "the spec is empty");

    struct Range {
        int a, b, step;
    };
    std::vector<Range> ranges;
    int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
    std::int64_t listed = 0; // frames listed, repeats included
    int element = 1;
    for (;;) {
        in.skipSpace();
        if (in.peek() == ',' || in.atEnd())
            specError(spec, "element " + std::to_string(element) + " is empty (stray comma?)");
        int a = in.number(true, "first frame");
        int b = a;
        int step = 1;
        in.skipSpace();
        if (in.peek() == '-') {
            ++in.pos;
            b = in.number(true, "last frame of the range");
            in.skipSpace();
            if (in.peek() == 'x' || in.peek() == 'X') {
                ++in.pos;
                step = in.number(false, "step");
                if (step < 1)
                    specError(spec, "the step of " + std::to_string(a) + "-" + std::to_string(b) +
                                        "x" + std::to_string(step) + " must be at least 1");
            }
            if (a > b)
                specError(spec, "the range " + std::to_string(a) + "-" + std::to_string(b) +
                                    " runs backwards (its first frame must not exceed its last)");
        } else if (in.peek() == 'x' || in.peek() == 'X') {
            specError(spec, "a step needs a range (A-BxS), found one after the single frame " +
                                std::to_string(a));
        }
        in.skipSpace();
        if (!in.atEnd() && in.peek() != ',') specError(spec, "unexpected character " + in.where());

        const std::int64_t count = (std::int64_t(b) - a) / step + 1;
        if (count > kMaxFrames)
            specError(spec, "it names more than " + std::to_string(kMaxFrames) + " frames");
        // bounds the work of the union below (and the memory of its sorted path)
        listed += count;
        if (listed > kMaxListedFrames)
            specError(spec, "it lists more than " + std::to_string(kMaxListedFrames) +
                                " frames counting repeats (ranges that overlap count each time)");
        ranges.push_back({a, b, step});
        lo = std::min(lo, a);
        hi = std::max(hi, b);

        if (in.atEnd()) break;
        ++in.pos; // ','
        ++element;
    }

    // The union, in order, without duplicates. Where the frames are dense (a span of at most
    // 2^26 frames and at most 16 times the frames listed) a bitmap over the span marks them,
    // with no sorting; sparse specs (a few frames far apart) sort the listed frames once.
    // Either way the work is bounded by a small multiple of the frames listed.
    std::vector<int> frames;
    const std::int64_t span = std::int64_t(hi) - lo + 1;
    if (span <= (std::int64_t(1) << 26) && span <= 16 * listed + 65536) {
        std::vector<bool> on(static_cast<size_t>(span), false);
        for (const Range& r : ranges)
            for (std::int64_t f = r.a; f <= r.b; f += r.step) on[size_t(f - lo)] = true;
        const auto n = std::count(on.begin(), on.end(), true);
        if (n > kMaxFrames)
            specError(spec, "it names more than " + std::to_string(kMaxFrames) + " frames");
        frames.reserve(size_t(n));
        for (std::int64_t i = 0; i < span; ++i)
            if (on[size_t(i)]) frames.push_back(int(lo + i));
    } else {
        frames.reserve(size_t(listed));
        for (const Range& r : ranges)
            for (std::int64_t f = r.a; f <= r.b; f += r.step) frames.push_back(int(f));
        std::sort(frames.begin(), frames.end());
        frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
        if (frames.size() > size_t(kMaxFrames))
            specError(spec, "it names more than " + std::to_string(kMaxFrames) + " frames");
    }
    return frames;
}

bool patternHasFrameToken(const std::string& pattern) {
    int width = 0;
    for (size_t i = 0; i < pattern.size(); ++i)
        if (frameTokenAt(pattern, i, width) > 0) return true;
    return false;
}

std::string expandFramePattern(const std::string& pattern, int frame) {
    std::string out;
    out.reserve(pattern.size() + 8);
    for (size_t i = 0; i < pattern.size();) {
        int width = 0;
        size_t len = frameTokenAt(pattern, i, width);
        if (len == 0) {
            out += pattern[i++];
            continue;
        }
        appendPadded(out, frame, width);
        i += len;
    }
    return out;
}

} // namespace nimbus::io
