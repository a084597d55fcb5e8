#!/bin/sh
# The benchmarks are out of the default build (bench/CMakeLists.txt): build them here in the
# README build's folder, so they keep compiling, and run the fastest one once as a smoke check.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
cmake --build "$root/build" -j2 --target benchmarks
"$root/build/bench/bench_temporal" --benchmark-samples 2 >/dev/null
echo "benchmarks built; bench_temporal ran"
