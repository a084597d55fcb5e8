#!/bin/sh
# The generator hold-outs of the issue-21 validation protocol (docs/validation_protocol.md on
# branch handdata, "Sources"): g = users 0-5 plain (seed 1), hold = users 200-205 randomised
# (seed 3), 20 frames per gesture and lighting, at the pre-registered hand scales 0.6, 0.7, 1,
# 1.5, 2 (ss_gesture_data --scale-range S,S: the body S times larger in pixels; S = 1 is the
# unscaled set, byte for byte), each with its sessions' empty skin and calibrations
# (--empty-skin: empty_skin/, for calibrated input encodings; the frames are the same with or
# without it). A set whose metadata.csv and empty_skin/ exist is complete and kept.
#   sh models/make_scaled_holdouts.sh [BUILD_DIR] [OUT_DIR]
set -e
BUILD=${1:-build}
OUT=${2:-/work/hands-sets}
for s in 1 0.6 0.7 1.5 2; do
  [ -f "$OUT/g_s$s/metadata.csv" ] && [ -d "$OUT/g_s$s/empty_skin" ] ||
    "$BUILD/examples/ss_gesture_data" --out "$OUT/g_s$s" --overwrite --users 6 --frames 20 \
      --seed 1 --scale-range "$s,$s" --empty-skin >/dev/null
  [ -f "$OUT/hold_s$s/metadata.csv" ] && [ -d "$OUT/hold_s$s/empty_skin" ] ||
    "$BUILD/examples/ss_gesture_data" --out "$OUT/hold_s$s" --overwrite --users 6 \
      --first-user 200 --frames 20 --seed 3 --randomise --scale-range "$s,$s" --empty-skin \
      >/dev/null
  echo "scale $s: $OUT/g_s$s $OUT/hold_s$s"
done
