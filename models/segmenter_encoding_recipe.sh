#!/bin/sh
# The recipe of the candidates whose input the library's own segmenter makes (issue 21, "an input
# the renderer cannot hide behind"; models/make_c11.sh: masks, models/make_c12.sh:
# darkness_contact): C4's and C7's data (models/make_c4.sh: C2's users, seeds, frames, scales,
# real rps hands, each session with its empty-skin calibration) and training budget
# (architecture, epochs, augmentation, seed), with the classifier's input encoded ENCODING
# (docs/input_encodings.md). tools/train.py encodes every frame through the Python module of the
# same build (BUILD_DIR/python), so training sees the bits inference sees. Light-independent like
# C7's darkness_warmth: no lighting normalisation, contrast 1. docs/validation_protocol.md,
# "Issue 21, encodings: masks" and "... the combination". About 45 minutes of one core.
#   sh models/segmenter_encoding_recipe.sh ENCODING BUILD_DIR WORK_DIR OUT [HANDS_DIR]
set -e
[ $# -ge 4 ] || { echo "usage: segmenter_encoding_recipe.sh ENCODING BUILD_DIR WORK_DIR OUT [HANDS_DIR]" >&2; exit 2; }
ENCODING=$1
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "$2" && pwd)
HANDS=${5:-$SRC/data/hands/rps}
[ -d "$BUILD/python/shadowsense" ] ||
  { echo "segmenter_encoding_recipe.sh: $BUILD/python/shadowsense not built" >&2; exit 2; }
export LIGHTING=
export PYTHONPATH="$BUILD/python${PYTHONPATH:+:$PYTHONPATH}"
exec sh "$SRC/models/c0_recipe.sh" "$BUILD" "$3" "$4" \
  "--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5 --empty-skin" \
  "--input-encoding $ENCODING --contrast 1"
