#!/bin/sh
# Fuzz the model-file loader for a bounded time with libFuzzer + ASan/UBSan (clang from
# Debian). Seeds: the committed model fixtures. FUZZ_SECONDS overrides the 60 s budget.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${FUZZ_BUILD_DIR:-$root/build-fuzz}
seconds=${FUZZ_SECONDS:-60}
cxx=$(command -v clang++-14 || command -v clang++ || true)
if [ -z "$cxx" ]; then
  echo "fuzz.sh: clang++ not found (apt-get install clang-14)" >&2
  exit 1
fi
mkdir -p "$out/corpus"
cp "$root"/tests/data/*.ssdn "$out/corpus/" 2>/dev/null || true
"$cxx" -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
  -I"$root/include" "$root/fuzz/fuzz_model_file.cpp" -o "$out/fuzz_model_file"
"$out/fuzz_model_file" -max_total_time="$seconds" -max_len=300000 -rss_limit_mb=2048 \
  -timeout=10 -print_final_stats=1 "$out/corpus"
