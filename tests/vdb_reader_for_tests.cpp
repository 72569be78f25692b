/// @file vdb_reader_for_tests.cpp
/// @brief A reader executable that misbehaves on request, run by tests/test_vdb_corrupt.cpp and
///        test_vdb_velocity.cpp in place of nimbus-vdb-reader (detail::setReaderForTests): it
///        does what NIMBUS_TEST_READER_DOES says, then (for the kinds that go on) reads the grid as
///        the real reader does. The parent's handling of a crash, a hang, an abnormal exit, a
///        garbled reply and the reader's output is what these tests check.
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <unistd.h>

#include "plugin/vdb/vdb_isolate.h"

namespace {

void writeBytes(const void* p, std::size_t n) {
    [[maybe_unused]] const ssize_t w = ::write(3, p, n); // the reply's descriptor
}

} // namespace

int main() {
    const char* env = std::getenv("NIMBUS_TEST_READER_DOES");
    const std::string does = env ? env : "";
    if (does == "segv") {
        std::fprintf(stderr, "something went wrong at leaf 17\n");
        std::fflush(stderr);
        std::raise(SIGSEGV);
    } else if (does == "abort") {
        std::abort();
    } else if (does == "sigkill") {
        ::kill(::getpid(), SIGKILL);
    } else if (does == "warn") {
        // what OpenVDB 10 prints for a multi-buffer tree (Tree.h), colours included
        std::fprintf(stderr, "\x1b[35m WARN: multi-buffer trees are no longer supported\n\x1b[0m");
    } else if (does == "flood") {
        for (int i = 0; i < 1000; ++i)
            std::fprintf(stderr, "line %d %s\n", i, std::string(500, 'x').c_str());
    } else if (does == "announce") {
        std::fprintf(stderr, "the reader for tests ran\n");
    } else if (does == "hang") {
        for (;;) ::pause();
    } else if (does == "exit7") {
        ::_exit(7);
    } else if (does == "exit0") {
        ::_exit(0);
    } else if (does == "junk" || does == "junk-then-hang") {
        const char junk[64] = "hello, this is not a reply at all, but it is 64 bytes long....";
        writeBytes(junk, sizeof junk);
        if (does == "junk") ::_exit(0);
        for (;;) ::pause();
    } else if (does == "huge") { // a reply that announces a 1 TB grid
        struct {
            char magic[8] = {'N', 'I', 'M', 'B', 'V', 'D', 'B', '1'};
            std::uint32_t kind = 1, reserved = 0;
            std::uint64_t metaBytes = 0, gridBytes = 1ull << 40;
        } h;
        writeBytes(&h, sizeof h);
        ::_exit(0);
    } else if (!does.empty()) {
        std::fprintf(stderr, "vdb_reader_for_tests: unknown NIMBUS_TEST_READER_DOES=%s\n",
                     does.c_str());
        return 2;
    }
    std::fflush(stderr);
    return nimbus::vdb::detail::readerMain();
}
