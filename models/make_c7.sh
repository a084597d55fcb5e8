#!/bin/sh
# Reproduces models/candidates/c7.ssm, candidate C7 of issue 21 ("an input the renderer cannot
# hide behind"): C4's data (models/make_c4.sh: C2's users, seeds, frames, scales, real rps hands,
# each session with its empty-skin calibration) and training budget (architecture, epochs,
# augmentation, seed), with the classifier's input encoded darkness_warmth
# (docs/input_encodings.md): the relative pixel rule's darkness and warmth maps beside the skin
# mask. That encoding has divided the light out, so it takes no lighting normalisation, and the
# contrast factor is 1 (the recipe's 3 would clip darkness below about 0.25, the segmenter's
# light shadows, to 0). docs/validation_protocol.md, "Issue 21, encodings: darkness_warmth".
# About 40 minutes of one core, 5 of them data.
#   sh models/make_c7.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
HANDS=${4:-$SRC/data/hands/rps}
export LIGHTING=
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c7}" \
  "${3:-$SRC/models/candidates/c7.ssm}" \
  "--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5 --empty-skin" \
  "--input-encoding darkness_warmth --contrast 1"
