#!/bin/sh
# Independent validation set smoke check: render a tiny realhand set (tools/realhand/render.py,
# real hand silhouettes from data/realhand) and check that the C++ dataset reader accepts all
# three parts: ss_eval_classify scores the gestures, ss_track_eval reads tracking and slides.
# Figures are not checked here (docs/validation_set.md reports them); this only guards the format.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${TRACK_EVAL_BIN_DIR:-$root/build/examples}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 "$root/tools/realhand/render.py" --out "$work/rh" --seed 3 --users 1 \
  --frames-per-user 1 --tracking-contact 2 --tracking-empty 2 --tracking-hover 2 --slides 8 --workers 2
"$bin/ss_eval_classify" --score "$root/models/default.ssm" --data "$work/rh/gestures" --quiet \
  --json "$work/score.json"
"$bin/ss_track_eval" --data "$work/rh" --calib-frames 20 --json "$work/track.json"
python3 - "$work/score.json" "$work/track.json" <<'PY'
import json, sys
s, t = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
print("realhand smoke: loaded", json.dumps(s)[:80], "...")
assert "table5" in t and "figure14" in t, "ss_track_eval output lacks table5/figure14"
PY
