#!/bin/sh
# Reproduces candidate C14 of issue 21: C2's recipe (models/make_c2.sh: users, seeds, frames,
# scales 0.6-2, half of the hands real from rps, architecture, colour input, 20 epochs at the
# paper's constant rate) with the kept weights the mean of the weights after epochs 11-20
# (tools/train.py --swa-from 11, stochastic weight averaging, BatchNorm statistics recomputed)
# instead of the best validation epoch. Aim: the generator nearer 99% at 1x without C13's loss
# on real fists (docs/validation_protocol.md, "Issue 21: candidate C14"). About 45 minutes of
# one core.
#   sh models/make_c14.sh [BUILD_DIR] [WORK_DIR] [OUT]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c14}" \
  "${3:-$SRC/models/candidates/c14.ssm}" \
  "--scale-range 0.6,2 --hands $SRC/data/hands/rps --hands-split train --real-hand-probability 0.5" \
  "--swa-from 11"
