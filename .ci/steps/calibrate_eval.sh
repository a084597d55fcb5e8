#!/bin/sh
# Calibration from box labels (issue 9 item 1): ss_calibrate on 12 empty + 48 box-labelled
# generator frames (seed 2, labels = the dataset's boxes), then ss_track_eval with that file on
# the paper-size tracking dataset (seed 1): the Table 5 targets of track_eval.sh must still hold,
# with no phantom shadow on the empty frames and no phantom contact on hovering hands.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${TRACK_EVAL_BIN_DIR:-$root/build/examples}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$bin/ss_synth" --out "$work/cal" --dataset tracking --tracking-per-category 12 --seed 2 >/dev/null
"$bin/ss_synth" --out "$work/data" --dataset tracking --paper-sizes --seed 1 >/dev/null
# The dataset's own boxes; its nothing/ frames are the empty skin (docs/calibration.md).
"$bin/ss_calibrate" --empty "$work/cal/tracking/nothing" --touch "$work/cal/tracking" \
  --out "$work/skin.calib"
"$bin/ss_track_eval" --tracking "$work/data/tracking" --calibration "$work/skin.calib" \
  --json "$work/eval.json"
python3 - "$work/eval.json" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))["table5"]
fails = []
def need(ok, what):
    print(("ok   " if ok else "MISS ") + what)
    if not ok: fails.append(what)
for c in ("palm", "fist", "finger"):
    need(t[c]["shadow"]["iou_mean"] >= 0.93, f"{c} shadow IoU {t[c]['shadow']['iou_mean']:.3f} >= 0.93")
    need(t[c]["contact"]["iou_mean"] >= 0.85, f"{c} contact IoU {t[c]['contact']['iou_mean']:.3f} >= 0.85")
need(t["hover"]["shadow"]["iou_mean"] >= 0.85, f"hover shadow IoU {t['hover']['shadow']['iou_mean']:.3f} >= 0.85")
need(t["nothing"]["shadow"]["false_positives"] == 0, "no phantom shadow on the empty frames")
need(t["nothing"]["contact"]["false_positives"] == 0, "no phantom contact on the empty frames")
need(t["hover"]["contact"]["false_positives"] == 0, "no phantom contact on hovering hands")
sys.exit(1 if fails else 0)
PY
