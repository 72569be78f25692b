/// @file fuzz_vdb.cpp
/// @brief libFuzzer harnesses: the VDB loading wrapper (plugin/vdb). Built twice:
///  - fuzz_vdb (in-process): listVdbGrids() and loadVdbGrid() with isolate = false, i.e. our
///    pre-checks of the header and grid descriptors followed by OpenVDB's own reader. A crash
///    here inside OpenVDB's tree reader is why Nimbus reads untrusted files in a child;
///  - fuzz_vdb_isolated (NIMBUS_FUZZ_ISOLATED): loadVdbGrid() as the renderer calls it, in a
///    forked child with a time and memory limit. Whatever the bytes, the caller must get a grid
///    or a VdbError: a crash, hang or other exception in the parent is a bug.
/// The grid name comes from the first byte (density, or the first grid the file lists).
#include <cstdint>
#include <cstdlib>
#include <new>
#include <string>

#include "plugin/vdb/vdb_error.h"
#include "plugin/vdb/vdb_reader.h"
#include "tests/fuzz/fuzz_input.h"

#ifdef NIMBUS_FUZZ_NEW_THROWS
// The in-process harness under AddressSanitizer. OpenVDB's tree reader allocates what a chunk
// size in the file says (docs/fuzzing.md, find 4: 140 TB). In a process of its own that is a
// std::bad_alloc, which loadVdbGrid turns into a VdbError; ASan's operator new instead reports
// the failed allocation as a fatal error, so every later input would be lost to that one known
// fault. This operator new takes its memory from ASan's malloc (still checked for overflows and
// use after free) and throws std::bad_alloc when malloc returns null; run.sh sets
// allocator_may_return_null=1 and max_allocation_size_mb, so an allocation past the limit fails
// as it would under the memory limit of the isolated child. New and delete are replaced together
// (plain and sized; the aligned forms stay ASan's, a pair of their own).
void* operator new(std::size_t n) {
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
    return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
    return std::malloc(n ? n : 1);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
    std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
    std::free(p);
}
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace nimbus::vdb;
    const std::string path = nimbus::fuzz::scratchFile(data, size, ".vdb");
    std::string grid = "density";
    try {
        const std::vector<VdbGridInfo> grids = listVdbGrids(path);
        if (!grids.empty() && size && (data[0] & 1)) grid = grids.front().name;
    } catch (const VdbError&) {
    }
    VdbLoadOptions o;
    o.path = path;
    o.gridName = grid;
    o.levelsetToFog = size > 1 && (data[1] & 1);
#ifdef NIMBUS_FUZZ_ISOLATED
    o.isolate = true;
    o.timeoutSeconds = 5.0;
    o.memoryLimitBytes = std::uint64_t(1) << 30;
#else
    o.isolate = false;
#endif
    try {
        const LoadedVdbGrid g = loadVdbGrid(o);
        if (!g.grid()) __builtin_trap(); // documented: never null after a successful load
    } catch (const VdbError&) {
    }
    return 0;
}
