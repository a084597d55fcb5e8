#!/bin/sh
# The benchmarks are out of the default build (bench/CMakeLists.txt): build them here in the
# README build's folder, so they keep compiling, and run the fastest ones once as a smoke check:
# bench_temporal, and roofline at tiny sizes (a few seconds) replacing the marked table of a
# scratch document, whose text around the markers must survive.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
cmake --build "$root/build" -j2 --target benchmarks
"$root/build/bench/bench_temporal" --benchmark-samples 2 >/dev/null
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
echo "benchmarks built; bench_temporal and roofline ran"
