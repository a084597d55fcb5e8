#!/bin/sh
# Reproduces candidate C10 of issue 21: C8 without epsrc, i.e. C2's recipe (models/make_c2.sh:
# users, seeds, frames, scales 0.6-2, half of the hands real, architecture, budget, colour input)
# with the real silhouettes of rps (`train` rows, as C2) and cnngest (all rows: palm, punch)
# composited by the generator's own renderer. It is C8's leave-one-source-out run for epsrc
# (docs/validation_protocol.md, "Issue 21, two real-hand sources: candidate C10"): C8 read two
# hands as a hug, and epsrc's hand-filling palms are the suspect. About 45 minutes of one core.
#   sh models/make_c10.sh [BUILD_DIR] [WORK_DIR] [OUT]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
WORK=${2:-/tmp/shadowsense-c10}
HANDS=$WORK/hands
sh "$SRC/models/merge_hand_sources.sh" "$HANDS" rps cnngest
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "$WORK" \
  "${3:-$SRC/models/candidates/c10.ssm}" \
  "--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5"
