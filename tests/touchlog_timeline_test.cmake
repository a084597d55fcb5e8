# tools/realhand/touchlog_timeline.py on a hand-made BioIdent-format record (tests/data/touchlog:
# two clicks 150 ms apart on one track -> one tap truth, a 2 cm stroke after a gap shortened to
# 2 s, a stray move after a lift; 254 dpi so 100 px = 1 cm). The expected files were checked row
# by row against the recipe (docs/validation_protocol.md, "Issue 23 (second source)").
# Then a bad action code must exit 2 naming the line.
# -DPYTHON=... -DSCRIPT=... -DDATA=... -DOUT=...
include(${CMAKE_CURRENT_LIST_DIR}/timeline_converter.cmake)
file(REMOVE_RECURSE ${OUT})
check_converter(${OUT}/good ${DATA}/expected_truth.csv ${DATA}/expected_timeline.csv
                "1 samples without a touch-down" --bioident ${DATA} --fps 30)
file(MAKE_DIRECTORY ${OUT}/bad)
file(COPY ${DATA}/devices.csv DESTINATION ${OUT}/bad)
file(READ ${DATA}/rawdata.csv raw)
string(REPLACE "1,7,1,5050,2," "1,7,1,5050,3," raw "${raw}")
file(WRITE ${OUT}/bad/rawdata.csv "${raw}")
expect_converter_error(${OUT}/bad_out "rawdata.csv line 8: action must be 0, 1 or 2, got 3"
                       --bioident ${OUT}/bad)
