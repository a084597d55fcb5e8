#!/bin/sh
# Reproduces models/candidates/c11.ssm, candidate C11 of issue 21: C7's data and budget with the
# input encoded masks (the segmenter's shadow and contact masks beside the skin mask).
# models/segmenter_encoding_recipe.sh says the rest; docs/validation_protocol.md, "Issue 21,
# encodings: masks". About 45 minutes of one core.
#   sh models/make_c11.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
SRC=$(cd "$(dirname "$0")/.." && pwd)
exec sh "$SRC/models/segmenter_encoding_recipe.sh" masks "${1:-build}" \
  "${2:-/tmp/shadowsense-c11}" "${3:-$SRC/models/candidates/c11.ssm}" ${4:+"$4"}
