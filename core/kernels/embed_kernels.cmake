# embed_kernels.cmake: writes the C++ file that embeds the GLSL kernel text (see source.h).
# Run at build time by the custom command in the top-level CMakeLists.txt:
#   cmake -DPRELUDE=<prelude.glsl> -DKERNEL_DIR=<core/kernels> -DKERNELS=<name,name,...>
#         -DOUT=<generated .cpp> -P embed_kernels.cmake
# KERNELS is the include order of core/kernels/kernels.h (comma-separated: a semicolon would
# split the argument in the custom command). Every byte is written as a \xNN escape, so no
# text in a kernel can end the literal early (no raw-string delimiter to collide with).

foreach(_var PRELUDE KERNEL_DIR KERNELS OUT)
  if(NOT DEFINED ${_var})
    message(FATAL_ERROR "embed_kernels.cmake: -D${_var}=... is required")
  endif()
endforeach()

include(${CMAKE_CURRENT_LIST_DIR}/embed_literal.cmake) # nimbus_embed_literal()

string(REPLACE "," ";" _kernels "${KERNELS}")

set(_cpp "// Generated at build time by core/kernels/embed_kernels.cmake from the include order of\n")
string(APPEND _cpp "// core/kernels/kernels.h: do not edit. Kernel order: ${KERNELS}.\n")
string(APPEND _cpp "#include \"core/kernels/source.h\"\n\nnamespace nimbus::kern {\nnamespace {\n\n")

nimbus_embed_literal("${PRELUDE}" _lit)
string(APPEND _cpp "constexpr char kPreludeText[] =\n${_lit};\n\n")
set(_table "")
foreach(_k ${_kernels})
  nimbus_embed_literal("${KERNEL_DIR}/${_k}.glsl" _lit)
  string(APPEND _cpp "// core/kernels/${_k}.glsl\nconstexpr char kText_${_k}[] =\n${_lit};\n\n")
  string(APPEND _table "    {\"${_k}\", \"core/kernels/${_k}.glsl\", "
                       "std::string_view(kText_${_k}, sizeof(kText_${_k}) - 1)},\n")
endforeach()
string(APPEND _cpp "constexpr KernelSource kKernels[] = {\n${_table}};\n\n} // namespace\n\n")
string(APPEND _cpp "std::string_view glslPrelude() {\n"
                   "    return std::string_view(kPreludeText, sizeof(kPreludeText) - 1);\n}\n\n")
string(APPEND _cpp "std::span<const KernelSource> kernelSources() { return kKernels; }\n\n")
string(APPEND _cpp "} // namespace nimbus::kern\n")

file(WRITE "${OUT}" "${_cpp}")
