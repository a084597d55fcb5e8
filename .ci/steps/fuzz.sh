#!/bin/sh
# Fuzz every parser for a bounded time with libFuzzer + ASan/UBSan (clang from Debian): each
# fuzz/fuzz_<name>.cpp is built and run on its committed seeds fuzz/corpus/<name>/ (copied, so
# the run's new inputs stay out of the tree) for FUZZ_SECONDS (default 30) each. Keep the
# number of targets x FUZZ_SECONDS under ~5 minutes. A crash, leak, timeout or abort fails CI
# and leaves the reproducer in $FUZZ_BUILD_DIR/<name>/.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${FUZZ_BUILD_DIR:-$root/build-fuzz}
seconds=${FUZZ_SECONDS:-30}
cxx=$(command -v clang++-14 || command -v clang++ || true)
if [ -z "$cxx" ]; then
  echo "fuzz.sh: clang++ not found (apt-get install clang-14)" >&2
  exit 1
fi
opencv_cflags=$(pkg-config --cflags opencv4)
opencv_libs="-lopencv_imgcodecs -lopencv_imgproc -lopencv_core"
for src in "$root"/fuzz/fuzz_*.cpp; do
  name=$(basename "$src" .cpp)
  name=${name#fuzz_}
  work="$out/$name"
  mkdir -p "$work/corpus"
  if [ -d "$root/fuzz/corpus/$name" ]; then cp "$root/fuzz/corpus/$name"/* "$work/corpus/"; fi
  echo "== fuzz $name for ${seconds}s =="
  # shellcheck disable=SC2086
  "$cxx" -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
    -I"$root/include" $opencv_cflags "$src" -o "$work/fuzz_$name" $opencv_libs
  (cd "$work" && "./fuzz_$name" -max_total_time="$seconds" -max_len=300000 -rss_limit_mb=2048 \
    -timeout=10 -print_final_stats=1 corpus)
done
