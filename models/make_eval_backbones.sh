#!/bin/sh
# Reproduces the classification evaluation of docs/classification_eval.md: evaluation data
# (users 0-5), backbone data (users 100-111, disjoint people), the evaluation backbones, and
# the tables with and without lighting normalisation.
#   sh models/make_eval_backbones.sh [BUILD_DIR] [WORK_DIR]
# Backbones (compact DenseNet growth 8, blocks 3-3-3, init 16, 160x88 input), each trained by
# tools/train.py on users 100-105 of the backbone data for 10 epochs:
#   all.ssm            all three lightings            (Tables 1, 2: never saw users 0-5)
#   no_<L>.ssm         every lighting except L        (Table 3, test lighting L: never saw L)
#   only_<L>.ssm       lighting L only                (Table 4, trained on L: saw nothing else)
# in WORK/models_norm (lighting normalisation + augmentation) and WORK/models_plain (the paper's
# preprocessing): the with/without comparison at equal budget. Headline: Tables 1 and 2 with
# models/default.ssm (users 100-111, 20 epochs) as backbone; Tables 3 and 4 with WORK/models_full
# (no_/only_ backbones with the full recipe: all of users 100-111, 20 epochs, normalisation +
# augmentation).
set -e
BUILD=${1:-build}
WORK=${2:-/tmp/shadowsense-eval}
SRC=$(cd "$(dirname "$0")/.." && pwd)
[ -f "$WORK/gestures/metadata.csv" ] || "$BUILD/examples/ss_gesture_data" --out "$WORK/gestures" \
  --users 6 --frames 20 --seed 1
[ -f "$WORK/backbone/metadata.csv" ] || "$BUILD/examples/ss_gesture_data" --out "$WORK/backbone" \
  --users 12 --first-user 100 --frames 12 --seed 2
train() { # flags, folder, name, selection...
  flags=$1 dir=$2 name=$3
  shift 3
  users="--users 100,101,102,103,104,105 --epochs 10"
  [ "$dir" = models_full ] && users=""
  mkdir -p "$WORK/$dir"
  [ -f "$WORK/$dir/$name.ssm" ] || /usr/bin/python3 "$SRC/tools/train.py" "$WORK/backbone" \
    -o "$WORK/$dir/$name.ssm" --mode scratch --growth-rate 8 --block-config 3 3 3 \
    --init-features 16 --resize 160 88 --crop 0 0 $flags --seed 0 \
    $users --classes nothing,hug,palm,point,punch,two_hands "$@" > "$WORK/$dir/$name.log"
}
for variant in norm plain full; do
  if [ $variant = plain ]; then F=""; else F="--lighting-normalise --augment"; fi
  [ $variant = full ] || train "$F" models_$variant all
  for L in daylight dusk night; do
    train "$F" models_$variant no_$L --exclude-lightings $L
    train "$F" models_$variant only_$L --lightings $L
  done
done
"$BUILD/examples/ss_eval_classify" --data "$WORK/gestures" --backbone "$WORK/models_norm/all.ssm" \
  --backbone-dir "$WORK/models_norm" --lighting-normalise --json "$WORK/eval_norm.json" \
  --confusion-dir "$WORK/confusion_norm"
"$BUILD/examples/ss_eval_classify" --data "$WORK/gestures" --backbone "$WORK/models_plain/all.ssm" \
  --backbone-dir "$WORK/models_plain" --json "$WORK/eval_plain.json" \
  --confusion-dir "$WORK/confusion_plain"
"$BUILD/examples/ss_eval_classify" --data "$WORK/gestures" --backbone "$SRC/models/default.ssm" \
  --backbone-dir "$WORK/models_full" --lighting-normalise --json "$WORK/eval_default.json" \
  --confusion-dir "$WORK/confusion_default"
"$BUILD/examples/ss_eval_classify" --score "$SRC/models/default.ssm" --data "$WORK/gestures" \
  --lighting-normalise --json "$WORK/score_default.json"
