#!/bin/sh
# Tracking regression check (issue 3 targets): render the paper-size tracking and slides
# datasets with ss_synth (seed 1), run ss_track_eval on them (calibrated on generator frames of
# another seed) and fail if a target is missed. Uses the binaries of the README build (build/).
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${TRACK_EVAL_BIN_DIR:-$root/build/examples}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$bin/ss_synth" --out "$work/data" --dataset tracking --paper-sizes --seed 1
"$bin/ss_synth" --out "$work/data" --dataset slides --paper-sizes --seed 1
"$bin/ss_track_eval" --data "$work/data" --json "$work/eval.json"
python3 - "$work/eval.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
t, f = r["table5"], r["figure14"]
fails = []
def need(ok, what):
    print(("ok   " if ok else "MISS ") + what)
    if not ok: fails.append(what)
for c in ("palm", "fist", "finger"):
    need(t[c]["shadow"]["iou_mean"] >= 0.93, f"{c} shadow IoU {t[c]['shadow']['iou_mean']:.3f} >= 0.93")
    need(t[c]["contact"]["iou_mean"] >= 0.85, f"{c} contact IoU {t[c]['contact']['iou_mean']:.3f} >= 0.85")
need(t["hover"]["shadow"]["iou_mean"] >= 0.85, f"hover shadow IoU {t['hover']['shadow']['iou_mean']:.3f} >= 0.85")
for c in ("hover", "palm", "fist", "finger"):
    for k in ("shadow", "contact"):
        s = t[c][k]
        if s["truth"] == 0: continue
        need(s["tracking_error_rate"] <= 0.01, f"{c} {k} tracking error {s['tracking_error_rate']:.3f} <= 0.01")
        for a in ("x", "y"):
            m = s[f"error_{a}_cm_mean"]
            need(abs(m) <= 0.2, f"{c} {k} |mean error {a}| {abs(m):.3f} cm <= 0.2")
need(t["nothing"]["shadow"]["false_positives"] == 0, "no shadow false positives on nothing")
need(t["nothing"]["contact"]["false_positives"] == 0, "no contact false positives on nothing")
acc = f["overall"]["accuracy"]
need(acc[2] >= 0.9, f"direction accuracy at ratio 0.3: {acc[2]:.3f} >= 0.9")
need(acc[9] >= 0.99, f"direction accuracy at ratio 1.0: {acc[9]:.3f} >= 0.99")
sys.exit(1 if fails else 0)
PY
