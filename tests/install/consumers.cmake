# The runtime without Eigen: consumers of shadowsense::shadowsense built with Eigen hidden.
#   1. find_package from the installed PREFIX, with find_package(Eigen3) disabled
#      (CMAKE_DISABLE_FIND_PACKAGE_Eigen3): configures, sees only shadowsense::shadowsense, builds
#      and runs; no compile command mentions eigen3; and tests/consumer/uses_eigen.cpp, which
#      includes <Eigen/Core>, must then FAIL to build for want of Eigen/Core: no Eigen include
#      path reaches the consumer.
#   2. pkg-config (PREFIX's shadowsense.pc): the flags hold no eigen3, main.cpp builds and runs,
#      uses_eigen.cpp fails the same way.
#   3. add_subdirectory of the source tree with Eigen disabled: configures with a STATUS message
#      naming what was skipped, only the runtime, io and sim targets exist, builds and runs;
#      uses_eigen.cpp fails the same way.
# Variables: SOURCE_DIR, PREFIX, DATADIR, WORK_DIR, GENERATOR, CXX, LAUNCHER (may be empty).
include(${CMAKE_CURRENT_LIST_DIR}/common.cmake)
file(REMOVE_RECURSE ${WORK_DIR})
set(consumer_dir ${SOURCE_DIR}/tests/consumer)
set(no_eigen -DCMAKE_DISABLE_FIND_PACKAGE_Eigen3=ON)
set(common_args -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_EXPORT_COMPILE_COMMANDS=ON)
if(LAUNCHER)
  list(APPEND common_args -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()
set(eigen_missing "Eigen/Core: No such file or directory|Eigen/Core' file not found")

# Configures, builds and runs one consumer; checks the targets it saw and its compile commands.
function(consumer name expected_targets)
  set(dir ${WORK_DIR}/${name})
  run(${CMAKE_COMMAND} -S ${consumer_dir} -B ${dir} ${common_args} ${no_eigen} ${ARGN})
  must_contain("${run_out}" "${name}: configure"
               "consumer: shadowsense targets: ${expected_targets}\n")
  set(configure_output "${run_out}" PARENT_SCOPE)
  run(${CMAKE_COMMAND} --build ${dir})
  file(READ ${dir}/compile_commands.json commands)
  must_contain("${commands}" "${name}: compile commands" "consumer")
  must_not_contain("${commands}" "${name}: compile commands" "eigen3")
  run(${dir}/consumer)
  must_contain("${run_out}" "${name}: run" ", 0 events\n")
  set(neg ${WORK_DIR}/${name}_uses_eigen)
  run(${CMAKE_COMMAND} -S ${consumer_dir} -B ${neg} ${common_args} ${no_eigen} ${ARGN}
      -DSHADOWSENSE_CONSUMER_SOURCE=uses_eigen.cpp)
  must_fail("${eigen_missing}" ${CMAKE_COMMAND} --build ${neg})
  message(STATUS "${name}: builds without Eigen; <Eigen/Core> is out of its reach")
endfunction()

consumer(find_package shadowsense -DCMAKE_PREFIX_PATH=${PREFIX})
# Asking for a component that needs Eigen fails, naming the missing dependency.
must_fail("Eigen3" ${CMAKE_COMMAND} -S ${consumer_dir} -B ${WORK_DIR}/find_package_train
          ${common_args} ${no_eigen} -DCMAKE_PREFIX_PATH=${PREFIX}
          -DSHADOWSENSE_CONSUMER_COMPONENTS=train)

consumer(subdirectory "shadowsense;io;sim" -DSHADOWSENSE_CONSUMER_MODE=subdirectory
         -DSHADOWSENSE_SOURCE_DIR=${SOURCE_DIR})
must_contain("${configure_output}" "subdirectory: configure"
             "shadowsense: Eigen 3.3+ not found: skipping shadowsense::train, shadowsense::eval")

find_program(PKG_CONFIG pkg-config)
if(NOT PKG_CONFIG)
  message(FATAL_ERROR "pkg-config not found (Debian: pkg-config); it checks shadowsense.pc")
endif()
set(ENV{PKG_CONFIG_PATH} ${PREFIX}/${DATADIR}/pkgconfig)
run(${PKG_CONFIG} --cflags shadowsense)
string(STRIP "${run_out}" cflags)
run(${PKG_CONFIG} --libs shadowsense)
string(STRIP "${run_out}" libs)
must_contain("${cflags}" "pkg-config --cflags shadowsense" "-I${PREFIX}/")
must_not_contain("${cflags} ${libs}" "pkg-config flags" "eigen3")
must_not_contain("${libs}" "pkg-config --libs" "imgcodecs")
separate_arguments(cflags UNIX_COMMAND "${cflags}")
separate_arguments(libs UNIX_COMMAND "${libs}")
file(MAKE_DIRECTORY ${WORK_DIR}/pkg-config)
run(${CXX} ${cflags} ${consumer_dir}/main.cpp -o ${WORK_DIR}/pkg-config/consumer ${libs})
run(${WORK_DIR}/pkg-config/consumer)
must_contain("${run_out}" "pkg-config consumer: run" ", 0 events\n")
must_fail("${eigen_missing}" ${CXX} ${cflags} -c ${consumer_dir}/uses_eigen.cpp
          -o ${WORK_DIR}/pkg-config/uses_eigen.o)
message(STATUS "pkg-config: builds without Eigen; <Eigen/Core> is out of its reach")
