#!/bin/sh
# Reproduces candidate C17 of issue 21: C2's data and training (models/make_c2.sh) with
# knowledge distillation from three C2 runs that differ only in the training seed (0: the
# shipped models/default.ssm; 1 and 2 trained here first unless WORK_DIR holds them):
# tools/train.py --teacher x3 --distill-weight 0.5 --distill-temperature 2. Aim: the seed-to-seed
# spread of C2's recipe (docs/validation_protocol.md, "Issue 21: the C2 recipe over three
# seeds") is larger than the differences between candidates; the three runs' mean soft targets
# should carry less of one run's chance (docs/validation_protocol.md, "Issue 21: candidate C17").
# SEED (default 0) is the student's training seed; the protocol trains 0 (C17) and 1 (its
# paired check). About 45 minutes of one core per run, 30 more for each missing teacher.
#   sh models/make_c17.sh [BUILD_DIR] [WORK_DIR] [OUT] [SEED]
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${1:-build}
WORK=${2:-/tmp/shadowsense-c17}
OUT=${3:-$SRC/models/candidates/c17.ssm}
SEED=${4:-0}
DATA="--scale-range 0.6,2 --hands $SRC/data/hands/rps --hands-split train"
DATA="$DATA --real-hand-probability 0.5"
for s in 1 2; do
  if [ ! -f "$WORK/teacher_seed$s.ssm" ]; then
    sh "$SRC/models/c0_recipe.sh" "$BUILD" "$WORK/teacher$s" "$WORK/teacher_seed$s.ssm" "$DATA" \
      "--seed $s"
  fi
done
TEACHERS="--teacher $SRC/models/default.ssm --teacher $WORK/teacher_seed1.ssm"
TEACHERS="$TEACHERS --teacher $WORK/teacher_seed2.ssm"
exec sh "$SRC/models/c0_recipe.sh" "$BUILD" "$WORK/student$SEED" "$OUT" "$DATA" \
  "--seed $SEED $TEACHERS --distill-weight 0.5 --distill-temperature 2"
