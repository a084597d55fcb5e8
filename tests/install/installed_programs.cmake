# The installed programs run from <PREFIX>/bin alone: PATH is <PREFIX>/bin plus /usr/bin (for
# the shell), nothing from the build or source tree.
#   - every program (one per examples/*.cpp) answers --version by its bare name;
#   - the --help of ss_classify, ss_train_head and ss_eval_classify names the installed model
#     (<PREFIX>/<DATADIR>/shadowsense/models/default.ssm) as their default;
#   - a copy of ss_classify outside the prefix finds no model and says where it looked: beside
#     itself only, never the source tree;
#   - $SHADOWSENSE_MODEL overrides the default, and naming a missing file is an error naming it.
# Variables: SOURCE_DIR, PREFIX, BINDIR, DATADIR, WORK_DIR, VERSION.
include(${CMAKE_CURRENT_LIST_DIR}/common.cmake)
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(path "${PREFIX}/${BINDIR}:/usr/bin")
set(installed_model "${PREFIX}/${DATADIR}/shadowsense/models/default.ssm")
# A program by its bare name, found through PATH by the shell, with a clean environment.
macro(installed)
  run(${CMAKE_COMMAND} -E env --unset=SHADOWSENSE_MODEL PATH=${path} /bin/sh -c "${ARGN}")
endmacro()

shadowsense_program_names(programs ${SOURCE_DIR})
foreach(program IN LISTS programs)
  installed("command -v ${program}")
  if(NOT run_out STREQUAL "${PREFIX}/${BINDIR}/${program}\n")
    message(FATAL_ERROR "${program} resolves to '${run_out}', not the prefix's")
  endif()
  installed("${program} --version")
  if(NOT run_out STREQUAL "${program} shadowsense ${VERSION}\n")
    message(FATAL_ERROR "${program} --version: got '${run_out}'")
  endif()
endforeach()

foreach(program IN ITEMS ss_classify ss_train_head ss_eval_classify)
  installed("${program} --help")
  string(REGEX REPLACE "\n +" " " help "${run_out}") # undo the help text's line wrapping
  must_contain("${help}" "${program} --help" "the installed model (${installed_model})")
endforeach()

# A copy outside any prefix: no model beside it, and the source tree is not looked at.
file(MAKE_DIRECTORY ${WORK_DIR}/elsewhere/bin ${WORK_DIR}/frames)
file(COPY ${PREFIX}/${BINDIR}/ss_classify DESTINATION ${WORK_DIR}/elsewhere/bin)
execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=SHADOWSENSE_MODEL
                        ${WORK_DIR}/elsewhere/bin/ss_classify ${WORK_DIR}/frames
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 2)
  message(FATAL_ERROR "ss_classify without a model: expected exit 2, got ${rc}\n${err}")
endif()
must_contain("${err}" "ss_classify without a model"
  "looked at ${WORK_DIR}/elsewhere/share/shadowsense/models/default.ssm (the installed model);")
must_not_contain("${err}" "ss_classify without a model" "${SOURCE_DIR}/models")
must_not_contain("${err}" "ss_classify without a model" "source tree")

# $SHADOWSENSE_MODEL: used when set, an error naming it when its file is missing.
run(${CMAKE_COMMAND} -E env SHADOWSENSE_MODEL=${installed_model} PATH=${path}
    /bin/sh -c "ss_classify --help")
must_contain("${run_out}" "ss_classify --help with SHADOWSENSE_MODEL"
             "$SHADOWSENSE_MODEL (${installed_model})")
execute_process(COMMAND ${CMAKE_COMMAND} -E env SHADOWSENSE_MODEL=${WORK_DIR}/missing.ssm
                        PATH=${path} /bin/sh -c "ss_classify ${WORK_DIR}/frames"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 2)
  message(FATAL_ERROR "ss_classify with a missing SHADOWSENSE_MODEL: expected exit 2, got ${rc}")
endif()
must_contain("${err}" "ss_classify with a missing SHADOWSENSE_MODEL"
             "looked at ${WORK_DIR}/missing.ssm ($SHADOWSENSE_MODEL);")
list(LENGTH programs n)
message(STATUS "${n} installed programs run from ${PREFIX}/${BINDIR} alone")
