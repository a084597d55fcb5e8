#!/bin/sh
# Reproduces candidate C8 of issue 21 ("shapes from real hands in training": three public sources
# instead of one): C2's recipe (models/make_c2.sh: users, seeds, frames, scales 0.6-2, half of
# the hands real, architecture, budget, colour input) with the real silhouettes of rps (`train`
# rows, as C2), epsrc (all rows: palm, point) and cnngest (all rows: palm, punch) composited by
# the generator's own renderer. epsrc and cnngest were validation sources already "used for
# decisions"; from C8 on they are "trained on" for it (docs/validation_protocol.md, "Issue 21,
# real hands from three sources: candidate C8"). The three are merged into WORK_DIR/hands (one
# manifest, every row split `train`: models/merge_hand_sources.sh). About 45 minutes of one
# core, 5 of them data.
#   sh models/make_c8.sh [BUILD_DIR] [WORK_DIR] [OUT]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
WORK=${2:-/tmp/shadowsense-c8}
HANDS=$WORK/hands
sh "$SRC/models/merge_hand_sources.sh" "$HANDS" rps epsrc cnngest
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "$WORK" \
  "${3:-$SRC/models/candidates/c8.ssm}" \
  "--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5"
