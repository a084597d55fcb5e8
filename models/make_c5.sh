#!/bin/sh
# Reproduces models/candidates/c5.ssm, candidate C5 of the issue-21 protocol's "more data or more
# pixels" section (docs/validation_protocol.md): C2's recipe (models/make_c2.sh: scales 0.6-2,
# half the hands real rps `train` silhouettes, same architecture, input, epochs and seed) with
# twice the users per session (USERS=24: users 100-171, 5184 training frames instead of 2592).
# Question: is the generator hold-outs' shortfall (small hands, 1x below 99%) a matter of data?
# About 70-80 minutes of one core.
#   sh models/make_c5.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
HANDS=${4:-$SRC/data/hands/rps}
USERS=24 exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c5}" \
  "${3:-$SRC/models/candidates/c5.ssm}" \
  "--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5"
