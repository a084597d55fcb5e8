# tools/realhand/socialtouch_timeline.py on hand-made SocialTouch-format records
# (tests/data/socialtouch, 10 fps, 1 cm cells): a tap_light file with a repetition that lifts
# inside the record and one that ends in contact, an unmapped gesture (tickle_one_fix) and a
# mapped one without contact. The expected files were derived by hand from the recipe
# (docs/validation_protocol.md, "Issue 23 (third source)"). Then a repetition whose times do not
# increase and a file with a missing column must exit 2 naming the file.
# -DPYTHON=... -DSCRIPT=... -DDATA=... -DOUT=...
include(${CMAKE_CURRENT_LIST_DIR}/timeline_converter.cmake)
file(REMOVE_RECURSE ${OUT})
check_converter(${OUT}/good ${DATA}/expected_truth.csv ${DATA}/expected_timeline.csv
                "read 4\nmapped 2\nnot_mapped 1\nno_contact 1\n"
                --data ${DATA} --names ${DATA}/names.csv --fps 10)
file(READ ${DATA}/touch_p0_g0-fixture.csv raw)
file(MAKE_DIRECTORY ${OUT}/time)
string(REPLACE "0,0,1,2,180," "0,0,1,2,90," bad "${raw}")
file(WRITE ${OUT}/time/touch_p0_g0-fixture.csv "${bad}")
expect_converter_error(${OUT}/time_out
  "touch_p0_g0-fixture.csv line 7: the times of the repetition starting here must increase"
  --data ${OUT}/time --names ${DATA}/names.csv)
file(MAKE_DIRECTORY ${OUT}/columns)
string(REPLACE ",10\n" "\n" short "${raw}")
file(WRITE ${OUT}/columns/touch_p0_g0-fixture.csv "${short}")
expect_converter_error(${OUT}/columns_out "touch_p0_g0-fixture.csv"
                       --data ${OUT}/columns --names ${DATA}/names.csv)
