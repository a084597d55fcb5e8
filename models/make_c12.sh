#!/bin/sh
# Reproduces models/candidates/c12.ssm, candidate C12 of issue 21 ("an input the renderer cannot
# hide behind"): C4's and C7's data (models/make_c4.sh: C2's users, seeds, frames, scales, real
# rps hands, each session with its empty-skin calibration) and training budget (architecture,
# epochs, augmentation, seed), with the classifier's input encoded darkness_contact
# (docs/input_encodings.md, the combination): C7's darkness map, the segmenter's contact mask in
# place of warmth, and the skin mask, computed by the library itself through its Python module
# (BUILD_DIR/python, built with the project). Light-independent: no lighting normalisation,
# contrast 1. docs/validation_protocol.md, "Issue 21, encodings: masks". About 45 minutes of one
# core.
#   sh models/make_c12.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-build}" && pwd)
HANDS=${4:-$SRC/data/hands/rps}
[ -d "$BUILD/python/shadowsense" ] || { echo "make_c12.sh: $BUILD/python/shadowsense not built" >&2; exit 2; }
export LIGHTING=
export PYTHONPATH="$BUILD/python${PYTHONPATH:+:$PYTHONPATH}"
exec sh "$SRC/models/c0_recipe.sh" "$BUILD" "${2:-/tmp/shadowsense-c12}" \
  "${3:-$SRC/models/candidates/c12.ssm}" \
  "--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5 --empty-skin" \
  "--input-encoding darkness_contact --contrast 1"
