#!/bin/sh
# Reproduces models/candidates/c12.ssm, candidate C12 of issue 21: C7's data and budget with the
# input encoded darkness_contact, the combination (C7's darkness map, the segmenter's contact mask
# in place of warmth, the skin mask). models/segmenter_encoding_recipe.sh says the rest;
# docs/validation_protocol.md, "Issue 21, encodings: the combination". About 45 minutes of one
# core.
#   sh models/make_c12.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
SRC=$(cd "$(dirname "$0")/.." && pwd)
exec sh "$SRC/models/segmenter_encoding_recipe.sh" darkness_contact "${1:-build}" \
  "${2:-/tmp/shadowsense-c12}" "${3:-$SRC/models/candidates/c12.ssm}" ${4:+"$4"}
