# tools/realhand/socialtouch_timeline.py on hand-made SocialTouch-format records
# (tests/data/socialtouch, 10 fps, 1 cm cells): a tap_light file with a repetition that lifts
# inside the record and one that ends in contact, an unmapped gesture (tickle_one_fix) and a
# mapped one without contact. The expected files were derived by hand from the recipe
# (docs/validation_protocol.md, "Issue 23 (third source)"). Then a repetition whose times do not
# increase and a file with a missing column must exit 2 naming the file.
# -DPYTHON=... -DSCRIPT=... -DDATA=... -DOUT=...
file(REMOVE_RECURSE ${OUT})
execute_process(COMMAND ${PYTHON} ${SCRIPT} --data ${DATA} --names ${DATA}/names.csv
                        --out ${OUT}/good --fps 10
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
if(NOT out MATCHES "read 4\nmapped 2\nnot_mapped 1\nno_contact 1\n")
  message(FATAL_ERROR "unexpected counts: ${out}")
endif()
file(READ ${DATA}/touch_p0_g0-fixture.csv raw)
file(MAKE_DIRECTORY ${OUT}/time)
string(REPLACE "0,0,1,2,180," "0,0,1,2,90," bad "${raw}")
file(WRITE ${OUT}/time/touch_p0_g0-fixture.csv "${bad}")
execute_process(COMMAND ${PYTHON} ${SCRIPT} --data ${OUT}/time --names ${DATA}/names.csv
                        --out ${OUT}/time_out RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 2 OR NOT err MATCHES "touch_p0_g0-fixture.csv line 7: the times of the repetition starting here must increase")
  message(FATAL_ERROR "non-increasing time: expected exit 2 naming line 7, got ${rc}: ${err}")
endif()
file(MAKE_DIRECTORY ${OUT}/columns)
string(REPLACE ",10\n" "\n" short "${raw}")
file(WRITE ${OUT}/columns/touch_p0_g0-fixture.csv "${short}")
execute_process(COMMAND ${PYTHON} ${SCRIPT} --data ${OUT}/columns --names ${DATA}/names.csv
                        --out ${OUT}/columns_out RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 2 OR NOT err MATCHES "touch_p0_g0-fixture.csv")
  message(FATAL_ERROR "missing column: expected exit 2 naming the file, got ${rc}: ${err}")
endif()
