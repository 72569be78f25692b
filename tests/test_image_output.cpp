/// @file test_image_output.cpp
/// @brief Tests of EXR/PNG output (plugin/io/image_output.h) and atomic writes
///        (plugin/io/atomic_file.h).
#include "plugin/io/atomic_file.h"
#include "plugin/io/image_output.h"
#include "tests/test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <unistd.h>
#include <vector>

using namespace nimbus::io;
namespace fs = std::filesystem;

namespace {

class IoTempDir : public ::testing::Test {
  protected:
    /// Every entry of the test directory (recursive, including hidden temp files).
    std::vector<std::string> listing() const {
        std::vector<std::string> out;
        for (const auto& e : fs::recursive_directory_iterator(dir_))
            out.push_back(fs::relative(e.path(), dir_).string());
        std::sort(out.begin(), out.end());
        return out;
    }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    TempDir dir_{"io"};
};

std::string readBytes(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A framebuffer with distinct values everywhere: including values beyond half-float range and
/// below its precision, negatives and denormal-ish magnitudes, so only 32-bit float round-trips.
nimbus::Framebuffer makeFramebuffer(int w, int h, nimbus::AovSet aovs) {
    nimbus::Framebuffer fb;
    fb.resize(w, h, aovs);
    for (size_t i = 0; i < fb.rgba.size(); ++i) {
        const float base = 0.001f + 0.0137f * float(i);
        fb.rgba[i] = (i % 4 == 3) ? std::min(1.0f, 0.1f + 0.01f * float(i)) : base;
    }
    fb.rgba[0] = 70000.123f; // > half max
    fb.rgba[1] = 1.0e-30f;   // < half min
    fb.rgba[2] = -2.5f;      // negative (out of gamut)
    fb.rgba[4] = 0.1234567f; // needs 24 mantissa bits
    for (size_t i = 0; i < fb.transmittance.size(); ++i) fb.transmittance[i] = 1.0f / (1.0f + i);
    for (size_t i = 0; i < fb.depth.size(); ++i) fb.depth[i] = 1234.5678f + 3.0f * float(i);
    return fb;
}

ExrMetadata makeMetadata() {
    ExrMetadata md;
    md.settings = {{"step", "0.25"}, {"integrator", "march"}};
    md.seed = 4000000000u;
    md.renderSeconds = 12.5;
    md.frame = 107;
    md.version = "9.8.7";
    return md;
}

std::string attr(const ExrImage& img, const std::string& name) {
    auto it = img.attributes.find(name);
    return it == img.attributes.end() ? std::string("<missing>") : it->second;
}

} // namespace

// ---------------------------------------------------------------------------------------------
// EXR

using ExrOutput = IoTempDir;

TEST_F(ExrOutput, RoundTripKeepsChannelsFloatValuesChromaticitiesAndMetadata) {
    const ColorSystem cs = ColorSystem::builtin();
    const auto fb = makeFramebuffer(5, 4, {true, true});
    const std::string file = path("frames/beauty.0107.exr");
    EXPECT_EQ(writeExr(file, fb, cs, "ACEScg", "ACEScg", makeMetadata()), 0u);

    const ExrImage img = readExr(file);
    ASSERT_EQ(img.width, 5);
    ASSERT_EQ(img.height, 4);
    EXPECT_EQ(img.channels,
              (std::vector<std::string>{"R", "G", "B", "A", "depth", "transmittance.R",
                                        "transmittance.G", "transmittance.B"}));
    for (const auto& f : img.channelFormats) EXPECT_EQ(f, "float");
    ASSERT_EQ(img.pixels.size(), size_t(5 * 4 * 8));
    const int d = img.channelIndex("depth"), t = img.channelIndex("transmittance.R");
    ASSERT_GE(d, 0);
    ASSERT_GE(t, 0);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 5; ++x) {
            const size_t i = size_t(y) * 5 + x;
            for (int c = 0; c < 4; ++c)
                EXPECT_EQ(img.at(x, y, c), fb.rgba[i * 4 + c]) << x << "," << y << " c" << c;
            for (int c = 0; c < 3; ++c) EXPECT_EQ(img.at(x, y, t + c), fb.transmittance[i * 3 + c]);
            EXPECT_EQ(img.at(x, y, d), fb.depth[i]);
        }

    ASSERT_TRUE(img.chromaticities.has_value());
    for (int i = 0; i < 8; ++i) EXPECT_FLOAT_EQ((*img.chromaticities)[i], chroma::AP1[i]);
    EXPECT_EQ(attr(img, "nimbus/colorSpace"), "ACEScg");
    EXPECT_EQ(attr(img, "nimbus/ocioConfig"), cs.description());
    EXPECT_EQ(attr(img, "nimbus/version"), "9.8.7");
    EXPECT_EQ(attr(img, "nimbus/seed"), "4000000000");
    EXPECT_EQ(attr(img, "nimbus/frame"), "107");
    EXPECT_EQ(std::stod(attr(img, "nimbus/renderTime")), 12.5);
    EXPECT_EQ(attr(img, "nimbus/settings/step"), "0.25");
    EXPECT_EQ(attr(img, "nimbus/settings/integrator"), "march");
    EXPECT_EQ(attr(img, "compression"), "zip");
    EXPECT_EQ(img.attributes.count("nimbus/nonFiniteReplaced"), 0u);
    // Only the final file remains (no temp files).
    EXPECT_EQ(listing(), (std::vector<std::string>{"frames", "frames/beauty.0107.exr"}));
}

TEST_F(ExrOutput, WithoutAovsOnlyRgbaIsWritten) {
    const ColorSystem cs = ColorSystem::builtin();
    const auto fb = makeFramebuffer(3, 2, {});
    writeExr(path("a.exr"), fb, cs, "ACEScg", "ACEScg", {});
    const ExrImage img = readExr(path("a.exr"));
    EXPECT_EQ(img.channels, (std::vector<std::string>{"R", "G", "B", "A"}));
    EXPECT_EQ(img.pixels, fb.rgba);
}

TEST_F(ExrOutput, OutputSpaceConversionAppliesToRgbOnly) {
    const ColorSystem cs = ColorSystem::builtin();
    auto fb = makeFramebuffer(4, 3, {true, true});
    fb.rgba[0] = 1.0f; // keep the first pixel small enough for a tight tolerance
    ExrMetadata md = makeMetadata();
    md.colorSpace = "lin_srgb"; // an alias of the output space: accepted
    writeExr(path("rec709.exr"), fb, cs, "ACEScg", "lin_rec709", md);
    const ExrImage img = readExr(path("rec709.exr"));
    EXPECT_EQ(attr(img, "nimbus/colorSpace"), "lin_rec709");
    ASSERT_TRUE(img.chromaticities.has_value());
    for (int i = 0; i < 8; ++i) EXPECT_FLOAT_EQ((*img.chromaticities)[i], chroma::Rec709[i]);
    const int t = img.channelIndex("transmittance.R"), d = img.channelIndex("depth");
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 4; ++x) {
            const size_t i = size_t(y) * 4 + x;
            const glm::vec3 want =
                cs.convert(glm::vec3(fb.rgba[i * 4], fb.rgba[i * 4 + 1], fb.rgba[i * 4 + 2]),
                           "ACEScg", "lin_rec709");
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(img.at(x, y, c), want[c], 1e-6f * std::max(1.0f, std::fabs(want[c])));
            EXPECT_EQ(img.at(x, y, 3), fb.rgba[i * 4 + 3]);
            for (int c = 0; c < 3; ++c) EXPECT_EQ(img.at(x, y, t + c), fb.transmittance[i * 3 + c]);
            EXPECT_EQ(img.at(x, y, d), fb.depth[i]);
        }
    // A metadata colour space contradicting the output space is an error.
    md.colorSpace = "ACEScg";
    EXPECT_THROW(writeExr(path("bad.exr"), fb, cs, "ACEScg", "lin_rec709", md), std::runtime_error);
    EXPECT_FALSE(fs::exists(path("bad.exr")));
}

TEST_F(ExrOutput, RawOutputHasNoChromaticities) {
    const ColorSystem cs = ColorSystem::builtin();
    const auto fb = makeFramebuffer(2, 2, {});
    writeExr(path("raw.exr"), fb, cs, "ACEScg", "raw", {});
    const ExrImage img = readExr(path("raw.exr"));
    EXPECT_FALSE(img.chromaticities.has_value());
    EXPECT_EQ(img.attributes.count("chromaticities"), 0u);
    EXPECT_EQ(attr(img, "nimbus/colorSpace"), "raw");
    EXPECT_EQ(img.pixels, fb.rgba);
}

TEST_F(ExrOutput, NanAndInfAreReplacedByZeroAndCounted) {
    const ColorSystem cs = ColorSystem::builtin();
    auto fb = makeFramebuffer(3, 3, {true, true});
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    fb.rgba[4 * 4 + 0] = nan; // centre pixel R
    fb.rgba[4 * 4 + 3] = inf; // centre pixel A
    fb.rgba[8 * 4 + 2] = -inf;
    fb.transmittance[5] = nan;
    fb.depth[7] = inf;
    for (const char* out : {"ACEScg", "lin_rec709"}) {
        const std::string file = path(std::string("nan_") + out + ".exr");
        EXPECT_EQ(writeExr(file, fb, cs, "ACEScg", out, {}), 5u) << out;
        const ExrImage img = readExr(file);
        for (float v : img.pixels) EXPECT_TRUE(std::isfinite(v)) << out;
        EXPECT_EQ(attr(img, "nimbus/nonFiniteReplaced"), "5");
        EXPECT_EQ(img.at(1, 1, 3), 0.0f); // the Inf alpha became 0
        EXPECT_EQ(img.at(1, 2, img.channelIndex("depth")), 0.0f);
        EXPECT_EQ(img.at(1, 0, img.channelIndex("transmittance.B")), 0.0f); // transmittance[5]
        if (std::string(out) == "ACEScg") {
            EXPECT_EQ(img.at(1, 1, 0), 0.0f);
            EXPECT_EQ(img.at(2, 2, 2), 0.0f);
        }
    }
}

TEST_F(ExrOutput, InvalidInputsThrowAndWriteNothing) {
    const ColorSystem cs = ColorSystem::builtin();
    auto fb = makeFramebuffer(2, 2, {true, false});
    try {
        writeExr(path("x.exr"), fb, cs, "ACEScg", "NotASpace", {});
        ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("'NotASpace'"), std::string::npos) << e.what();
    }
    fb.transmittance.pop_back();
    EXPECT_THROW(writeExr(path("x.exr"), fb, cs, "ACEScg", "ACEScg", {}), std::runtime_error);
    nimbus::Framebuffer empty;
    EXPECT_THROW(writeExr(path("x.exr"), empty, cs, "ACEScg", "ACEScg", {}), std::runtime_error);
    EXPECT_TRUE(listing().empty());
}

TEST_F(ExrOutput, ReadingAMissingOrCorruptFileNamesThePath) {
    for (const std::string& p : {path("missing.exr"), path("corrupt.exr")}) {
        if (p == path("corrupt.exr")) writeText(p, "this is not an EXR file");
        try {
            readExr(p);
            ADD_FAILURE() << "no exception for " << p;
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
        }
    }
}

// ---------------------------------------------------------------------------------------------
// PNG preview

using PngPreview = IoTempDir;

TEST_F(PngPreview, WrittenReadableRightSizeAndDisplayEncoded) {
    const ColorSystem cs = ColorSystem::builtin();
    nimbus::Framebuffer fb;
    fb.resize(7, 5, {});
    for (size_t i = 0; i < 35; ++i) {
        float* px = &fb.rgba[i * 4];
        px[0] = px[1] = px[2] = 0.18f;
        px[3] = 1.0f;
    }
    // Pixel 1: premultiplied, half covered: over black it is 0.09.
    for (int c = 0; c < 3; ++c) fb.rgba[4 + c] = 0.09f;
    fb.rgba[7] = 0.5f;
    // Pixel 2: NaN must not leak; pixel 3: very bright clips to 255.
    fb.rgba[8] = std::numeric_limits<float>::quiet_NaN();
    for (int c = 0; c < 3; ++c) fb.rgba[12 + c] = 50.0f;

    const std::string file = path("preview/frame.0001.png");
    EXPECT_EQ(writePreviewPng(file, fb, cs, "ACEScg", "sRGB", "Un-tone-mapped"), 1u);

    const ExrImage png = readExr(file);
    EXPECT_EQ(png.fileFormat, "png");
    EXPECT_EQ(png.width, 7);
    EXPECT_EQ(png.height, 5);
    ASSERT_EQ(png.channels.size(), 3u);
    for (const std::string& f : png.channelFormats) EXPECT_EQ(f, "uint8");
    // 8-bit values come back as v / 255, which rounds back to v exactly
    std::vector<int> px(png.pixels.size());
    for (size_t i = 0; i < px.size(); ++i) px[i] = int(std::lround(png.pixels[i] * 255.0f));
    const auto enc = [](float x) { return 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f; };
    EXPECT_EQ(int(px[0]), int(std::lround(enc(0.18f) * 255.0f))); // 118
    EXPECT_EQ(int(px[3]), int(std::lround(enc(0.09f) * 255.0f)));
    EXPECT_EQ(int(px[6]), 0) << "NaN must become 0";
    EXPECT_EQ(int(px[9]), 255);

    // The tone-mapped view also works, and differs from the un-tone-mapped one.
    writePreviewPng(path("aces.png"), fb, cs, "ACEScg", "sRGB", "ACES 1.0 SDR-video");
    const ExrImage aces = readExr(path("aces.png"));
    EXPECT_EQ(aces.width, 7);
    EXPECT_EQ(aces.height, 5);
    EXPECT_NE(std::lround(aces.pixels[0] * 255.0f), long(px[0]));
}

TEST_F(PngPreview, UnknownViewThrowsAndWritesNothing) {
    const ColorSystem cs = ColorSystem::builtin();
    nimbus::Framebuffer fb;
    fb.resize(2, 2, {});
    EXPECT_THROW(writePreviewPng(path("p.png"), fb, cs, "ACEScg", "sRGB", "Filmic"),
                 std::runtime_error);
    EXPECT_TRUE(listing().empty());
}

// ---------------------------------------------------------------------------------------------
// Atomic writes

using AtomicFile = IoTempDir;

TEST_F(AtomicFile, TempFileIsHiddenInSameDirectoryNotEndingInTheExtensionAndRegistered) {
    const std::string final = path("out/frame.0042.exr");
    std::string seenTemp;
    size_t inFlight = 0;
    writeAtomically(final, [&](const std::string& temp) {
        seenTemp = temp;
        inFlight = inFlightTempFileCount();
        writeText(temp, "payload");
    });
    const fs::path t(seenTemp);
    EXPECT_EQ(t.parent_path(), fs::path(final).parent_path());
    // hidden, not ending in .exr (find -name '*.exr' must not see it), naming the pid
    EXPECT_NE(t.extension(), ".exr");
    EXPECT_EQ(t.filename().string().rfind(".frame.0042.exr.tmp-", 0), 0u) << t;
    EXPECT_NE(t.filename().string().find("-" + std::to_string(getpid()) + "-"), std::string::npos)
        << t;
    EXPECT_EQ(inFlight, 1u);
    EXPECT_EQ(inFlightTempFileCount(), 0u);
    EXPECT_EQ(readBytes(final), "payload");
    EXPECT_EQ(listing(), (std::vector<std::string>{"out", "out/frame.0042.exr"}));
    EXPECT_NE(makeTempPath(final), makeTempPath(final)); // unique names
}

TEST_F(AtomicFile, WriterExceptionLeavesNeitherFinalNorTempFile) {
    const std::string final = path("a/b/c.exr");
    struct Boom : std::exception {};
    EXPECT_THROW(writeAtomically(final,
                                 [&](const std::string& temp) {
                                     writeText(temp, "half a frame");
                                     throw Boom();
                                 }),
                 Boom);
    EXPECT_FALSE(fs::exists(final));
    EXPECT_EQ(listing(), (std::vector<std::string>{"a", "a/b"})); // only the created directories
    EXPECT_EQ(inFlightTempFileCount(), 0u);
}

TEST_F(AtomicFile, FailedRewriteLeavesExistingValidFileUntouched) {
    const ColorSystem cs = ColorSystem::builtin();
    const auto fb = makeFramebuffer(3, 2, {true, true});
    const std::string final = path("frame.exr");
    writeExr(final, fb, cs, "ACEScg", "ACEScg", makeMetadata());
    const std::string before = readBytes(final);
    ASSERT_FALSE(before.empty());

    EXPECT_THROW(writeAtomically(final,
                                 [&](const std::string& temp) {
                                     writeText(temp, "garbage");
                                     throw std::runtime_error("disk on fire");
                                 }),
                 std::runtime_error);
    // A failing writeExr (unknown space) does not touch it either.
    EXPECT_THROW(writeExr(final, fb, cs, "ACEScg", "nope", {}), std::runtime_error);

    EXPECT_EQ(readBytes(final), before);
    EXPECT_EQ(readExr(final).pixels.size(), size_t(3 * 2 * 8));
    EXPECT_EQ(listing(), std::vector<std::string>{"frame.exr"});
}

TEST_F(AtomicFile, WriterThatProducesNoFileIsAnError) {
    const std::string final = path("nothing.exr");
    try {
        writeAtomically(final, [](const std::string&) {});
        ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(".nothing.exr.tmp-"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(std::strerror(ENOENT)), std::string::npos) << e.what();
    }
    EXPECT_TRUE(listing().empty());
}

TEST_F(AtomicFile, UncreatableDirectoryAndDirectoryTargetAreErrorsNamingThePath) {
    writeText(path("plainfile"), "x");
    const std::string bad = path("plainfile/sub/frame.exr");
    try {
        writeAtomically(bad, [](const std::string& t) { writeText(t, "x"); });
        ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(path("plainfile")), std::string::npos) << e.what();
    }
    fs::create_directories(path("isdir/child"));
    try {
        writeAtomically(path("isdir"), [](const std::string& t) { writeText(t, "x"); });
        ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(path("isdir")), std::string::npos) << e.what();
    }
    EXPECT_EQ(listing(), (std::vector<std::string>{"isdir", "isdir/child", "plainfile"}));
}

TEST_F(AtomicFile, RemoveInFlightTempFilesDeletesTheTempAndNoFinalAppears) {
    const std::string final = path("interrupted.exr");
    bool tempExistedBefore = false, tempGoneAfter = false;
    EXPECT_THROW(writeAtomically(final,
                                 [&](const std::string& temp) {
                                     writeText(temp, "partial");
                                     tempExistedBefore = fs::exists(temp);
                                     removeInFlightTempFiles(); // what the signal handler does
                                     tempGoneAfter = !fs::exists(temp);
                                 }),
                 std::runtime_error);
    EXPECT_TRUE(tempExistedBefore);
    EXPECT_TRUE(tempGoneAfter);
    EXPECT_EQ(inFlightTempFileCount(), 0u);
    EXPECT_TRUE(listing().empty());
    // The registry slot is reusable afterwards.
    writeAtomically(final, [](const std::string& t) { writeText(t, "ok"); });
    EXPECT_EQ(readBytes(final), "ok");
}

// Named *DeathTest so that gtest runs it first (before other tests start threads). The default
// "fast" death-test style forks at EXPECT_EXIT, so the child writes into this test's directory.
using AtomicFileDeathTest = IoTempDir;

TEST_F(AtomicFileDeathTest, SigtermDuringWriteLeavesNoFiles) {
    const std::string final = path("killed.exr");
    EXPECT_EXIT(
        {
            installTempFileCleanupOnSignals();
            writeAtomically(final, [](const std::string& temp) {
                writeText(temp, "half written");
                std::raise(SIGTERM);
            });
        },
        ::testing::KilledBySignal(SIGTERM), "");
    EXPECT_TRUE(listing().empty());
}
