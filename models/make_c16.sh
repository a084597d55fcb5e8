#!/bin/sh
# Reproduces candidate C16 of issue 21: C14's recipe (models/make_c14.sh: C2's data and training
# with the kept weights the mean of the weights after epochs 11-20, BatchNorm statistics
# recomputed) with each hand of a palm, punch, two_hands and hug frame a real silhouette of the
# rps source's train split with probability 0.8 instead of 0.5. Aim: the averaged weights fit
# the generator (C14: g 99.12 / hold 98.33% at 1x) on mostly real hand shapes, so that they do
# not lose the real fists C14 lost (docs/validation_protocol.md, "Issue 21: candidate C16").
# About 30 minutes of one core (28 measured).
#   sh models/make_c16.sh [BUILD_DIR] [WORK_DIR] [OUT]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c16}" \
  "${3:-$SRC/models/candidates/c16.ssm}" \
  "--scale-range 0.6,2 --hands $SRC/data/hands/rps --hands-split train --real-hand-probability 0.8" \
  "--swa-from 11"
