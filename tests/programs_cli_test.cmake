# The command-line conventions every program shares (examples/common/cli.hpp), checked on the
# built program:
#   --help            exit 0, stdout starts with "usage: <program>", mentions --help and the
#                     numeric option, nothing on stderr
#   --version         exit 0, stdout is "<program> shadowsense <VERSION>"
#   a bad flag        exit 2, one line "<program>: error: ..." naming it on stderr, empty stdout
#   a bad number      exit 2, one line "<program>: error: <option>: ... '<value>'" on stderr,
#                     empty stdout (for "abc", "2.9x" and "1e99"), the same given as
#                     "<option>=<value>"
#   INPUT_OPTION      (when given, e.g. --input) --help lists it, and "<option>=<path>" with a
#                     missing path is an error that is not "unknown option"
#   SHOW_OPTION       (when given, e.g. --show) "<program> --show" alone with DISPLAY and
#                     WAYLAND_DISPLAY unset: exit 2 and one line "<program>: error: <option>:
#                     ..." on stderr, not an abort (so programs check it right after parsing,
#                     before other missing options: cli::require_display)
# Usage: cmake -DPROGRAM=path -DNUMERIC_OPTION=--threads -DVERSION=0.1.0 [-DINPUT_OPTION=--input]
#              [-DSHOW_OPTION=--show] -P programs_cli_test.cmake
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
  set(separate "${err}")
  run_program(${NUMERIC_OPTION}=${bad})
  if(NOT rc STREQUAL "2" OR NOT out STREQUAL "" OR NOT err STREQUAL "${separate}")
    fail("${NUMERIC_OPTION}=${bad}: expected the same error as '${NUMERIC_OPTION} ${bad}'")
  endif()
endforeach()

if(DEFINED INPUT_OPTION AND NOT INPUT_OPTION STREQUAL "")
  run_program(--help)
  string(FIND "${out}" "${INPUT_OPTION} " at_input)
  if(at_input EQUAL -1)
    fail("--help: expected it to list ${INPUT_OPTION}")
  endif()
  run_program(${INPUT_OPTION}=/nonexistent/shadowsense-input)
  if(NOT rc STREQUAL "2" OR NOT err MATCHES "^${name}: error: [^\n]*\n$" OR err MATCHES "unknown option")
    fail("${INPUT_OPTION}=PATH: expected exit status 2 and one error line other than 'unknown option'")
  endif()
endif()

if(DEFINED SHOW_OPTION AND NOT SHOW_OPTION STREQUAL "")
  execute_process(COMMAND "${CMAKE_COMMAND}" -E env --unset=DISPLAY --unset=WAYLAND_DISPLAY
                          "${PROGRAM}" ${SHOW_OPTION}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 60)
  if(NOT rc STREQUAL "2" OR NOT err MATCHES "^${name}: error: ${SHOW_OPTION}: [^\n]*\n$")
    fail("${SHOW_OPTION} without a display: expected exit status 2 and one error line naming it")
  endif()
endif()

if(failures)
  message(FATAL_ERROR "${name} does not follow the command-line conventions:\n${failures}")
endif()
message(STATUS "${name}: --help, --version, a bad flag and bad numbers as expected")
