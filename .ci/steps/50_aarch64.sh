#!/usr/bin/env bash
# aarch64 under emulation: cross-compile the GEMM/DenseNet kernel tests (tests/test_gemm.cpp:
# DenseNet headers + doctest only, no OpenCV, no Python) with Debian's cross toolchain,
# statically linked, and run them under qemu-user. They compare the NEON, portable and
# reference kernels with each other and, on the committed fixtures tests/data/*.ssdn, with
# torchvision's logits, at the same tolerances as on x86. The segmenter's per-row kernels
# (tests/test_segment_kernels.cpp: NEON against portable, byte for byte and float for float) and
# tests/test_int8.cpp (the int8 GEMM kernels against their reference, exactly, and the int8
# forward) and tests/test_channel_sums.cpp (the lighting normalisation's byte sums, NEON against
# a plain loop) are built into the same program. Only this subset runs under
# emulation (the other tests need OpenCV/Eigen for aarch64 and are covered natively on x86).
# Built at -O2 and again at -O3 (the portable kernel must vectorise and be right at both).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${AARCH64_BUILD_DIR:-$root/build-aarch64}
export DEBIAN_FRONTEND=noninteractive

packages=(g++-aarch64-linux-gnu qemu-user doctest-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "installing: ${missing[*]}" >&2
  sudo_cmd=(); [[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# doctest is header-only: give the cross compiler that header alone, not the host's
# /usr/include.
mkdir -p "$out/include"
cp -r /usr/include/doctest "$out/include/"

for opt in O2 O3; do
  exe="$out/test_gemm_$opt"
  echo "== aarch64 -$opt: building $exe =="
  aarch64-linux-gnu-g++ -std=c++20 "-$opt" -Wall -Wextra -Wpedantic -Werror -static \
    -I"$root/include" -I"$out/include" \
    -DSHADOWSENSE_TEST_DATA_DIR="\"$root/tests/data\"" \
    "$root/tests/test_gemm.cpp" "$root/tests/test_segment_kernels.cpp" \
    "$root/tests/test_int8.cpp" "$root/tests/test_channel_sums.cpp" \
    "$root/tests/doctest_main.cpp" -o "$exe"
  echo "== aarch64 -$opt: running under qemu-aarch64 =="
  QEMU_LD_PREFIX=/usr/aarch64-linux-gnu qemu-aarch64 "$exe" --success=false
done
