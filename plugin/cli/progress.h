/// @file progress.h
/// @brief Render progress on stderr: a bar with ETA on a terminal, plain lines otherwise
/// (`frame 3/24 37%`), or one JSON object per line (`--progress json`, docs/farm_cli.md).
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace nimbus::cli {

enum class ProgressMode { Auto, Bar, Plain, Json, None };

class Progress {
  public:
    Progress(ProgressMode mode, int frames);
    /// Frame `index` (0-based) of the sequence, `frameNumber` as the user knows it, `fraction`
    /// of its tiles done.
    void update(int index, int frameNumber, double fraction);
    /// Ends the bar line (if any) so other output starts on a clean line.
    void finishLine();

  private:
    ProgressMode mode_;
    int frames_;
    int lastPlainPercent_ = -1;
    int lastPlainIndex_ = -1;
    int lastJsonPercent_ = -1;
    int lastJsonIndex_ = -1;
    bool lineOpen_ = false;
    std::chrono::steady_clock::time_point start_, lastDraw_;
};

std::string formatDuration(double seconds);

/// One JSON object on one line of stderr: `{"event":"<event>", ...fields in the order added}`.
/// Strings are escaped as JSON requires (quote, backslash, control characters); numbers that
/// are not finite are written as null.
class JsonLine {
  public:
    explicit JsonLine(const char* event);
    JsonLine& str(const char* key, const std::string& value);
    JsonLine& num(const char* key, double value);
    JsonLine& num(const char* key, int value);
    /// Writes the line (and a newline) to stderr and flushes it.
    void print();

  private:
    std::string text_;
};

/// `text` as a JSON string literal, quotes included.
std::string jsonString(const std::string& text);

} // namespace nimbus::cli
