/// @file progress.h
/// @brief Render progress on stderr: a bar with ETA on a terminal, plain lines otherwise
/// (`frame 3/24 37%`), machine-parsable for farm logs.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace nimbus::cli {

enum class ProgressMode { Auto, Bar, Plain, None };

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
    bool lineOpen_ = false;
    std::chrono::steady_clock::time_point start_, lastDraw_;
};

std::string formatDuration(double seconds);

} // namespace nimbus::cli
