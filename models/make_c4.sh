#!/bin/sh
# Reproduces models/candidates/c4.ssm, candidate C4 of issue 21 ("an input the renderer cannot
# hide behind"): the C2 recipe (models/make_c2.sh: same users, seeds, frames, scales, real rps
# hands, architecture and training budget) with the classifier's input encoded skin_relative
# (docs/input_encodings.md): every frame divided by its session's empty-skin model, which
# ss_gesture_data --empty-skin writes as empty_skin/<session>.calib beside the frames (the frames
# themselves are byte-identical to C2's). The one difference from C2 is the input encoding, so
# C2 against C4 is the colour against skin_relative comparison on the same data and budget
# (docs/validation_protocol.md, "Issue 21, encodings").
# About 40 minutes of one core, 5 of them data.
#   sh models/make_c4.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
HANDS=${4:-$SRC/data/hands/rps}
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c4}" \
  "${3:-$SRC/models/candidates/c4.ssm}" \
  "--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5 --empty-skin" \
  "--input-encoding skin_relative"
