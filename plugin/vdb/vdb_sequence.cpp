/// @file vdb_sequence.cpp
/// @brief resolveVdbFrame() (see vdb_reader.h): per-frame VDB file patterns, missing frames and
///        holding the previous frame. No OpenVDB here (cheap to compile).
#include "plugin/vdb/vdb_reader.h"

#include <filesystem>
#include <limits>
#include <system_error>

#include "plugin/io/frames.h"

namespace nimbus::vdb {

namespace {

namespace fs = std::filesystem;

bool isRegularFile(const std::string& path) {
    std::error_code ec;
    return fs::is_regular_file(path, ec);
}

/// The nearest frame in [lowest, frame) whose file exists, found by listing the pattern's
/// directory once (one readdir instead of up to maxHoldFrames stat calls, which matters on
/// network file systems). A name matches frame f when expandFramePattern(filePattern, f) gives
/// it; the candidates f are the numbers written in the name. Returns false when none exists.
bool nearestEarlierByListing(const fs::path& dir, const std::string& filePattern, int frame,
                             long long lowest, int& found) {
    std::error_code ec;
    fs::directory_iterator it(dir.empty() ? fs::path(".") : dir, ec), end;
    if (ec) return false;
    bool any = false;
    for (; it != end; it.increment(ec)) {
        if (ec) break;
        const std::string name = it->path().filename().string();
        for (std::size_t i = 0; i < name.size(); ++i) {
            if (name[i] < '0' || name[i] > '9') continue;
            if (i > 0 && name[i - 1] >= '0' && name[i - 1] <= '9') continue; // not a run start
            std::size_t j = i;
            while (j < name.size() && name[j] >= '0' && name[j] <= '9') ++j;
            if (j - i > 10) continue;
            const long long value = std::stoll(name.substr(i, j - i));
            for (long long f : {value, -value}) { // "-007" may be a negative frame
                if (f < lowest || f >= frame || (any && f <= found)) continue;
                if (io::expandFramePattern(filePattern, int(f)) != name) continue;
                std::error_code fec;
                if (!it->is_regular_file(fec)) continue;
                found = int(f);
                any = true;
            }
        }
    }
    return any;
}

} // namespace

VdbFrameFile resolveVdbFrame(const std::string& pattern, int frame, bool hold, int maxHoldFrames) {
    VdbFrameFile out;
    out.frame = frame;
    out.sourceFrame = frame;
    out.path = io::expandFramePattern(pattern, frame);
    if (isRegularFile(out.path)) return out;

    const std::string where = pattern + ": frame " + std::to_string(frame) + ": ";
    {
        // there, but not a file: say what it is (it was reported as missing)
        std::error_code ec;
        const fs::file_status st = fs::status(out.path, ec);
        const char* kind = nullptr;
        switch (st.type()) {
        case fs::file_type::directory:
            kind = "a directory";
            break;
        case fs::file_type::fifo:
            kind = "a FIFO (named pipe)";
            break;
        case fs::file_type::character:
            kind = "a character device";
            break;
        case fs::file_type::block:
            kind = "a block device";
            break;
        case fs::file_type::socket:
            kind = "a socket";
            break;
        default:
            break;
        }
        if (kind) throw VdbError(where + "\"" + out.path + "\" is " + kind + ", not a VDB file");
    }
    if (!io::patternHasFrameToken(pattern)) {
        throw VdbError(where + "the file \"" + out.path + "\" does not exist");
    }
    if (!hold) {
        throw VdbError(where + "the file \"" + out.path +
                       "\" does not exist (a missing frame of the sequence; holding the previous "
                       "frame is an option)");
    }
    // Nearest earlier frame whose file exists, at most maxHoldFrames back, never below INT_MIN.
    const long long lowest = std::max<long long>(std::numeric_limits<int>::min(),
                                                 (long long)frame - std::max(maxHoldFrames, 0));
    const fs::path patternPath(pattern);
    const std::string dirPattern = patternPath.parent_path().string();
    int source = 0;
    bool found = false;
    if (!io::patternHasFrameToken(dirPattern)) {
        found = nearestEarlierByListing(patternPath.parent_path(), patternPath.filename().string(),
                                        frame, lowest, source);
    } else { // the frame is (also) in a directory name: probe frame by frame
        for (long long f = (long long)frame - 1; f >= lowest && !found; --f) {
            if (isRegularFile(io::expandFramePattern(pattern, int(f))))
                source = int(f), found = true;
        }
    }
    if (!found) {
        throw VdbError(where + "the file \"" + out.path +
                       "\" does not exist, and no earlier frame exists to hold (searched back to "
                       "frame " +
                       std::to_string(lowest) + ")");
    }
    const std::string candidate = io::expandFramePattern(pattern, source);
    out.sourceFrame = source;
    out.held = true;
    out.warning = where + "the file \"" + out.path + "\" does not exist; holding frame " +
                  std::to_string(source) + " (\"" + candidate + "\")";
    out.path = candidate;
    return out;
}

} // namespace nimbus::vdb
