#!/bin/sh
# Reproduces models/candidates/c0.ssm, the gesture model shipped until 2026-11-25 (candidate C0
# of docs/validation_protocol.md; docs/classification_eval.md). The shipped model is now C2
# (models/make_default.sh runs models/make_c2.sh).
# Data: the scene generator's gesture sessions of 36 users, none of them evaluation users (those
# are 0-5 for ss_eval_classify and 200-205 for the randomised hold-out): users 100-111 and
# 124-135 with domain randomisation (ss_gesture_data --randomise: fabric, light colour, exposure,
# lens, noise, hand shapes, press depth, hug body size, ...; docs/scene_generator.md) and users
# 112-123 without it, daylight, dusk and night, 12 frames per gesture, merged into one dataset
# folder (hard links, one metadata.csv).
# Model: compact DenseNet (growth 12, blocks 4-4-4, 24 initial features), 160x88 input,
# lighting normalisation + lighting and geometric augmentation, the paper's recipe (Adam 1e-3,
# batch 16, 20 epochs, best epoch on the last 30% of every session x gesture block). About 35
# minutes of one core, 5 of them data.
# The steps are in models/c0_recipe.sh, which C1 and C2 run with more generator options.
#   sh models/make_c0.sh [BUILD_DIR] [WORK_DIR]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-default}" \
  "$SRC/models/candidates/c0.ssm"
