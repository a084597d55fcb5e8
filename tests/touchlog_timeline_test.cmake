# tools/realhand/touchlog_timeline.py on a hand-made BioIdent-format record (tests/data/touchlog:
# two clicks 150 ms apart on one track -> one tap truth, a 2 cm stroke after a gap shortened to
# 2 s, a stray move after a lift; 254 dpi so 100 px = 1 cm). The expected files were checked row
# by row against the recipe (docs/validation_protocol.md, "Issue 23 (second source)").
# Then a bad action code must exit 2 naming the line.
# -DPYTHON=... -DSCRIPT=... -DDATA=... -DOUT=...
file(REMOVE_RECURSE ${OUT})
execute_process(COMMAND ${PYTHON} ${SCRIPT} --bioident ${DATA} --out ${OUT}/good --fps 30
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "converter failed (${rc}): ${err}")
endif()
foreach(f truth timeline)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/good/${f}.csv
                          ${DATA}/expected_${f}.csv RESULT_VARIABLE diff)
  if(NOT diff EQUAL 0)
    message(FATAL_ERROR "${f}.csv differs from ${DATA}/expected_${f}.csv")
  endif()
endforeach()
if(NOT out MATCHES "1 samples without a touch-down")
  message(FATAL_ERROR "the stray move was not reported: ${out}")
endif()
file(MAKE_DIRECTORY ${OUT}/bad)
file(COPY ${DATA}/devices.csv DESTINATION ${OUT}/bad)
file(READ ${DATA}/rawdata.csv raw)
string(REPLACE "1,7,1,5050,2," "1,7,1,5050,3," raw "${raw}")
file(WRITE ${OUT}/bad/rawdata.csv "${raw}")
execute_process(COMMAND ${PYTHON} ${SCRIPT} --bioident ${OUT}/bad --out ${OUT}/bad_out
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 2 OR NOT err MATCHES "rawdata.csv line 8: action must be 0, 1 or 2, got 3")
  message(FATAL_ERROR "bad action: expected exit 2 naming line 8, got ${rc}: ${err}")
endif()
