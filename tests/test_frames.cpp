/// @file test_frames.cpp
/// @brief Frame specs and frame-numbered file patterns (plugin/io/frames.h).
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "plugin/io/frames.h"
#include "tests/test_util.h"

using nimbus::io::expandFramePattern;
using nimbus::io::parseFrameSpec;
using nimbus::io::patternHasFrameToken;

namespace {

std::vector<int> range(int a, int b, int step = 1) {
    std::vector<int> out;
    for (int f = a; f <= b; f += step) out.push_back(f);
    return out;
}

/// The message of the std::invalid_argument that parseFrameSpec(spec) throws, or "" (a failure).
std::string specError(const std::string& spec) {
    try {
        std::vector<int> frames = parseFrameSpec(spec);
        ADD_FAILURE() << "parseFrameSpec(\"" << spec << "\") did not throw; it gave "
                      << frames.size() << " frames";
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(FrameSpec, SingleFrame) {
    EXPECT_EQ(parseFrameSpec("7"), std::vector<int>{7});
    EXPECT_EQ(parseFrameSpec("0"), std::vector<int>{0});
}

TEST(FrameSpec, Range) {
    EXPECT_EQ(parseFrameSpec("1-24"), range(1, 24));
    EXPECT_EQ(parseFrameSpec("5-5"), std::vector<int>{5});
}

TEST(FrameSpec, RangeWithStep) {
    std::vector<int> f = parseFrameSpec("1-100x2");
    EXPECT_EQ(f, range(1, 99, 2));
    EXPECT_EQ(f.size(), 50u);
    EXPECT_EQ(parseFrameSpec("1-10x3"), (std::vector<int>{1, 4, 7, 10}));
    EXPECT_EQ(parseFrameSpec("1-9x3"), (std::vector<int>{1, 4, 7}));
    EXPECT_EQ(parseFrameSpec("1-10X5"), (std::vector<int>{1, 6}));
    EXPECT_EQ(parseFrameSpec("3-4x100"), std::vector<int>{3});
}

TEST(FrameSpec, List) {
    EXPECT_EQ(parseFrameSpec("1,5,7-9"), (std::vector<int>{1, 5, 7, 8, 9}));
}

TEST(FrameSpec, WhitespaceTolerated) {
    EXPECT_EQ(parseFrameSpec("  1 , 5 - 9 x 2 ,\t20 "), (std::vector<int>{1, 5, 7, 9, 20}));
}

TEST(FrameSpec, SortedWithoutDuplicates) {
    EXPECT_EQ(parseFrameSpec("9, 1-3, 2, 3, 9"), (std::vector<int>{1, 2, 3, 9}));
    EXPECT_EQ(parseFrameSpec("1-1000000,1-1000000").size(), 1000000u);
}

TEST(FrameSpec, NegativeFrames) {
    EXPECT_EQ(parseFrameSpec("-7"), std::vector<int>{-7});
    EXPECT_EQ(parseFrameSpec("-5--1"), range(-5, -1));
    EXPECT_EQ(parseFrameSpec("-3-2"), range(-3, 2));
    EXPECT_EQ(parseFrameSpec(" -10 - -4 x 3"), (std::vector<int>{-10, -7, -4}));
    EXPECT_EQ(parseFrameSpec("-2,-1"), (std::vector<int>{-2, -1}));
}

TEST(FrameSpec, ExtremeFrameNumbers) {
    EXPECT_EQ(parseFrameSpec("2147483646-2147483647"), (std::vector<int>{2147483646, 2147483647}));
    EXPECT_EQ(parseFrameSpec("-2147483648"), std::vector<int>{-2147483648});
    EXPECT_EQ(parseFrameSpec("1-1000000").size(), 1000000u);
}

TEST(FrameSpec, ErrorsQuoteTheSpecAndSayWhatIsExpected) {
    for (const char* spec :
         {"",      "   ", "5-1",         "1-10x0",     "abc",         "1,,2",      "1,",
          ",1",    "1-",  "1-3x",        "7x2",        "1-10x-2",     "--5",       "1 2",
          "1-5;6", "1.5", "99999999999", "2147483648", "-2147483649", "0-1000000", "1e3"}) {
        std::string msg = specError(spec);
        EXPECT_TRUE(contains(msg, "\"" + std::string(spec) + "\"")) << "spec " << spec;
        EXPECT_TRUE(contains(msg, "expected")) << "spec " << spec;
    }
}

TEST(FrameSpec, ErrorsNameTheProblem) {
    EXPECT_TRUE(contains(specError(""), "empty"));
    EXPECT_TRUE(contains(specError("5-1"), "runs backwards"));
    EXPECT_TRUE(contains(specError("1-10x0"), "at least 1"));
    EXPECT_TRUE(contains(specError("1-10x-2"), "may not be negative"));
    EXPECT_TRUE(contains(specError("abc"), "position 1"));
    EXPECT_TRUE(contains(specError("1,,2"), "element 2 is empty"));
    EXPECT_TRUE(contains(specError("7x2"), "needs a range"));
    EXPECT_TRUE(contains(specError("99999999999"), "outside the range"));
    EXPECT_TRUE(contains(specError("0-1000000"), "more than 1000000 frames"));
    EXPECT_TRUE(contains(specError("1-600000,700000-1300000"), "more than 1000000 frames"));
    // Repeats are allowed (eight full ranges) but bounded: a ninth is refused, whatever it adds.
    std::string eight = "1-1000000";
    for (int i = 1; i < 8; ++i) eight += ",1-1000000";
    EXPECT_EQ(parseFrameSpec(eight).size(), 1000000u);
    EXPECT_TRUE(contains(specError(eight + ",5"), "more than 8000000 frames counting repeats"));
    // 41 copies of a range of 0.8 M frames: each element sorted ~2 M frames before the bound;
    // now refused at the eleventh.
    std::string many = "100-800000";
    for (int i = 0; i < 40; ++i) many += ",100-800000";
    EXPECT_TRUE(contains(specError(many), "counting repeats"));
}

TEST(FramePattern, HashRunIsZeroPadded) {
    EXPECT_EQ(expandFramePattern("out/frame.####.exr", 7), "out/frame.0007.exr");
    EXPECT_EQ(expandFramePattern("f.#.exr", 7), "f.7.exr");
    EXPECT_EQ(expandFramePattern("f.###.exr", 0), "f.000.exr");
}

TEST(FramePattern, WiderFrameIsWrittenInFull) {
    EXPECT_EQ(expandFramePattern("f.##.exr", 12345), "f.12345.exr");
    EXPECT_EQ(expandFramePattern("f.#.exr", 2147483647), "f.2147483647.exr");
}

TEST(FramePattern, NegativeFramesKeepTheSign) {
    EXPECT_EQ(expandFramePattern("f.####.exr", -7), "f.-007.exr");
    EXPECT_EQ(expandFramePattern("f.#.exr", -7), "f.-7.exr");
    EXPECT_EQ(expandFramePattern("f.$F.exr", -12), "f.-12.exr");
    EXPECT_EQ(expandFramePattern("f.#.exr", -2147483647 - 1), "f.-2147483648.exr");
}

TEST(FramePattern, HoudiniTokens) {
    EXPECT_EQ(expandFramePattern("f.$F4.exr", 7), "f.0007.exr");
    EXPECT_EQ(expandFramePattern("f.$F.exr", 7), "f.7.exr");
    EXPECT_EQ(expandFramePattern("f_$F", 42), "f_42");
    EXPECT_EQ(expandFramePattern("f.${F3}x.exr", 5), "f.005x.exr");
    EXPECT_EQ(expandFramePattern("f.$F2.exr", 123), "f.123.exr");
    EXPECT_THROW(expandFramePattern("f.$F100.exr", 1), std::invalid_argument);
}

TEST(FramePattern, SeveralTokens) {
    EXPECT_EQ(expandFramePattern("shot.##/beauty.####.$F.exr", 3), "shot.03/beauty.0003.3.exr");
}

TEST(FramePattern, NoTokenIsUnchanged) {
    EXPECT_EQ(expandFramePattern("still.exr", 7), "still.exr");
    EXPECT_EQ(expandFramePattern("$FPS.exr", 7), "$FPS.exr"); // another variable
    EXPECT_EQ(expandFramePattern("$HOME/a.exr", 7), "$HOME/a.exr");
}

TEST(FramePattern, HasFrameToken) {
    EXPECT_TRUE(patternHasFrameToken("a.####.exr"));
    EXPECT_TRUE(patternHasFrameToken("a.#.exr"));
    EXPECT_TRUE(patternHasFrameToken("a.$F4.exr"));
    EXPECT_TRUE(patternHasFrameToken("a.$F.exr"));
    EXPECT_TRUE(patternHasFrameToken("a_$F"));
    EXPECT_TRUE(patternHasFrameToken("a.${F}.exr"));
    EXPECT_FALSE(patternHasFrameToken("still.exr"));
    EXPECT_FALSE(patternHasFrameToken("$FPS.exr"));
    EXPECT_FALSE(patternHasFrameToken("a.$.exr"));
    EXPECT_FALSE(patternHasFrameToken(""));
}
