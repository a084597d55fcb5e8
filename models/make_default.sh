#!/bin/sh
# Reproduces models/default.ssm, the shipped compact gesture model (docs/classification_eval.md).
# Data: the scene generator's gesture sessions of users 100-111 (disjoint from the evaluation
# users 0-5 that ss_eval_classify scores on), daylight, dusk and night, 12 frames per gesture.
# Model: compact DenseNet (growth 8, blocks 3-3-3, 16 initial features), 160x88 input,
# lighting normalisation + lighting augmentation, the paper's recipe (Adam 1e-3, batch 16,
# 20 epochs, best epoch on the last 30% of every session x gesture block).
#   sh models/make_default.sh [BUILD_DIR] [WORK_DIR]
set -e
BUILD=${1:-build}
WORK=${2:-/tmp/shadowsense-default}
SRC=$(cd "$(dirname "$0")/.." && pwd)
"$BUILD/examples/ss_gesture_data" --out "$WORK/backbone" --overwrite --users 12 --first-user 100 \
  --frames 12 --seed 2
/usr/bin/python3 "$SRC/tools/train.py" "$WORK/backbone" -o "$SRC/models/default.ssm" \
  --mode scratch --growth-rate 8 --block-config 3 3 3 --init-features 16 \
  --resize 160 88 --crop 0 0 --lighting-normalise --augment --seed 0 \
  --classes nothing,hug,palm,point,punch,two_hands
