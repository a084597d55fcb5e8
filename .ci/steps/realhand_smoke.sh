#!/bin/sh
# Independent validation set smoke check: render a tiny realhand set (tools/realhand/render.py,
# real hand silhouettes from data/realhand) and check that the C++ dataset reader accepts all
# three parts: ss_eval_classify scores the gestures, ss_track_eval reads tracking and slides.
# Figures are not checked here (docs/validation_set.md reports them); this only guards the format.
# Also the empty skin of the gesture sessions (render.py --only empty_skin, what
# tools/realhand/score.sh calibrates for skin_relative models): three frames per session, the
# gesture frames unchanged, ss_calibrate --empty accepts them, and a colour model's score is the
# same with --session-calibrations.
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
sums() { find "$work/rh/gestures" -path '*empty_skin*' -prune -o -type f -print | sort | xargs cat | cksum; }
before=$(sums)
/usr/bin/python3 "$root/tools/realhand/render.py" --out "$work/rh" --seed 3 --users 1 --only empty_skin
[ "$(sums)" = "$before" ] || { echo "render.py --only empty_skin changed the gesture frames" >&2; exit 1; }
for lighting in daylight dusk night; do
  mkdir "$work/$lighting"
  for k in 0 1 2; do
    f="$work/rh/gestures/empty_skin/u0_${lighting}_$k.png"
    [ -s "$f" ] || { echo "missing $f" >&2; exit 1; }
    ln "$f" "$work/$lighting/"
  done
  "$bin/ss_calibrate" --empty "$work/$lighting" --out "$work/rh/gestures/empty_skin/u0_$lighting.calib" >/dev/null
done
"$bin/ss_eval_classify" --score "$root/models/default.ssm" --data "$work/rh/gestures" --quiet \
  --session-calibrations --json "$work/score_sessions.json"
cmp "$work/score.json" "$work/score_sessions.json"
python3 - "$work/score.json" "$work/track.json" <<'PY'
import json, sys
s, t = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
print("realhand smoke: loaded", json.dumps(s)[:80], "...")
assert "table5" in t and "figure14" in t, "ss_track_eval output lacks table5/figure14"
PY
