# Builds tests/firmware/no_exceptions.cpp with -fno-exceptions against the runtime's include
# paths and OpenCV core + imgproc, then runs it on MODEL (exit 0) and on a missing model (the
# program's own error handler: exit 3 and the library's message naming the file).
# Variables: CXX, SOURCE_DIR, WORK_DIR, MODEL, OPENCV_INCLUDE_DIRS (;-list), OPENCV_LIBS (files).
file(MAKE_DIRECTORY ${WORK_DIR})
set(args -std=c++20 -O1 -fno-exceptions -I${SOURCE_DIR}/include)
foreach(dir IN LISTS OPENCV_INCLUDE_DIRS)
  list(APPEND args -I${dir})
endforeach()
execute_process(COMMAND ${CXX} ${args} ${SOURCE_DIR}/tests/firmware/no_exceptions.cpp
                        ${OPENCV_LIBS} -pthread -o ${WORK_DIR}/no_exceptions
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the runtime does not compile with -fno-exceptions:\n${err}")
endif()
execute_process(COMMAND ${WORK_DIR}/no_exceptions ${MODEL}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "frame 3: 1 shadow\\(s\\), gesture '[a-z_]+'")
  message(FATAL_ERROR "no_exceptions on ${MODEL}: exit ${rc}\n${out}${err}")
endif()
execute_process(COMMAND ${WORK_DIR}/no_exceptions ${WORK_DIR}/missing.ssm
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 3 OR NOT err MATCHES "shadowsense error: .*missing\\.ssm")
  message(FATAL_ERROR "no_exceptions on a missing model: expected the handler (exit 3) naming "
                      "the file, got exit ${rc}\n${out}${err}")
endif()
message(STATUS "-fno-exceptions: built and ran; ${out}${err}")
