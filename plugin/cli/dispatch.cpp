#include "plugin/cli/dispatch.h"

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <new>
#include <string>
#include <thread>

#include <unistd.h>

#include "plugin/cli/commands.h"
#include "plugin/io/atomic_file.h"
#include "plugin/io/scene_file.h"

using namespace nimbus::cli;

namespace {

/// The last resort for an exception that reaches std::terminate (one thrown on a thread that
/// does not pass it on, or out of a noexcept function): a message instead of abort's core dump
/// and exit 134, no temp file left behind, exit 1 (internal error).
[[noreturn]] void onTerminate() {
    nimbus::io::removeInFlightTempFiles();
    std::string what = "no exception";
    if (std::exception_ptr e = std::current_exception()) {
        try {
            std::rethrow_exception(e);
        } catch (const std::exception& ex) {
            what = ex.what();
        } catch (...) {
            what = "an exception that is not a std::exception";
        }
    }
    std::fprintf(stderr, "nimbus: internal error: unhandled (%s); please report it\n",
                 what.c_str());
    std::fflush(stderr);
    _exit(kExitInternal);
}

/// NIMBUS_TEST_FAULT (tests only, tests/test_stability.cpp): `thread` throws on a thread of
/// its own (reaches std::terminate), `worker` throws an int from a render worker (progress
/// callback), `bad-alloc`/`std` throw std::bad_alloc/std::runtime_error there.
void testFaultAtStart() {
    const char* f = std::getenv("NIMBUS_TEST_FAULT");
    if (f && std::string(f) == "thread") {
        std::thread([] { throw std::runtime_error("test fault on a thread of its own"); }).join();
    }
}

} // namespace

extern "C" __attribute__((visibility("default"))) int nimbus_cli_command(int command,
                                                                         const void* options) {
    std::set_terminate(onTerminate);
    try {
        testFaultAtStart();
        switch (Command(command)) {
        case Command::Render: // libnimbus_render.so's nimbus_cli_render (main.cpp loads it)
            break;
        case Command::Converge:
            return runConverge(*static_cast<const ConvergeOptions*>(options));
        case Command::Calibrate:
            return runCalibrate(*static_cast<const CalibrateOptions*>(options));
        case Command::Bake:
            return runBake(*static_cast<const BakeOptions*>(options));
        case Command::BenchVdb:
            return runBenchVdb(*static_cast<const BenchVdbOptions*>(options));
        case Command::Stress:
            return runStress(*static_cast<const StressOptions*>(options));
        case Command::Rt:
            return runRt(*static_cast<const RtOptions*>(options));
        case Command::ExportGlsl:
            return runExportGlsl(*static_cast<const ExportGlslOptions*>(options));
        case Command::Reference:
            std::cout << nimbus::io::sceneFileReference();
            return kExitOk;
        }
    } catch (const std::bad_alloc&) {
        nimbus::io::removeInFlightTempFiles();
        std::fprintf(stderr, "nimbus: error: out of memory\n");
        return kExitNoMemory;
    } catch (const std::exception& e) {
        nimbus::io::removeInFlightTempFiles();
        std::fprintf(stderr, "nimbus: internal error: %s\n", e.what());
        return kExitInternal;
    } catch (...) {
        nimbus::io::removeInFlightTempFiles();
        std::fprintf(stderr, "nimbus: internal error: an exception that is not a "
                             "std::exception; please report it\n");
        return kExitInternal;
    }
    std::fprintf(stderr, "nimbus: internal error: unknown command %d\n", command);
    return kExitInternal;
}
