# The command-line conventions every program shares (examples/common/cli.hpp), checked on the
# built program:
#   --help            exit 0, stdout starts with "usage: <program>", mentions --help and the
#                     numeric option, nothing on stderr
#   --version         exit 0, stdout is "<program> shadowsense <VERSION>"
#   a bad flag        exit 2, one line "<program>: error: ..." naming it on stderr, empty stdout
#   a bad number      exit 2, one line "<program>: error: <option>: ... '<value>'" on stderr,
#                     empty stdout (for "abc", "2.9x" and "1e99")
# Usage: cmake -DPROGRAM=path -DNUMERIC_OPTION=--threads -DVERSION=0.1.0 -P programs_cli_test.cmake
foreach(var PROGRAM NUMERIC_OPTION VERSION)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "programs_cli_test.cmake: -D${var}=... is required")
  endif()
endforeach()
get_filename_component(name "${PROGRAM}" NAME_WE)
set(failures "")

macro(run_program)
  execute_process(COMMAND "${PROGRAM}" ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err TIMEOUT 60)
endmacro()
macro(fail what)
  string(APPEND failures "  ${what}\n    exit: ${rc}\n    stdout: ${out}\n    stderr: ${err}\n")
endmacro()

run_program(--help)
string(FIND "${out}" "usage: ${name}" at_usage)
string(FIND "${out}" "--help" at_help)
string(FIND "${out}" "${NUMERIC_OPTION} " at_option)
if(NOT rc STREQUAL "0")
  fail("--help: expected exit status 0")
elseif(NOT at_usage EQUAL 0 OR at_help EQUAL -1 OR at_option EQUAL -1)
  fail("--help: expected stdout to start with 'usage: ${name}' and mention --help and ${NUMERIC_OPTION}")
elseif(NOT err STREQUAL "")
  fail("--help: expected nothing on stderr")
endif()

run_program(--version)
if(NOT rc STREQUAL "0" OR NOT out STREQUAL "${name} shadowsense ${VERSION}\n")
  fail("--version: expected exit status 0 and '${name} shadowsense ${VERSION}'")
endif()

run_program(--no-such-flag)
set(pattern "^${name}: error: [^\n]*--no-such-flag[^\n]*\n$")
if(NOT rc STREQUAL "2" OR NOT out STREQUAL "" OR NOT err MATCHES "${pattern}")
  fail("bad flag: expected exit status 2, empty stdout, one error line naming the flag")
endif()

foreach(bad abc 2.9x 1e99)
  run_program(${NUMERIC_OPTION} ${bad})
  set(pattern "^${name}: error: ${NUMERIC_OPTION}: [^\n]*'${bad}'\n$")
  if(NOT rc STREQUAL "2" OR NOT out STREQUAL "" OR NOT err MATCHES "${pattern}")
    fail("${NUMERIC_OPTION} ${bad}: expected exit status 2, empty stdout, one error line naming the option and the value")
  endif()
endforeach()

if(failures)
  message(FATAL_ERROR "${name} does not follow the command-line conventions:\n${failures}")
endif()
message(STATUS "${name}: --help, --version, a bad flag and bad numbers as expected")
