#!/bin/sh
# Merges real hand-silhouette sources of data/hands into one folder with one manifest, every row
# split `train`, for the candidates that train on more than one source (models/make_c8.sh,
# make_c10.sh). rps keeps only its `train` rows (its `heldout` rows stay a within-source check);
# every other source gives all of its rows. Files are copied as SOURCE/FILE.
#   sh models/merge_hand_sources.sh OUT_DIR SOURCE...
set -e
SRC=$(cd "$(dirname "$0")/.." && pwd)
OUT=$1
shift
rm -rf "$OUT"
mkdir -p "$OUT"
head -n 1 "$SRC/data/hands/rps/manifest.csv" >"$OUT/manifest.csv.tmp"
for s in "$@"; do
  cp -R "$SRC/data/hands/$s" "$OUT/$s"
  awk -F, -v OFS=, -v s="$s" 'NR > 1 && (s != "rps" || $4 == "train") { $1 = s "/" $1; $4 = "train"; print }' \
    "$SRC/data/hands/$s/manifest.csv" >>"$OUT/manifest.csv.tmp"
done
mv "$OUT/manifest.csv.tmp" "$OUT/manifest.csv"
