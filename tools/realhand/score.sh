#!/bin/sh
# Score a gesture model on one pre-registered validation source at one hand scale
# (docs/validation_protocol.md): renders the source with tools/realhand/render.py into
# VALSETS/<source>_s<scale>/ once (skipped when that folder exists), then runs ss_eval_classify
# --score on it and prints overall and per-class accuracy.
#
# usage: tools/realhand/score.sh --model M.ssm --source NAME --scale S [--valsets DIR]
#                                [--bin DIR] [--json OUT.json] [--render-only]
#                                [--camera-scale FILL]
#   NAME: realhand | epsrc | rps_heldout | cnngest | emoji | silentink   S: 0.6 | 0.7 | 1 | 1.5 | 2 (spelled so: the folder
#   name is <source>_s<S>; any number in [0.25, 4] works)
#   --valsets DIR  rendered folders (default /work/valsets, or $VALSETS)
#   --bin DIR      folder of ss_eval_classify (default build/examples, or $TRACK_EVAL_BIN_DIR)
#   --camera-scale FILL  bring frames to the network's scale: the camera's scale is S x 7.578125
#                  px per cm (ss_eval_classify --camera-px-per-cm, --scale-fill FILL: black,
#                  replicate or black_frame_contrast; docs/input_encodings.md)
# Exit 0 on success, 2 on bad arguments or a failing step (message on stderr).
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
model="" source="" scale="" json="" render_only=0 fill=
valsets=${VALSETS:-/work/valsets}
bin=${TRACK_EVAL_BIN_DIR:-$root/build/examples}
die() { echo "score.sh: $*" >&2; exit 2; }
while [ $# -gt 0 ]; do
  case $1 in
    -h|--help) sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'; exit 0;;
    --version) echo "score.sh 1"; exit 0;;
    --model) [ $# -ge 2 ] || die "--model needs a value"; model=$2; shift 2;;
    --source) [ $# -ge 2 ] || die "--source needs a value"; source=$2; shift 2;;
    --scale) [ $# -ge 2 ] || die "--scale needs a value"; scale=$2; shift 2;;
    --valsets) [ $# -ge 2 ] || die "--valsets needs a value"; valsets=$2; shift 2;;
    --bin) [ $# -ge 2 ] || die "--bin needs a value"; bin=$2; shift 2;;
    --json) [ $# -ge 2 ] || die "--json needs a value"; json=$2; shift 2;;
    --render-only) render_only=1; shift;;
    --camera-scale) [ $# -ge 2 ] || die "--camera-scale needs a value"; fill=$2; shift 2;;
    *) die "unknown argument '$1' (see --help)";;
  esac
done
[ -n "$source" ] || die "--source is required"
[ -n "$scale" ] || die "--scale is required"
[ $render_only = 1 ] || [ -n "$model" ] || die "--model is required"
[ $render_only = 1 ] || [ -f "$model" ] || die "model '$model' not found"
case $scale in ''|*[!0-9.]*|*.*.*) die "--scale '$scale' is not a number";; esac
case $fill in ''|black|replicate|black_frame_contrast) ;;
  *) die "--camera-scale '$fill' is not black, replicate or black_frame_contrast";; esac
# The pre-registered sources (docs/validation_protocol.md): hands, split, render parameters.
case $source in
  realhand) hands="$root/data/realhand"; split="";;
  epsrc) hands="$root/data/hands/epsrc"; split="";;
  rps_heldout) hands="$root/data/hands/rps"; split="heldout";;
  cnngest) hands="$root/data/hands/cnngest"; split="";;
  emoji) hands="$root/data/hands/emoji"; split="";;
  silentink) hands="$root/data/hands/silentink"; split="";;
  *) die "unknown --source '$source' (realhand, epsrc, rps_heldout, cnngest, emoji or silentink)";;
esac
out="$valsets/${source}_s$scale"
if [ ! -f "$out/gestures/metadata.csv" ]; then
  mkdir -p "$valsets" || die "cannot create '$valsets'"
  rm -rf "$out.tmp"
  # shellcheck disable=SC2086
  /usr/bin/python3 "$root/tools/realhand/render.py" --out "$out.tmp" --hands "$hands" \
    ${split:+--split "$split"} --scale "$scale" --seed 21 --users 4 --frames-per-user 4 \
    --only gestures --workers 1 >/dev/null || die "rendering $source at scale $scale failed"
  mv "$out.tmp" "$out" || die "cannot move '$out.tmp' to '$out'"
fi
# Each gesture session's empty skin and its calibration (docs/validation_protocol.md, "Issue 21,
# encodings"): what a calibrated input encoding (skin_relative) divides by, made as a user makes
# it, with ss_calibrate --empty on the session's three empty-skin frames. A colour model does
# not read them (ss_eval_classify --session-calibrations ignores them), so its scores are those
# of the fixed recipe.
skin="$out/gestures/empty_skin"
if [ ! -f "$skin/complete" ]; then
  [ -x "$bin/ss_calibrate" ] || die "'$bin/ss_calibrate' not found (build the target)"
  rm -rf "$skin"
  /usr/bin/python3 "$root/tools/realhand/render.py" --out "$out" --hands "$hands" \
    ${split:+--split "$split"} --scale "$scale" --seed 21 --users 4 --only empty_skin \
    --workers 1 >/dev/null || die "rendering the empty skin of $source at scale $scale failed"
  for first in "$skin"/*_0.png; do
    session=$(basename "$first" _0.png)
    frames="$skin/$session.frames"
    mkdir -p "$frames" && ln -f "$skin/${session}"_[0-2].png "$frames/" ||
      die "cannot gather the empty-skin frames of session $session"
    "$bin/ss_calibrate" --empty "$frames" --out "$skin/$session.calib" >/dev/null 2>"$frames.log" ||
      die "ss_calibrate failed on session $session (see $frames.log)"
    rm -rf "$frames" "$frames.log"
  done
  : >"$skin/complete" || die "cannot write '$skin/complete'"
fi
[ $render_only = 1 ] && { echo "rendered: $out"; exit 0; }
[ -x "$bin/ss_eval_classify" ] || die "'$bin/ss_eval_classify' not found (build the target)"
tmp=$(mktemp) || die "mktemp failed"
trap 'rm -f "$tmp"' EXIT
camera=""
[ -z "$fill" ] || camera=$(/usr/bin/python3 -c "print(repr($scale * 242.5 / 32))")
# No --lighting-normalise: every model file records its own lighting normalisation (the flag
# only switches it on for version-1 files, and a darkness_warmth model refuses it).
"$bin/ss_eval_classify" --score "$model" --data "$out/gestures" --quiet \
  --session-calibrations --json "$tmp" ${fill:+--camera-px-per-cm "$camera" --scale-fill "$fill"} \
  >/dev/null || die "ss_eval_classify failed on '$out/gestures'"
if [ -n "$json" ]; then
  { cp "$tmp" "$json.tmp" && mv "$json.tmp" "$json"; } || die "cannot write '$json'"
fi
/usr/bin/python3 - "$tmp" "$source" "$scale" "$model" "${fill:+ (camera scale, $fill fill)}" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
names = ["nothing", "hug", "palm", "point", "punch", "two_hands"]
m = r["confusion"]["all"]
if len(m) != len(names):
    sys.exit(f"score.sh: expected {len(names)} classes, the model has {len(m)}")
n = sum(map(sum, m))
ok = sum(m[i][i] for i in range(len(m)))
cells = []
for i, nm in enumerate(names):
    t = sum(m[i])
    cells.append(f"{nm} {100.0 * m[i][i] / t:.1f}% ({m[i][i]}/{t})" if t else f"{nm} -")
print(f"{sys.argv[2]} x{sys.argv[3]}{sys.argv[5]}: all {100.0 * ok / n:.2f}% ({ok}/{n}); " + "; ".join(cells))
PY
