#!/bin/sh
# The benchmarks are out of the default build (bench/CMakeLists.txt): build them here in the
# README build's folder, so they keep compiling, and run the fastest ones once as a smoke check:
# bench_temporal, the command lines of frame_time, roofline and thread_scaling, thread_scaling
# once at a tiny size, and roofline at tiny sizes (a few seconds) replacing the marked table of
# a scratch document, whose text around the markers must survive.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
cmake --build "$root/build" -j2 --target benchmarks
"$root/build/bench/bench_temporal" --benchmark-samples 2 >/dev/null
# frame_time and roofline parse their options as the programs do: the programs' command-line
# check (--help, --version, a bad flag, bad numbers; tests/programs_cli_test.cmake).
version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' "$root/build/CMakeCache.txt")
for timer in frame_time roofline; do
  cmake -DPROGRAM="$root/build/bench/$timer" -DNUMERIC_OPTION=--frames -DVERSION="$version" \
    -P "$root/tests/programs_cli_test.cmake"
done
cmake -DPROGRAM="$root/build/bench/thread_scaling" -DNUMERIC_OPTION=--rounds \
  -DVERSION="$version" -P "$root/tests/programs_cli_test.cmake"
# thread_scaling once at a tiny size (DenseNet-121 on 32 x 32, one round): it runs, and its
# JSON has the summary (the figures mean nothing here). It needs two CPUs.
if [ "$(nproc)" -ge 2 ]; then
  "$root/build/bench/thread_scaling" --height 32 --width 32 --rounds 1 --passes 1 --json |
    grep -q '"far": {"rounds": '
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf 'before\n<!-- roofline:begin -->\nold table\n<!-- roofline:end -->\nafter\n' >"$tmp/roofline.md"
"$root/build/bench/roofline" --model "$root/models/default.ssm" --frames 2 --rounds 1 \
  --dram-mb 8 --out "$tmp/roofline.md" 2>/dev/null
test "$(head -n 1 "$tmp/roofline.md")" = before
test "$(tail -n 1 "$tmp/roofline.md")" = after
grep -q '^| \*\*frame (whole)\*\* |' "$tmp/roofline.md"
if grep -q 'old table' "$tmp/roofline.md"; then
  echo "roofline --out kept the old table" >&2
  exit 1
fi
echo "benchmarks built; bench_temporal, thread_scaling and roofline ran; frame_time, roofline and thread_scaling command lines checked"
