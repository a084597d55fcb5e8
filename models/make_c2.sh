#!/bin/sh
# Reproduces models/candidates/c2.ssm, candidate C2 of issue 21 ("hands we have never seen"):
# the C0 recipe (models/make_c0.sh: same users, seeds, frames, architecture
# and training) with the body drawn at a pixel scale log-uniform in [0.6, 2] per gesture block
# (ss_gesture_data --scale-range 0.6,2: Scene::zoom about the gesture's anchor, the hands,
# arms, shadow shifts and penumbrae seen 0.6x to 2x as large; docs/scene_generator.md) - that
# is C1 (models/make_c1.sh) - and real hand shapes mixed in: each hand of a palm, punch,
# two_hands and hug frame is, with probability 0.5, a real hand silhouette of the rps source's
# train split (ss_gesture_data --hands: 535 open hands and 523 fists, CC BY-SA 4.0, made by
# tools/handsets/extract_rps.py, committed as data/hands/rps; its heldout split and the epsrc source are
# validation only), placed, lifted and shadowed by the generator's renderer. rps has no
# pointing hands: point frames keep the parametric hands.
# About 35-40 minutes of one core, 5 of them data.
#   sh models/make_c2.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
set -e
BUILD=${1:-build}
WORK=${2:-/tmp/shadowsense-c2}
SRC=$(cd "$(dirname "$0")/.." && pwd)
OUT=${3:-$SRC/models/candidates/c2.ssm}
HANDS=${4:-$SRC/data/hands/rps}
SCALE="--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5"
"$BUILD/examples/ss_gesture_data" --out "$WORK/randomised" --overwrite --users 12 \
  --first-user 100 --frames 12 --seed 2 --randomise $SCALE
"$BUILD/examples/ss_gesture_data" --out "$WORK/randomised2" --overwrite --users 12 \
  --first-user 124 --frames 12 --seed 2 --randomise $SCALE
"$BUILD/examples/ss_gesture_data" --out "$WORK/plain" --overwrite --users 12 --first-user 112 \
  --frames 12 --seed 2 $SCALE
rm -rf "$WORK/mixed"
mkdir -p "$WORK/mixed" "$(dirname "$OUT")"
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
/usr/bin/python3 "$SRC/tools/train.py" "$WORK/mixed" -o "$OUT" \
  --mode scratch --growth-rate 12 --block-config 4 4 4 --init-features 24 \
  --resize 160 88 --crop 0 0 --lighting-normalise --augment --augment-geometry --seed 0 \
  --threads 1 --classes nothing,hug,palm,point,punch,two_hands
