#!/bin/sh
# Contact vs hover ROC on generator frames (docs/tracking_eval.md "Contact vs hover ROC"): the
# shipped rule (darkness AND warmth) must keep separating hovering hands from contacts - AUC
# 1.000, no contact on a hover and every contact found at the shipped thresholds - and the ROC
# file must hold every variant's curve from (1, 1) to (0, 0).
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${TRACK_EVAL_BIN_DIR:-$root/build/examples}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$bin/ss_synth" --out "$work/data" --dataset tracking --tracking-per-category 60 --seed 1 >/dev/null
"$bin/ss_track_eval" --tracking "$work/data/tracking" --roc "$work/roc.csv" --json "$work/eval.json"
python3 - "$work/eval.json" "$work/roc.csv" <<'PY'
import csv, json, sys
r = json.load(open(sys.argv[1]))["contact_roc"]
rows = list(csv.DictReader(open(sys.argv[2])))
fails = []
def need(ok, what):
    print(("ok   " if ok else "MISS ") + what)
    if not ok: fails.append(what)
j = r["variants"]["darkness_and_warmth"]
need(j["auc"] >= 0.999, f"shipped rule AUC {j['auc']:.4f} >= 0.999")
need(j["shipped_fpr"] == 0, f"no contact on the {r['negatives']} hovering hands ({j['shipped_fpr']:.3f})")
need(j["shipped_tpr"] == 1, f"every contact found ({j['shipped_tpr']:.3f})")
for v in r["variants"]:
    pts = [(float(x["fpr"]), float(x["tpr"])) for x in rows if x["variant"] == v]
    need(pts[0] == (1.0, 1.0) and pts[-1] == (0.0, 0.0), f"{v}: curve from (1, 1) to (0, 0)")
    need(sum(x["shipped"] == "1" for x in rows if x["variant"] == v) == 1, f"{v}: one shipped point")
sys.exit(1 if fails else 0)
PY
