#include "plugin/cli/progress.h"

#include <cmath>
#include <unistd.h>

namespace nimbus::cli {

std::string formatDuration(double s) {
    char buf[64];
    if (!std::isfinite(s) || s < 0) return "--";
    if (s < 60.0)
        std::snprintf(buf, sizeof buf, "%.1fs", s);
    else if (s < 3600.0)
        std::snprintf(buf, sizeof buf, "%dm%02ds", int(s) / 60, int(s) % 60);
    else
        std::snprintf(buf, sizeof buf, "%dh%02dm", int(s) / 3600, (int(s) / 60) % 60);
    return buf;
}

Progress::Progress(ProgressMode mode, int frames) : mode_(mode), frames_(frames) {
    if (mode_ == ProgressMode::Auto)
        mode_ = isatty(STDERR_FILENO) ? ProgressMode::Bar : ProgressMode::Plain;
    start_ = lastDraw_ = std::chrono::steady_clock::now();
}

void Progress::update(int index, int frameNumber, double fraction) {
    if (mode_ == ProgressMode::None) return;
    const double overall = (index + fraction) / frames_;
    const int percent = int(std::floor(overall * 100.0));
    auto now = std::chrono::steady_clock::now();
    if (mode_ == ProgressMode::Json) {
        // one line per whole percent of the frame: per tile would flood a log on big frames
        const int framePercent = int(std::floor(fraction * 100.0));
        if (index == lastJsonIndex_ && framePercent == lastJsonPercent_) return;
        lastJsonIndex_ = index;
        lastJsonPercent_ = framePercent;
        JsonLine j("progress");
        j.num("frame", frameNumber);
        j.num("index", index);
        j.num("frames", frames_);
        j.num("percent", framePercent);
        j.num("overall_percent", percent);
        j.num("elapsed", std::chrono::duration<double>(now - start_).count());
        j.print();
        return;
    }
    if (mode_ == ProgressMode::Plain) {
        // one line per 10% and one per new frame: enough for a farm log, never a flood
        if (index == lastPlainIndex_ && percent / 10 == lastPlainPercent_ / 10 && fraction < 1.0)
            return;
        if (index == lastPlainIndex_ && percent == lastPlainPercent_) return;
        lastPlainIndex_ = index;
        lastPlainPercent_ = percent;
        std::fprintf(stderr, "frame %d/%d %d%% (frame %d)\n", index + 1, frames_, percent,
                     frameNumber);
        std::fflush(stderr);
        return;
    }
    if (fraction < 1.0 && now - lastDraw_ < std::chrono::milliseconds(100)) return;
    lastDraw_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double eta = overall > 1e-4 ? elapsed * (1.0 - overall) / overall : -1.0;
    const int width = 30, filled = int(overall * width);
    std::string bar(size_t(filled), '#');
    bar.resize(width, '.');
    std::fprintf(stderr, "\r[%s] %3d%%  frame %d/%d (%d)  elapsed %s  ETA %s   ", bar.c_str(),
                 percent, index + 1, frames_, frameNumber, formatDuration(elapsed).c_str(),
                 formatDuration(eta).c_str());
    std::fflush(stderr);
    lineOpen_ = true;
}

std::string jsonString(const std::string& text) {
    std::string out = "\"";
    for (const char c : text) {
        switch (c) {
        case '"':
            out += "\\\"";
            break;
        case '\\':
            out += "\\\\";
            break;
        case '\n':
            out += "\\n";
            break;
        case '\t':
            out += "\\t";
            break;
        case '\r':
            out += "\\r";
            break;
        default:
            if (static_cast<unsigned char>(c) < 0x20) {
                char buf[8];
                std::snprintf(buf, sizeof buf, "\\u%04x", unsigned(static_cast<unsigned char>(c)));
                out += buf;
            } else {
                out += c;
            }
        }
    }
    return out + "\"";
}

JsonLine::JsonLine(const char* event) : text_("{\"event\":" + jsonString(event)) {}

JsonLine& JsonLine::str(const char* key, const std::string& value) {
    text_ += "," + jsonString(key) + ":" + jsonString(value);
    return *this;
}

JsonLine& JsonLine::num(const char* key, double value) {
    char buf[64] = "null";
    if (std::isfinite(value)) std::snprintf(buf, sizeof buf, "%.6g", value);
    text_ += "," + jsonString(key) + ":" + buf;
    return *this;
}

JsonLine& JsonLine::num(const char* key, int value) {
    text_ += "," + jsonString(key) + ":" + std::to_string(value);
    return *this;
}

void JsonLine::print() {
    std::fprintf(stderr, "%s}\n", text_.c_str());
    std::fflush(stderr);
}

void Progress::finishLine() {
    if (lineOpen_) std::fprintf(stderr, "\n");
    lineOpen_ = false;
}

} // namespace nimbus::cli
