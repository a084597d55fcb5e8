#!/bin/sh
# The threading tests under ThreadSanitizer: a SHADOWSENSE_SANITIZE=thread build of
# tests/test_threads.cpp (separate instances in separate threads, the owner check, racing
# atomic writes). OpenCV's own thread pool is not instrumented, so OpenCV runs single-threaded
# here (OPENCV_FOR_THREADS_NUM=1) and reports from inside libopencv are suppressed.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${TSAN_BUILD_DIR:-$root/build-tsan}
cmake -S "$root" -B "$out" -G Ninja -DSHADOWSENSE_SANITIZE=thread -DSHADOWSENSE_WERROR=ON \
  -DSHADOWSENSE_BUILD_BENCH=OFF -DSHADOWSENSE_BUILD_EXAMPLES=OFF >/dev/null
# tests/test_threads.cpp is built in the tests_runtime group (tests/CMakeLists.txt).
cmake --build "$out" -j2 --target tests_runtime
supp="$out/tsan.supp"
# OpenCV's thread-local storage unlocks its mutex from the thread-exit destructor.
printf 'called_from_lib:libopencv_core.so\ncalled_from_lib:libopencv_imgproc.so\nmutex:nptl_deallocate_tsd\n' >"$supp"
OPENCV_FOR_THREADS_NUM=1 TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$supp" \
  "$out/tests/tests_runtime" --source-file="*/test_threads.cpp"
