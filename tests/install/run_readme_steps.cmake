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
file(STRINGS ${gen}/cal/tracking/metadata.csv rows)
list(POP_FRONT rows header)
string(REPLACE "," ";" header "${header}")
set(box_columns shadow_x shadow_y shadow_w shadow_h contact_x contact_y contact_w contact_h)
foreach(column IN ITEMS file_name class ${box_columns})
  list(FIND header ${column} at_${column})
  if(at_${column} EQUAL -1)
    message(FATAL_ERROR "tracking metadata.csv has no '${column}' column: ${header}")
  endif()
endforeach()
file(MAKE_DIRECTORY ${WORK_DIR}/robot/empty ${WORK_DIR}/robot/touch)
string(REPLACE ";" "," labels "file;${box_columns}")
string(APPEND labels "\n")
set(empty_count 0)
set(touch_count 0)
foreach(row IN LISTS rows)
  string(REPLACE "," ";" row "${row}")
  list(GET row ${at_file_name} file)
  list(GET row ${at_class} class)
  get_filename_component(name ${file} NAME)
  if(class STREQUAL "nothing")
    file(COPY ${gen}/cal/tracking/${file} DESTINATION ${WORK_DIR}/robot/empty)
    math(EXPR empty_count "${empty_count} + 1")
  else()
    file(COPY ${gen}/cal/tracking/${file} DESTINATION ${WORK_DIR}/robot/touch)
    string(APPEND labels "${name}")
    foreach(column IN LISTS box_columns)
      list(GET row ${at_${column}} value)
      string(APPEND labels ",${value}")
    endforeach()
    string(APPEND labels "\n")
    math(EXPR touch_count "${touch_count} + 1")
  endif()
endforeach()
file(WRITE ${WORK_DIR}/robot/labels.csv "${labels}")
if(empty_count EQUAL 0 OR touch_count EQUAL 0)
  message(FATAL_ERROR "the tracking dataset gave ${empty_count} empty and ${touch_count} touch "
                      "frames")
endif()

# frames/: the first palm slide sequence.
file(GLOB sequence LIST_DIRECTORIES true ${gen}/slides/slides/*/palm_*)
list(SORT sequence)
list(GET sequence 0 sequence)
file(GLOB frames ${sequence}/*.png)
if(NOT frames)
  message(FATAL_ERROR "no slide frames under ${gen}/slides/slides")
endif()
file(COPY ${frames} DESTINATION ${WORK_DIR}/robot/frames)

# ----------------------------------------------------------------------------------- run them
string(REGEX MATCHALL "ss_[a-z_]+" named "${commands}")
list(REMOVE_DUPLICATES named)
set(script "set -e\n# every program the steps name must be the installed one\n")
foreach(program IN LISTS named)
  string(APPEND script
         "case \"$(command -v ${program})\" in \"${bin}/${program}\") ;; *) echo \"${program}: "
         "not found in ${bin}\" >&2; exit 1;; esac\n")
endforeach()
string(APPEND script "set -x\n${commands}")
file(WRITE ${WORK_DIR}/steps.sh "${script}")
execute_process(COMMAND env -i PATH=${bin}:/usr/bin HOME=${WORK_DIR} /bin/sh -e
                        ${WORK_DIR}/steps.sh
                WORKING_DIRECTORY ${WORK_DIR}/robot RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err TIMEOUT 600)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the README's steps failed (${rc}) in ${WORK_DIR}/robot:\n"
                      "${WORK_DIR}/steps.sh:\n${script}\nstdout:\n${out}\nstderr:\n${err}")
endif()
message(STATUS "${blocks} README block(s) in ${regions} region(s) ran with ${named} from ${bin} "
               "on ${empty_count} empty and ${touch_count} touch frames:\n${err}")
