# embed_pass.cmake: writes the C++ file that embeds the GLSL pass files of plugin/realtime
# (plugin/realtime/pass_source.h). Run at build time by the custom command in the top-level
# CMakeLists.txt:
#   cmake -DDIR=<plugin/realtime> -DNAMES=<name,name,...> -DOUT=<generated .cpp> -P embed_pass.cmake
# Every byte is written as a \xNN escape (as core/kernels/embed_kernels.cmake does), so no text
# in a pass can end the literal early.

foreach(_var DIR NAMES OUT)
  if(NOT DEFINED ${_var})
    message(FATAL_ERROR "embed_pass.cmake: -D${_var}=... is required")
  endif()
endforeach()

include(${CMAKE_CURRENT_LIST_DIR}/../../core/kernels/embed_literal.cmake) # nimbus_embed_literal()

string(REPLACE "," ";" _names "${NAMES}")
set(_cpp "// Generated at build time by plugin/realtime/embed_pass.cmake: do not edit.\n")
string(APPEND _cpp "#include \"plugin/realtime/pass_source.h\"\n\nnamespace nimbus::rt {\n\n")
foreach(_n ${_names})
  nimbus_embed_literal("${DIR}/${_n}.glsl" _lit)
  string(APPEND _cpp "namespace {\n// plugin/realtime/${_n}.glsl\nconstexpr char kText_${_n}[] =\n${_lit};\n}\n")
  string(APPEND _cpp "std::string_view ${_n}Source() {\n"
                     "    return std::string_view(kText_${_n}, sizeof(kText_${_n}) - 1);\n}\n\n")
endforeach()
string(APPEND _cpp "} // namespace nimbus::rt\n")
file(WRITE "${OUT}" "${_cpp}")
