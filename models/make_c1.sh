#!/bin/sh
# Reproduces models/candidates/c1.ssm, candidate C1 of issue 21 ("hands we have never seen"):
# the C0 recipe (models/make_c0.sh: same users, seeds, frames, architecture
# and training) with the body drawn at a pixel scale log-uniform in [0.6, 2] per gesture block
# (ss_gesture_data --scale-range 0.6,2: Scene::zoom about the gesture's anchor, the hands,
# arms, shadow shifts and penumbrae seen 0.6x to 2x as large; docs/scene_generator.md).
# About 35-40 minutes of one core, 5 of them data.
#   sh models/make_c1.sh [BUILD_DIR] [WORK_DIR] [OUT]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c1}" \
  "${3:-$SRC/models/candidates/c1.ssm}" "--scale-range 0.6,2"
