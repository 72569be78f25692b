/// @file fuzz_input.h
/// @brief Shared by the fuzz harnesses: inputs that must reach a file-reading API are written to
/// a private file under /dev/shm (or $TMPDIR), one per process, and overwritten per input.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <unistd.h>

namespace nimbus::fuzz {

/// Writes data to this process's scratch file with the given extension and returns its path.
inline std::string scratchFile(const std::uint8_t* data, std::size_t size, const char* ext) {
    static const std::string dir = [] {
        const char* shm = "/dev/shm";
        if (access(shm, W_OK) == 0) return std::string(shm);
        const char* t = std::getenv("TMPDIR");
        return std::string(t && *t ? t : "/tmp");
    }();
    const std::string path =
        dir + "/nimbus_fuzz_" + std::to_string(static_cast<long>(getpid())) + ext;
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) {
        std::perror(path.c_str());
        std::abort();
    }
    if (size && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
    return path;
}

} // namespace nimbus::fuzz
