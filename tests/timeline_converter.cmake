# What the contact-timeline converters' fixture tests share (cost_, socialtouch_ and
# touchlog_timeline_test.cmake); include() it after setting PYTHON and SCRIPT.
# check_converter(OUT EXPECTED_TRUTH EXPECTED_TIMELINE SUMMARY_REGEX ARGS...): runs the converter
#   with ARGS and --out OUT; requires exit 0, truth.csv and timeline.csv byte-equal to the
#   expected files, and the summary it prints matching SUMMARY_REGEX.
# expect_converter_error(OUT ERROR_REGEX ARGS...): requires exit 2 and stderr matching.
function(check_converter out expected_truth expected_timeline summary_regex)
  execute_process(COMMAND ${PYTHON} ${SCRIPT} ${ARGN} --out ${out}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE stdout ERROR_VARIABLE stderr)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "converter failed (${rc}): ${stderr}")
  endif()
  foreach(f truth timeline)
    execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${out}/${f}.csv
                            ${expected_${f}} RESULT_VARIABLE diff)
    if(NOT diff EQUAL 0)
      message(FATAL_ERROR "${out}/${f}.csv differs from ${expected_${f}}")
    endif()
  endforeach()
  if(NOT stdout MATCHES "${summary_regex}")
    message(FATAL_ERROR "unexpected summary: ${stdout}")
  endif()
endfunction()

function(expect_converter_error out error_regex)
  execute_process(COMMAND ${PYTHON} ${SCRIPT} ${ARGN} --out ${out}
                  RESULT_VARIABLE rc ERROR_VARIABLE stderr)
  if(NOT rc EQUAL 2 OR NOT stderr MATCHES "${error_regex}")
    message(FATAL_ERROR "expected exit 2 and '${error_regex}', got ${rc}: ${stderr}")
  endif()
endfunction()
