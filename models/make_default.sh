#!/bin/sh
# Reproduces models/default.ssm, the shipped gesture model: candidate C2 of
# docs/validation_protocol.md (models/make_c2.sh: the C0 recipe of models/make_c0.sh, hands drawn
# 0.6x to 2x as large, and half of the palm, punch, two_hands and hug hands real silhouettes of
# data/hands/rps, train split), shipped since 2026-11-25 (docs/validation_protocol.md,
# "Results and decision log"). About 35-40 minutes of one core.
#   sh models/make_default.sh [BUILD_DIR] [WORK_DIR]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
exec sh "$SRC/models/make_c2.sh" "${1:-build}" "${2:-/tmp/shadowsense-default}" \
  "$SRC/models/default.ssm"
