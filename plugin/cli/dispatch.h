/// @file dispatch.h
/// @brief The one entry point of the commands' shared object (libnimbus_commands.so).
///
/// The `nimbus` executable holds only the command-line parser: `--version` and `--help` start
/// without loading OpenImageIO, OpenColorIO, OpenVDB and Embree (about 260 shared libraries and
/// 0.5 s of dynamic linking on Debian 12). A command that runs loads the shared object beside
/// the executable and calls nimbus_cli_command with its options struct.
#pragma once

namespace nimbus::cli {

enum class Command : int {
    Render = 0,
    Converge,
    Calibrate,
    Bake,
    BenchVdb,
    Reference,
    Stress,
    Rt,
    ExportGlsl
};

/// Name of the symbol the executable looks up.
inline constexpr const char* kDispatchSymbol = "nimbus_cli_command";
/// File name of the shared object, looked up beside the executable.
inline constexpr const char* kCommandsLibrary = "libnimbus_commands.so";
/// `render` is a host of libnimbus.so (the C ABI, plugin/capi/nimbus.h) in a shared object of
/// its own that links that library and none of the internals (plugin/cli/render_host.cpp).
inline constexpr const char* kRenderLibrary = "libnimbus_render.so";
/// Its entry point: int nimbus_cli_render(const RenderOptions*).
inline constexpr const char* kRenderSymbol = "nimbus_cli_render";

} // namespace nimbus::cli

/// Runs `command` with `options` (a pointer to the command's options struct of commands.h, or
/// null for Reference); returns the exit code. Never throws.
extern "C" int nimbus_cli_command(int command, const void* options);
