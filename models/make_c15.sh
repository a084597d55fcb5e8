#!/bin/sh
# Reproduces candidate C15 of issues 21 and 26: C2's recipe (models/make_c2.sh: users, seeds,
# frames, scales 0.6-2, half of the hands real from rps, architecture, colour input, the paper's
# training) with the network input at 128 x 72 instead of 160 x 88 (0.65x the pixels, so about
# 0.65x the forward pass's work). Aim: a faster frame at C2's accuracy
# (docs/validation_protocol.md, "Issues 21 and 26: candidate C15"). About 30 minutes of one core.
#   sh models/make_c15.sh [BUILD_DIR] [WORK_DIR] [OUT]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c15}" \
  "${3:-$SRC/models/candidates/c15.ssm}" \
  "--scale-range 0.6,2 --hands $SRC/data/hands/rps --hands-split train --real-hand-probability 0.5" \
  "--resize 128 72"
