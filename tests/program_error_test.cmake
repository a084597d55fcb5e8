# One bad run of a program: exit status 2 and a stderr that starts "<program>: error: " and
# contains EXPECT (stdout is not checked: a program may have printed progress before the error).
# Usage: cmake -DPROGRAM=path "-DARGS=a;b;c" "-DEXPECT=text" -P program_error_test.cmake
foreach(var PROGRAM ARGS EXPECT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "program_error_test.cmake: -D${var}=... is required")
  endif()
endforeach()
get_filename_component(name "${PROGRAM}" NAME_WE)
execute_process(COMMAND "${PROGRAM}" ${ARGS} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err TIMEOUT 120)
string(FIND "${err}" "${name}: error: " at_prefix)
string(FIND "${err}" "${EXPECT}" at_expect)
if(NOT rc STREQUAL "2" OR NOT at_prefix EQUAL 0 OR at_expect EQUAL -1)
  message(FATAL_ERROR "${name} ${ARGS}: expected exit 2 and '${name}: error: ...${EXPECT}...' "
                      "on stderr\n  exit: ${rc}\n  stdout: ${out}\n  stderr: ${err}")
endif()
