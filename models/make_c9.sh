#!/bin/sh
# Reproduces candidate C9 of issue 21 (report only): C2's recipe (models/make_c2.sh: users,
# seeds, frames, half of the hands real rps `train` silhouettes, architecture, budget, colour
# input) at the generator rig's one hand scale, without --scale-range: a model that sees hands at
# one size and relies on the calibration's camera scale (ss_calibrate --px-per-cm,
# --scale-to-network) to bring every robot's frames to it, where C2 was trained over 0.6x-2x.
# docs/validation_protocol.md, "Issue 21, one scale and the camera's scale: candidate C9".
# About 45 minutes of one core, 5 of them data.
#   sh models/make_c9.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
HANDS=${4:-$SRC/data/hands/rps}
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c9}" \
  "${3:-$SRC/models/candidates/c9.ssm}" \
  "--hands $HANDS --hands-split train --real-hand-probability 0.5"
