#include "plugin/cli/dispatch.h"

#include <cstdio>
#include <exception>
#include <iostream>
#include <new>

#include "plugin/cli/commands.h"
#include "plugin/io/scene_file.h"

using namespace nimbus::cli;

extern "C" __attribute__((visibility("default"))) int nimbus_cli_command(int command,
                                                                         const void* options) {
    try {
        switch (Command(command)) {
        case Command::Render:
            return runRender(*static_cast<const RenderOptions*>(options));
        case Command::Converge:
            return runConverge(*static_cast<const ConvergeOptions*>(options));
        case Command::Calibrate:
            return runCalibrate(*static_cast<const CalibrateOptions*>(options));
        case Command::Bake:
            return runBake(*static_cast<const BakeOptions*>(options));
        case Command::BenchVdb:
            return runBenchVdb(*static_cast<const BenchVdbOptions*>(options));
        case Command::Reference:
            std::cout << nimbus::io::sceneFileReference();
            return kExitOk;
        }
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "nimbus: error: out of memory\n");
        return kExitNoMemory;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nimbus: internal error: %s\n", e.what());
        return kExitInternal;
    }
    std::fprintf(stderr, "nimbus: internal error: unknown command %d\n", command);
    return kExitInternal;
}
