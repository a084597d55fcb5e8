# Compiles tests/firmware/firmware_main.cpp with only the runtime's include paths and lists every
# header it opens (-H); fails when a header outside the runtime is in the closure.
# Then compiles tests/firmware/classifier_alone.cpp: classify/classifier.hpp alone must not
# declare the DenseNet backend.
# Variables: CXX, SOURCE_DIR, OPENCV_INCLUDE_DIRS (;-list).
set(args -std=c++20 -fsyntax-only -H -I${SOURCE_DIR}/include)
set(opencv_args "")
foreach(dir IN LISTS OPENCV_INCLUDE_DIRS)
  list(APPEND opencv_args -I${dir})
endforeach()
list(APPEND args ${opencv_args})
execute_process(COMMAND ${CXX} ${args} ${SOURCE_DIR}/tests/firmware/firmware_main.cpp
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE headers)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the runtime umbrella does not compile with the runtime's include paths "
                      "alone (OpenCV core/imgproc, no Eigen):\n${headers}")
endif()
set(forbidden "/shadowsense/sim/" "/shadowsense/train/" "/shadowsense/io/" "/shadowsense/eval/"
    "/Eigen/" "/eigen3/" "imgcodecs" "videoio" "highgui")
set(bad "")
string(REPLACE "\n" ";" lines "${headers}")
set(count 0)
foreach(line IN LISTS lines)
  if(line MATCHES "^\\.+ ")
    math(EXPR count "${count} + 1")
    foreach(f IN LISTS forbidden)
      string(FIND "${line}" "${f}" at)
      if(NOT at EQUAL -1)
        string(APPEND bad "  ${line}\n")
      endif()
    endforeach()
  endif()
endforeach()
if(count EQUAL 0)
  message(FATAL_ERROR "the compiler listed no headers (-H output missing):\n${headers}")
endif()
if(bad)
  message(FATAL_ERROR "the runtime umbrella pulls in headers outside the runtime:\n${bad}")
endif()
message(STATUS "include closure: ${count} headers, none outside the runtime")

execute_process(COMMAND ${CXX} -std=c++20 -fsyntax-only -I${SOURCE_DIR}/include ${opencv_args}
                        ${SOURCE_DIR}/tests/firmware/classifier_alone.cpp
                RESULT_VARIABLE rc ERROR_VARIABLE errors)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "classify/classifier.hpp alone declares the DenseNet backend (or does not "
                      "compile):\n${errors}")
endif()
message(STATUS "classify/classifier.hpp alone: no DenseNet backend declared")
