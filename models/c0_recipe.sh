#!/bin/sh
# The C0 recipe (models/make_c0.sh says what it is and why), shared by the candidates built on it
# (models/make_c0.sh, make_c1.sh, make_c2.sh): the scene generator's gesture sessions of users
# 100-111 and 124-135 with domain randomisation and 112-123 without, 12 frames per gesture, merged
# into one dataset folder (hard links, one metadata.csv), then the compact DenseNet trained on it.
# DATA_FLAGS: more ss_gesture_data options for all three sessions (one word-split string, e.g.
# "--scale-range 0.6,2"; empty for C0 itself). TRAIN_FLAGS: more tools/train.py options (e.g.
# "--input-encoding skin_relative"; empty for C0-C2). The sessions' empty_skin/ folders
# (ss_gesture_data --empty-skin) are merged too when they exist. USERS (environment, default 12):
# users per session; the sessions then hold users 100.., 100+2*USERS.. (randomised) and
# 100+USERS.. (plain), which for 12 are the users above. LIGHTING (environment, default
# --lighting-normalise): the training's lighting option; empty for an encoding that takes none
# (darkness_warmth).
#   sh models/c0_recipe.sh BUILD_DIR WORK_DIR OUT [DATA_FLAGS [TRAIN_FLAGS]]
set -e
BUILD=$1
WORK=$2
OUT=$3
DATA_FLAGS=$4
TRAIN_FLAGS=${5:-}
USERS=${USERS:-12}
LIGHTING=${LIGHTING---lighting-normalise}
SRC=$(cd "$(dirname "$0")/.." && pwd)
"$BUILD/examples/ss_gesture_data" --out "$WORK/randomised" --overwrite --users "$USERS" \
  --first-user 100 --frames 12 --seed 2 --randomise $DATA_FLAGS
"$BUILD/examples/ss_gesture_data" --out "$WORK/randomised2" --overwrite --users "$USERS" \
  --first-user $((100 + 2 * USERS)) --frames 12 --seed 2 --randomise $DATA_FLAGS
"$BUILD/examples/ss_gesture_data" --out "$WORK/plain" --overwrite --users "$USERS" \
  --first-user $((100 + USERS)) --frames 12 --seed 2 $DATA_FLAGS
rm -rf "$WORK/mixed"
mkdir -p "$WORK/mixed" "$(dirname "$OUT")"
for c in nothing hug palm point punch two_hands; do
  mkdir "$WORK/mixed/$c"
  ln "$WORK/randomised/$c/"*.png "$WORK/randomised2/$c/"*.png "$WORK/plain/$c/"*.png \
    "$WORK/mixed/$c/"
done
if [ -d "$WORK/plain/empty_skin" ]; then
  mkdir "$WORK/mixed/empty_skin"
  ln "$WORK/randomised/empty_skin/"* "$WORK/randomised2/empty_skin/"* "$WORK/plain/empty_skin/"* \
    "$WORK/mixed/empty_skin/"
fi
{
  cat "$WORK/randomised/metadata.csv"
  tail -n +2 "$WORK/randomised2/metadata.csv"
  tail -n +2 "$WORK/plain/metadata.csv"
} >"$WORK/mixed/metadata.csv"
/usr/bin/python3 "$SRC/tools/train.py" "$WORK/mixed" -o "$OUT" \
  --mode scratch --growth-rate 12 --block-config 4 4 4 --init-features 24 \
  --resize 160 88 --crop 0 0 $LIGHTING --augment --augment-geometry --seed 0 \
  --threads 1 --classes nothing,hug,palm,point,punch,two_hands $TRAIN_FLAGS
