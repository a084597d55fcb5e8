# The installed CMake package and its components (find_package(shadowsense COMPONENTS ...)):
#   1. a library-only build (no programs) installed into WORK_DIR/prefix; tests/consumer builds
#      and runs against it and, asking for no component, sees shadowsense::shadowsense only;
#   2. COMPONENTS train loads io and train (not sim, eval); COMPONENTS eval loads all five;
#      an unknown component fails naming it;
#   3. a build configured without Eigen installs no train/eval: asking for them fails saying the
#      installation was built without them, while COMPONENTS io still works.
# Variables: SOURCE_DIR, WORK_DIR, GENERATOR.
include(${SOURCE_DIR}/tests/install/common.cmake)
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
# Installed without building: nothing compiled (no programs, no Python module).
set(lib_args -G ${GENERATOR} -DSHADOWSENSE_BUILD_TESTS=OFF -DSHADOWSENSE_BUILD_EXAMPLES=OFF
             -DSHADOWSENSE_BUILD_BENCH=OFF -DSHADOWSENSE_BUILD_PYTHON=OFF)
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/lib ${lib_args}
    -DCMAKE_INSTALL_PREFIX=${prefix})
run(${CMAKE_COMMAND} --install ${WORK_DIR}/lib)
set(consumer_args -S ${SOURCE_DIR}/tests/consumer -G ${GENERATOR})
run(${CMAKE_COMMAND} ${consumer_args} -B ${WORK_DIR}/consumer -DCMAKE_PREFIX_PATH=${prefix})
must_contain("${run_out}" "no components" "consumer: shadowsense targets: shadowsense\n")
run(${CMAKE_COMMAND} --build ${WORK_DIR}/consumer)
run(${WORK_DIR}/consumer/consumer)
must_contain("${run_out}" "consumer run" ", 0 events\n")

foreach(case IN ITEMS "train|shadowsense;io;train" "eval|shadowsense;io;sim;train;eval"
                      "sim|shadowsense;io;sim")
  string(REPLACE "|" ";" case "${case}")
  list(POP_FRONT case component)
  run(${CMAKE_COMMAND} ${consumer_args} -B ${WORK_DIR}/consumer_${component}
      -DCMAKE_PREFIX_PATH=${prefix} -DSHADOWSENSE_CONSUMER_COMPONENTS=${component})
  must_contain("${run_out}" "COMPONENTS ${component}" "consumer: shadowsense targets: ${case}\n")
endforeach()
must_fail("unknown component 'wings'" ${CMAKE_COMMAND} ${consumer_args}
          -B ${WORK_DIR}/consumer_wings -DCMAKE_PREFIX_PATH=${prefix}
          -DSHADOWSENSE_CONSUMER_COMPONENTS=wings)

# An installation built without Eigen.
set(prefix_no_eigen ${WORK_DIR}/prefix_no_eigen)
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/lib_no_eigen ${lib_args}
    -DCMAKE_DISABLE_FIND_PACKAGE_Eigen3=ON -DCMAKE_INSTALL_PREFIX=${prefix_no_eigen})
must_contain("${run_out}" "configure without Eigen" "Eigen 3.3+ not found: skipping")
run(${CMAKE_COMMAND} --install ${WORK_DIR}/lib_no_eigen)
run(${CMAKE_COMMAND} ${consumer_args} -B ${WORK_DIR}/consumer_no_eigen
    -DCMAKE_PREFIX_PATH=${prefix_no_eigen} -DSHADOWSENSE_CONSUMER_COMPONENTS=io)
must_contain("${run_out}" "no-Eigen install, COMPONENTS io"
             "consumer: shadowsense targets: shadowsense;io\n")
foreach(component IN ITEMS train eval)
  must_fail("component (train|eval): this installation was built without it"
            ${CMAKE_COMMAND} ${consumer_args} -B ${WORK_DIR}/consumer_no_eigen_${component}
            -DCMAKE_PREFIX_PATH=${prefix_no_eigen} -DSHADOWSENSE_CONSUMER_COMPONENTS=${component})
endforeach()
message(STATUS "find_package: the runtime alone by default; components load their dependencies")
