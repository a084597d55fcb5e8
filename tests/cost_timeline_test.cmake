# tools/realhand/cost_timeline.py on a hand-made CoST.csv (tests/data/cost/CoST_fixture.csv:
# subject 1, variant normal: a tap pressing cell 1 then cells 1 and 2, a hit pressing cell 64 for
# one 135 Hz frame, a grab (not mapped) and a pat that stays below the threshold), at 30 and 240
# fps. The expected files are the converter's output at the commit that added this test; every
# truth row and every contact row was checked by hand against the recipe
# (docs/validation_protocol.md, "Issue 23: independent real timing"): at 240 fps the tap's
# contacts (266.80, 186.80, 231.0) then (274.40, 186.80, 462.1) and the hit's (373.20, 293.20),
# at 30 fps only the tap's first (the hit's 7 ms contact falls between frames). Then a file with
# a missing column must exit 2 naming the file.
# -DPYTHON=... -DSCRIPT=... -DDATA=... -DOUT=...
include(${CMAKE_CURRENT_LIST_DIR}/timeline_converter.cmake)
file(REMOVE_RECURSE ${OUT})
foreach(fps 30 240)
  check_converter(${OUT}/fps${fps} ${DATA}/expected_truth_${fps}fps.csv
                  ${DATA}/expected_timeline_${fps}fps.csv
                  "read 4\nmapped 2\nnot_mapped 1\nno_contact 1\nfps ${fps}\n"
                  --cost ${DATA}/CoST_fixture.csv --fps ${fps})
endforeach()
file(READ ${DATA}/CoST_fixture.csv raw)
string(REGEX REPLACE ",[0-9]+\n" "\n" short "${raw}")
file(MAKE_DIRECTORY ${OUT}/columns)
file(WRITE ${OUT}/columns/CoST.csv "${short}")
expect_converter_error(${OUT}/columns_out "CoST.csv: 67 columns, CoST.csv has 68"
                       --cost ${OUT}/columns/CoST.csv)
