#!/bin/sh
# Reproduces models/candidates/c0.ssm, the gesture model shipped until 2026-11-25 (candidate C0
# of docs/validation_protocol.md; docs/classification_eval.md). The shipped model is now C2
# (models/make_default.sh runs models/make_c2.sh).
# Data: the scene generator's gesture sessions of 36 users, none of them evaluation users (those
# are 0-5 for ss_eval_classify and 200-205 for the randomised hold-out): users 100-111 and
# 124-135 with domain randomisation (ss_gesture_data --randomise: fabric, light colour, exposure,
# lens, noise, hand shapes, press depth, hug body size, ...; docs/scene_generator.md) and users
# 112-123 without it, daylight, dusk and night, 12 frames per gesture, merged into one dataset
# folder (hard links, one metadata.csv).
# Model: compact DenseNet (growth 12, blocks 4-4-4, 24 initial features), 160x88 input,
# lighting normalisation + lighting and geometric augmentation, the paper's recipe (Adam 1e-3,
# batch 16, 20 epochs, best epoch on the last 30% of every session x gesture block). About 35
# minutes of one core, 5 of them data.
#   sh models/make_c0.sh [BUILD_DIR] [WORK_DIR]
set -e
BUILD=${1:-build}
WORK=${2:-/tmp/shadowsense-default}
SRC=$(cd "$(dirname "$0")/.." && pwd)
"$BUILD/examples/ss_gesture_data" --out "$WORK/randomised" --overwrite --users 12 \
  --first-user 100 --frames 12 --seed 2 --randomise
"$BUILD/examples/ss_gesture_data" --out "$WORK/randomised2" --overwrite --users 12 \
  --first-user 124 --frames 12 --seed 2 --randomise
"$BUILD/examples/ss_gesture_data" --out "$WORK/plain" --overwrite --users 12 --first-user 112 \
  --frames 12 --seed 2
rm -rf "$WORK/mixed"
mkdir -p "$WORK/mixed"
for c in nothing hug palm point punch two_hands; do
  mkdir "$WORK/mixed/$c"
  ln "$WORK/randomised/$c/"*.png "$WORK/randomised2/$c/"*.png "$WORK/plain/$c/"*.png \
    "$WORK/mixed/$c/"
done
{
  cat "$WORK/randomised/metadata.csv"
  tail -n +2 "$WORK/randomised2/metadata.csv"
  tail -n +2 "$WORK/plain/metadata.csv"
} >"$WORK/mixed/metadata.csv"
/usr/bin/python3 "$SRC/tools/train.py" "$WORK/mixed" -o "$SRC/models/candidates/c0.ssm" \
  --mode scratch --growth-rate 12 --block-config 4 4 4 --init-features 24 \
  --resize 160 88 --crop 0 0 --lighting-normalise --augment --augment-geometry --seed 0 \
  --threads 1 --classes nothing,hug,palm,point,punch,two_hands
