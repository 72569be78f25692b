# embed_literal.cmake: nimbus_embed_literal(), shared by core/kernels/embed_kernels.cmake and
# plugin/realtime/embed_pass.cmake (both run with cmake -P).

# The file's bytes as adjacent C++ string literals of \xNN escapes, 24 bytes a line.
function(nimbus_embed_literal path out_var)
  file(READ "${path}" _hex HEX)
  string(LENGTH "${_hex}" _n)
  set(_lit "")
  set(_at 0)
  while(_at LESS _n)
    string(SUBSTRING "${_hex}" ${_at} 48 _chunk)
    string(REGEX REPLACE "([0-9a-f][0-9a-f])" "\\\\x\\1" _chunk "${_chunk}")
    string(APPEND _lit "    \"${_chunk}\"\n")
    math(EXPR _at "${_at} + 48")
  endwhile()
  if(_lit STREQUAL "")
    set(_lit "    \"\"\n")
  endif()
  set(${out_var} "${_lit}" PARENT_SCOPE)
endfunction()
