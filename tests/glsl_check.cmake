# Assembles prelude.glsl + the given kernel files into one compute shader and validates it, the
# way kern::glslLibrary() (core/kernels/source.h) assembles the embedded text: kernel i after
# "#line 1 <i + 1>", so a message's source-string number names the kernel file.
file(WRITE ${OUT} "#version 430\n")
file(READ ${PRELUDE} _text)
file(APPEND ${OUT} "${_text}")
set(_string 0)
foreach(k ${KERNELS})
  math(EXPR _string "${_string} + 1")
  file(READ ${k} _text)
  file(APPEND ${OUT} "#line 1 ${_string}\n${_text}\n")
endforeach()
file(APPEND ${OUT} "layout(local_size_x = 1) in;\nvoid main() {}\n")
execute_process(COMMAND ${VALIDATOR} ${OUT} RESULT_VARIABLE _rc OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
if(NOT _rc EQUAL 0)
  message(FATAL_ERROR "GLSL validation failed for ${OUT} (source string n = kernel n of ${KERNELS}):\n${_out}${_err}")
endif()
