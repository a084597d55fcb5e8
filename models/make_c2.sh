#!/bin/sh
# Reproduces models/candidates/c2.ssm, candidate C2 of issue 21 ("hands we have never seen"):
# the C0 recipe (models/make_c0.sh: same users, seeds, frames, architecture
# and training) with the body drawn at a pixel scale log-uniform in [0.6, 2] per gesture block
# (ss_gesture_data --scale-range 0.6,2: Scene::zoom about the gesture's anchor, the hands,
# arms, shadow shifts and penumbrae seen 0.6x to 2x as large; docs/scene_generator.md) - that
# is C1 (models/make_c1.sh) - and real hand shapes mixed in: each hand of a palm, punch,
# two_hands and hug frame is, with probability 0.5, a real hand silhouette of the rps source's
# train split (ss_gesture_data --hands: 535 open hands and 523 fists, CC BY-SA 4.0, made by
# tools/handsets/extract_rps.py, committed as data/hands/rps; its heldout split and the epsrc source are
# validation only), placed, lifted and shadowed by the generator's renderer. rps has no
# pointing hands: point frames keep the parametric hands.
# About 35-40 minutes of one core, 5 of them data.
#   sh models/make_c2.sh [BUILD_DIR] [WORK_DIR] [OUT] [HANDS_DIR]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
HANDS=${4:-$SRC/data/hands/rps}
exec sh "$SRC/models/c0_recipe.sh" "${1:-build}" "${2:-/tmp/shadowsense-c2}" \
  "${3:-$SRC/models/candidates/c2.ssm}" \
  "--scale-range 0.6,2 --hands $HANDS --hands-split train --real-hand-probability 0.5"
