# Runs the README's "Your own robot" commands verbatim with the installed programs.
#
# The commands are every ```sh block between "<!-- readme-steps:begin ... -->" and
# "<!-- readme-steps:end ... -->" in README.md (several marked regions allowed), in order, with the
# list indentation of the fences removed. They run as one `set -e` shell script in a fresh
# folder with PATH=<PREFIX>/bin:/usr/bin only, on generated frames prepared under the file
# names the README uses:
#   empty/            empty-skin frames (the generator's "nothing" tracking frames)
#   touch/ labels.csv hands on and over the skin, with the generator's shadow and contact boxes
#                     as the labels (file,shadow_x,...,contact_h)
#   frames/           one generated slide sequence (a palm sliding over the skin)
#   gestures/         gesture frames of one generated user, class-per-folder (dataset format)
#   gestures_test/    gesture frames of another user
# The script first checks that every ss_* program it names resolves to <PREFIX>/bin. The test
# fails when a command fails, when no marked block exists, or when the data cannot be made.
# Variables: SOURCE_DIR, PREFIX, BINDIR, WORK_DIR; README (default SOURCE_DIR/README.md).
include(${CMAKE_CURRENT_LIST_DIR}/common.cmake)
if(NOT README)
  set(README ${SOURCE_DIR}/README.md)
endif()
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR}/robot ${WORK_DIR}/generated)
set(bin ${PREFIX}/${BINDIR})

# ---------------------------------------------------------------- the README's marked commands
# Read line by line with ';' and '\' masked (CMake lists split at ';' and '\' escapes it).
file(READ ${README} text)
string(REPLACE "\\" "<BACKSLASH>" text "${text}")
string(REPLACE ";" "<SEMICOLON>" text "${text}")
string(REPLACE "\n" ";" lines "${text}")
set(in_region OFF)
set(in_block OFF)
set(commands "")
set(blocks 0)
set(regions 0)
foreach(line IN LISTS lines)
  if(line MATCHES "^ *<!-- readme-steps:begin")
    set(in_region ON)
    math(EXPR regions "${regions} + 1")
  elseif(line MATCHES "^ *<!-- readme-steps:end")
    set(in_region OFF)
  elseif(in_region AND NOT in_block AND line MATCHES "^( *)```sh *$")
    set(in_block ON)
    string(LENGTH "${CMAKE_MATCH_1}" indent)
    math(EXPR blocks "${blocks} + 1")
  elseif(in_block AND line MATCHES "^ *``` *$")
    set(in_block OFF)
  elseif(in_block)
    string(LENGTH "${line}" length)
    if(length GREATER_EQUAL indent)
      string(SUBSTRING "${line}" ${indent} -1 line)
    endif()
    string(REPLACE "<BACKSLASH>" "\\" line "${line}")
    string(REPLACE "<SEMICOLON>" ";" line "${line}")
    string(APPEND commands "${line}\n")
  endif()
endforeach()
if(in_region OR in_block)
  message(FATAL_ERROR "${README}: a readme-steps region or ```sh block is not closed")
endif()
if(blocks EQUAL 0)
  message(FATAL_ERROR "${README}: no ```sh block between <!-- readme-steps:begin --> and "
                      "<!-- readme-steps:end -->")
endif()

# -------------------------------------------------------------------- the data the steps use
set(gen ${WORK_DIR}/generated)
run(${bin}/ss_synth --out ${gen}/cal --dataset tracking --tracking-per-category 12 --seed 2)
run(${bin}/ss_synth --out ${gen}/slides --dataset slides --slides-per-combination 1 --seed 3)
run(${bin}/ss_gesture_data --out ${WORK_DIR}/robot/gestures --users 1 --first-user 0 --frames 4
    --seed 1)
run(${bin}/ss_gesture_data --out ${WORK_DIR}/robot/gestures_test --users 1 --first-user 1
    --frames 2 --seed 1)

# empty/, touch/ and labels.csv from the tracking dataset's metadata (the boxes are exact).
# recorded/: what the robot owner records, as a dataset folder (the empty skin in nothing/, the
# touches with their two boxes in metadata.csv): the generator's tracking dataset.
file(COPY ${gen}/cal/tracking/ DESTINATION ${WORK_DIR}/robot/recorded)
file(GLOB empty_frames ${WORK_DIR}/robot/recorded/nothing/*.png)
file(STRINGS ${WORK_DIR}/robot/recorded/metadata.csv rows)
list(LENGTH empty_frames empty_count)
list(LENGTH rows touch_count)
math(EXPR touch_count "${touch_count} - 1 - ${empty_count}")
if(empty_count EQUAL 0 OR touch_count LESS_EQUAL 0)
  message(FATAL_ERROR "the tracking dataset gave ${empty_count} empty and ${touch_count} touch "
                      "frames")
endif()

file(GLOB sequence LIST_DIRECTORIES true ${gen}/slides/slides/*/palm_*)
list(SORT sequence)
list(GET sequence 0 sequence)
file(GLOB frames ${sequence}/*.png)
if(NOT frames)
  message(FATAL_ERROR "no slide frames under ${gen}/slides/slides")
endif()
file(COPY ${frames} DESTINATION ${WORK_DIR}/robot/session)

# ----------------------------------------------------------------------------------- run them
string(REGEX MATCHALL "ss_[a-z_]+" named "${commands}")
list(REMOVE_DUPLICATES named)
set(script "set -e\n# every program the steps name must be the installed one\n")
foreach(program IN LISTS named)
  string(APPEND script
         "case \"$(command -v ${program})\" in \"${bin}/${program}\") ;; *) echo \"${program}: "
         "not found in ${bin}\" >&2; exit 1;; esac\n")
endforeach()
# TUIO goes to port 3333: liblo's oscdump (Debian liblo-tools) decodes it into tuio.txt.
string(APPEND script "oscdump -L 3333 > ${WORK_DIR}/tuio.txt 2>&1 &\ndump=$!\nsleep 0.3\n")
string(APPEND script "set -x\n${commands}")
string(APPEND script "set +x\nsleep 0.5\nkill $dump\n")
file(WRITE ${WORK_DIR}/steps.sh "${script}")
execute_process(COMMAND env -i PATH=${bin}:/usr/bin HOME=${WORK_DIR} /bin/sh -e
                        ${WORK_DIR}/steps.sh
                WORKING_DIRECTORY ${WORK_DIR}/robot RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err TIMEOUT 600)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the README's steps failed (${rc}) in ${WORK_DIR}/robot:\n"
                      "${WORK_DIR}/steps.sh:\n${script}\nstdout:\n${out}\nstderr:\n${err}")
endif()
# Events with gestures, in the event schema, as CSV, as JSON lines and over TUIO.
file(STRINGS ${WORK_DIR}/robot/events.csv csv_rows)
list(POP_FRONT csv_rows csv_header)
file(READ ${SOURCE_DIR}/include/shadowsense/output/event_sink.hpp sink_header)
string(REGEX MATCH "event_csv_header =[^;]*;" schema_text "${sink_header}")
string(REGEX MATCHALL "\"[^\"]*\"" schema_parts "${schema_text}")
string(REPLACE "\"" "" schema_parts "${schema_parts}")
string(REPLACE ";" "" expected_header "${schema_parts}")
if(NOT csv_header STREQUAL expected_header)
  message(FATAL_ERROR "events.csv: header '${csv_header}' is not the event schema "
                      "'${expected_header}'")
endif()
string(REPLACE "," ";" columns "${csv_header}")
list(FIND columns to at_to)
list(FIND columns gesture at_gesture)
set(with_gesture 0)
foreach(row IN LISTS csv_rows)
  string(REPLACE "," ";" fields "${row}")
  list(GET fields ${at_to} to)
  list(GET fields ${at_gesture} gesture)
  if(to STREQUAL "touch" AND NOT gesture STREQUAL "")
    math(EXPR with_gesture "${with_gesture} + 1")
  endif()
endforeach()
if(with_gesture EQUAL 0)
  message(FATAL_ERROR "events.csv has no touch event with a gesture:\n${csv_rows}")
endif()
file(READ ${WORK_DIR}/robot/events.jsonl jsonl)
must_contain("${jsonl}" "events.jsonl" "\"source\":\"session/\",")
string(REGEX MATCH "\"to\":\"touch\",[^\n]*\"gesture\":\"[a-z_]+\"" json_touch "${jsonl}")
if(NOT json_touch)
  message(FATAL_ERROR "events.jsonl has no touch event with a gesture:\n${jsonl}")
endif()
file(READ ${WORK_DIR}/tuio.txt tuio)
must_contain("${tuio}" "tuio.txt (oscdump)" "/tuio/2Dcur")
must_contain("${tuio}" "tuio.txt (oscdump)" "/tuio/2Dblb")
string(REGEX MATCH "/shadowsense/gesture sfi(sf)+ \"[a-z_]+\"" tuio_gesture "${tuio}")
if(NOT tuio_gesture)
  message(FATAL_ERROR "no /shadowsense/gesture message with a label over TUIO:\n${tuio}")
endif()
message(STATUS "${blocks} README block(s) in ${regions} region(s) ran with ${named} from ${bin} "
               "on ${empty_count} empty and ${touch_count} touch frames:\n${err}")
