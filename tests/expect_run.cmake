# Runs CMD with ARGS ('|'-separated) and fails unless it exits with EXPECT_RC and its output
# (stdout and stderr) contains EXPECT. Used by ctest entries that check a program's errors.
string(REPLACE "|" ";" _args "${ARGS}")
execute_process(COMMAND ${CMD} ${_args} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc STREQUAL "${EXPECT_RC}")
  message(FATAL_ERROR "exit code ${rc}, expected ${EXPECT_RC}\n${out}${err}")
endif()
string(FIND "${out}${err}" "${EXPECT}" at)
if(at EQUAL -1)
  message(FATAL_ERROR "\"${EXPECT}\" not in the output:\n${out}${err}")
endif()
message(STATUS "ok: exit ${rc}, output has \"${EXPECT}\"")
