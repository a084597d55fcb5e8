# ss_timeline_eval on its two csv files (issue 27): the touchlog fixture is read whole (its row
# counts printed), and a FIFO, a device or a folder in place of timeline.csv or truth.csv is
# refused with exit 2 naming the file, never opened for reading (a FIFO would block forever, a
# device such as /dev/zero would grow a line without bound). Each run has a timeout, so a reader
# that blocks on the FIFO fails this test instead of hanging it.
# -DPROGRAM=... -DDATA=<tests/data/touchlog> -DWORK=<scratch folder>
foreach(var PROGRAM DATA WORK)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "timeline_eval_inputs_test.cmake: -D${var}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE ${WORK})

# The fixture: the rows printed are the files' lines after the header.
file(MAKE_DIRECTORY ${WORK}/good)
configure_file(${DATA}/expected_timeline.csv ${WORK}/good/timeline.csv COPYONLY)
configure_file(${DATA}/expected_truth.csv ${WORK}/good/truth.csv COPYONLY)
file(STRINGS ${WORK}/good/timeline.csv timeline_lines)
file(STRINGS ${WORK}/good/truth.csv truth_lines)
list(LENGTH timeline_lines n_timeline)
list(LENGTH truth_lines n_truth)
math(EXPR n_timeline "${n_timeline} - 1")
math(EXPR n_truth "${n_truth} - 1")
execute_process(COMMAND ${PROGRAM} --input ${WORK}/good RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err TIMEOUT 60)
string(FIND "${out}" "sequences 1, timeline rows ${n_timeline}, truths ${n_truth} " at)
if(NOT rc STREQUAL "0" OR at EQUAL -1)
  message(FATAL_ERROR "fixture: expected exit 0 and 'sequences 1, timeline rows ${n_timeline}, "
                      "truths ${n_truth}'\n  exit: ${rc}\n  stdout: ${out}\n  stderr: ${err}")
endif()

# One bad input: `which` (timeline.csv or truth.csv) of folder `case` is made by `make`, the
# other file is the fixture's.
function(expect_refused case which)
  set(dir ${WORK}/${case})
  file(MAKE_DIRECTORY ${dir})
  foreach(f timeline truth)
    if(NOT f STREQUAL which)
      configure_file(${WORK}/good/${f}.csv ${dir}/${f}.csv COPYONLY)
    endif()
  endforeach()
  execute_process(COMMAND ${PROGRAM} --input ${dir} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err TIMEOUT 30)
  set(expect "${dir}/${which}.csv: not a regular file")
  string(FIND "${err}" "ss_timeline_eval: error: " at_prefix)
  string(FIND "${err}" "${expect}" at_expect)
  if(NOT rc STREQUAL "2" OR NOT at_prefix EQUAL 0 OR at_expect EQUAL -1)
    message(FATAL_ERROR "${case}: expected exit 2 and 'ss_timeline_eval: error: ...${expect}...' "
                        "on stderr\n  exit: ${rc}\n  stdout: ${out}\n  stderr: ${err}")
  endif()
endfunction()

file(MAKE_DIRECTORY ${WORK}/fifo)
execute_process(COMMAND mkfifo ${WORK}/fifo/timeline.csv RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "mkfifo ${WORK}/fifo/timeline.csv failed: ${rc}")
endif()
expect_refused(fifo timeline)

# /dev/null, not /dev/zero: the same refusal, and a reader that opened it would stop at once.
file(MAKE_DIRECTORY ${WORK}/device)
file(CREATE_LINK /dev/null ${WORK}/device/truth.csv SYMBOLIC)
expect_refused(device truth)

file(MAKE_DIRECTORY ${WORK}/folder/timeline.csv)
expect_refused(folder timeline)
