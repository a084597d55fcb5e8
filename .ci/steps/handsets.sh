#!/bin/sh
# Real hand sources (docs/hand_sources.md, docs/validation_protocol.md): the silhouette
# normalisation on synthetic hands with known answers, then a tiny render of the committed epsrc
# silhouettes at 1.5x (a source without fists: punch must be absent) scored through
# tools/realhand/score.sh, the rps heldout split, and the emoji silhouettes (every class
# rendered), the silentink silhouettes (palm and point, no punch);
# tools/handsets/test_extract_emoji.py checks the emoji (and silentink) extractor. Figures are not
# checked here; this guards the formats and the tools.
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${TRACK_EVAL_BIN_DIR:-$root/build/examples}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 "$root/tools/handsets/test_handsil.py"
/usr/bin/python3 "$root/tools/handsets/test_extract_emoji.py"
/usr/bin/python3 "$root/tools/realhand/render.py" --out "$work/epsrc_s1.5" \
  --hands "$root/data/hands/epsrc" --scale 1.5 --seed 3 --users 1 --frames-per-user 1 \
  --only gestures --workers 2
/usr/bin/python3 "$root/tools/realhand/render.py" --out "$work/rps" --hands "$root/data/hands/rps" \
  --split heldout --seed 3 --users 1 --frames-per-user 1 --only gestures --workers 2
out=$(TRACK_EVAL_BIN_DIR="$bin" sh "$root/tools/realhand/score.sh" --model "$root/models/default.ssm" \
  --source epsrc --scale 1.5 --valsets "$work")
echo "$out"
echo "$out" | grep -q "^epsrc x1.5: all .*(.*/15); .*punch -;" || {
  echo "handsets: unexpected score.sh output" >&2; exit 1; }
"$bin/ss_eval_classify" --score "$root/models/default.ssm" --data "$work/rps/gestures" --quiet \
  --json "$work/rps.json" >/dev/null
# The committed emoji silhouettes (palm, point, punch) render into every class.
/usr/bin/python3 "$root/tools/realhand/render.py" --out "$work/emoji" --hands "$root/data/hands/emoji" \
  --seed 3 --users 1 --frames-per-user 1 --only gestures --workers 2
for c in nothing hug palm point punch two_hands; do
  cut -d, -f2 "$work/emoji/gestures/metadata.csv" | grep -qx "$c" || {
    echo "handsets: emoji rendered no '$c' frame" >&2; exit 1; }
done
# The committed silentink silhouettes (palm, point; no fist) render palm and point, no punch.
/usr/bin/python3 "$root/tools/realhand/render.py" --out "$work/silentink" \
  --hands "$root/data/hands/silentink" --seed 3 --users 1 --frames-per-user 1 --only gestures \
  --workers 2
for c in palm point; do
  cut -d, -f2 "$work/silentink/gestures/metadata.csv" | grep -qx "$c" || {
    echo "handsets: silentink rendered no '$c' frame" >&2; exit 1; }
done
cut -d, -f2 "$work/silentink/gestures/metadata.csv" | grep -qx punch && {
  echo "handsets: silentink has no fists, yet punch frames were rendered" >&2; exit 1; }
cut -d, -f2 "$work/rps/gestures/metadata.csv" | grep -qx point && {
  echo "handsets: rps has no pointing hands, yet point frames were rendered" >&2; exit 1; }
echo "handsets: ok"
