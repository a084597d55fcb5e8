#!/bin/sh
# Training round trip (issue 5): generate a small gesture folder, train a tiny DenseNet with
# tools/train.py (scratch, then transfer from that model file), load both in C++ (the embedded
# self-test compares the C++ forward pass with PyTorch's logits), score them with
# ss_eval_classify --score, train a head on-device with ss_train_head, and check that the shipped
# model still reaches its documented accuracy on a fresh sample of unseen users.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${TRAIN_SMOKE_BIN_DIR:-$root/build/examples}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$bin/ss_gesture_data" --out "$work/data" --users 2 --frames 6 --seed 9
/usr/bin/python3 "$root/tools/train.py" "$work/data" -o "$work/tiny.ssm" --mode scratch \
  --growth-rate 4 --block-config 2 2 --init-features 8 --resize 80 44 --epochs 2 \
  --lighting-normalise --classes nothing,hug,palm,point,punch,two_hands
/usr/bin/python3 "$root/tools/train.py" "$work/data" -o "$work/transfer.ssm" --mode transfer \
  --backbone "$work/tiny.ssm" --epochs 2 --lighting-normalise \
  --classes nothing,hug,palm,point,punch,two_hands
"$bin/ss_eval_classify" --score "$work/tiny.ssm" --data "$work/data" --lighting-normalise
"$bin/ss_eval_classify" --score "$work/transfer.ssm" --data "$work/data" --lighting-normalise
"$bin/ss_train_head" --model "$work/tiny.ssm" --data "$work/data" --out "$work/head.ssm" \
  --epochs 3 --lighting-normalise
"$bin/ss_eval_classify" --score "$work/head.ssm" --data "$work/data" --lighting-normalise
# The few-shot options: no validation share, augmented copies, balanced batches, fine-tuning.
"$bin/ss_train_head" --model "$work/tiny.ssm" --data "$work/data" --out "$work/fewshot.ssm" \
  --users 0 --epochs 2 --val-fraction 0 --augment 2 --balanced --standardise --fine-tune \
  --anchor 0.1 --lighting-normalise
"$bin/ss_eval_classify" --score "$work/fewshot.ssm" --data "$work/data" --lighting-normalise
status=0
"$bin/ss_train_head" --model "$work/tiny.ssm" --data "$work/data" --out "$work/bad.ssm" \
  --anchor -1 2>/dev/null || status=$?
test "$status" -eq 2 && test ! -e "$work/bad.ssm"
# The shipped model on users it never saw (documented: 100% on users 0-5, seed 1).
"$bin/ss_gesture_data" --out "$work/eval" --users 2 --frames 10 --seed 1
"$bin/ss_eval_classify" --score "$root/models/default.ssm" --data "$work/eval" \
  --json "$work/score.json"
/usr/bin/python3 - "$work/score.json" <<'PY'
import json, sys
acc = json.load(open(sys.argv[1]))["accuracy"]["all"]
print(f"shipped model accuracy on unseen users: {acc:.4f}")
sys.exit(0 if acc >= 0.90 else 1)
PY
# A calibrated input encoding (docs/input_encodings.md): per-session empty-skin calibrations in
# the dataset, a tiny skin_relative model (format version 4) loaded and scored in C++ with a
# calibration, and refused without one (exit 2, naming the model and --calibration).
"$bin/ss_gesture_data" --out "$work/skin" --users 1 --frames 2 --seed 9 --empty-skin
/usr/bin/python3 "$root/tools/train.py" "$work/skin" -o "$work/skin.ssm" --mode scratch \
  --growth-rate 4 --block-config 2 --init-features 8 --resize 80 44 --epochs 1 \
  --input-encoding skin_relative --classes nothing,hug,palm,point,punch,two_hands
cal=$(ls "$work/skin/empty_skin/"*.calib | head -n 1)
"$bin/ss_eval_classify" --score "$work/skin.ssm" --data "$work/skin" --calibration "$cal"
status=0
"$bin/ss_eval_classify" --score "$work/skin.ssm" --data "$work/skin" 2>"$work/err.txt" || status=$?
test "$status" -eq 2 && grep -q "needs --calibration FILE" "$work/err.txt"
# An encoding the library's own segmenter makes (darkness_contact: train.py encodes through the
# Python module's InputEncoder), trained on the same folder, loaded (the embedded self-test) and
# scored in C++ with each session's calibration.
py="$bin/../python"
[ -d "$py/shadowsense" ] || { echo "train_smoke: $py/shadowsense not built" >&2; exit 1; }
PYTHONPATH="$py" /usr/bin/python3 "$root/tools/train.py" "$work/skin" -o "$work/contact.ssm" \
  --mode scratch --growth-rate 4 --block-config 2 --init-features 8 --resize 80 44 --epochs 1 \
  --input-encoding darkness_contact --contrast 1 --classes nothing,hug,palm,point,punch,two_hands
"$bin/ss_eval_classify" --score "$work/contact.ssm" --data "$work/skin" --session-calibrations
