/// @file pass_source.h
/// @brief The GLSL text of the pass files of plugin/realtime, embedded at build time
/// (plugin/realtime/embed_pass.cmake, regenerated whenever a pass file changes), so the shader a
/// run compiles is the text the C++ build compiled (march_params.glsl is also compiled as C++:
/// plugin/realtime/march_params.h).
#pragma once

#include <string_view>

namespace nimbus::rt {

/// plugin/realtime/march_params.glsl: the parameter block shared by C++ and GLSL.
std::string_view march_paramsSource();
/// plugin/realtime/march_data.glsl: the buffers of the pass (parameter block, Lorenz-Mie table,
/// multiple-scattering grids) and their lookups.
std::string_view march_dataSource();
/// plugin/realtime/march_pass.glsl: the march pass (entry point main()).
std::string_view march_passSource();
/// PNanoVDB.h (libnanovdb-dev) as GLSL: the installed header run through the C preprocessor
/// with PNANOVDB_GLSL at build time (CMakeLists.txt), so its text is plain GLSL 4.30 (no macros,
/// no C or HLSL branches). march_data.glsl reads VDB grids through it (RT_VDB).
std::string_view pnanovdbSource();

} // namespace nimbus::rt
