#!/usr/bin/python3
"""Extract hand silhouettes from the gesture masks of Emojinator (Akshay Bahadur,
github.com/akshaybahadur21/Emojinator, MIT licence): 50x50 grey JPEG skin masks of one hand in
front of a webcam (white hand on black), 1200 consecutive frames per gesture, written by the
repository's own CreateGest.py (HSV skin filter, the largest contour's box padded to a square,
resized to 50x50).

Source layout: SRC/Emojinator/gestures/<id>/<N>.jpg. Used: 10 -> punch (a raised fist),
4 -> palm (an open hand, fingers spread), 1 -> point (index up), 11 -> point (index sideways).
The other gestures are none of our poses. Consecutive frames of one session are near-duplicates,
so only every STRIDE-th frame is taken (N % STRIDE == 0; default 10: 120 per gesture folder).
The hand is every pixel brighter than 127 (JPEG leaves a thin grey fringe); the 50x50 mask is
enlarged 4x (bilinear, thresholded at half) so the renderer, which scales a silhouette to a
hand length, does not enlarge single-pixel stairs; then tools/handsets/handsil.py normalises it
(largest component, holes filled, rotated so the border the arm is cut by is at the bottom,
forearm cut at the wrist, cropped). Every row is validation only: split = heldout. The source
gives no person ids (person = unknown).

The same format is written by other capture scripts of this family (a gesture folder per id,
<N>.jpg masks): --folder, --poses and --source read such a source (e.g. silentink,
docs/hand_sources.md); the defaults are Emojinator's.

Usage:
  git --git-dir=MIRROR archive 1377141415fac31033ae4f8f3e148d378a4ad222 \
      Emojinator/gestures/10 Emojinator/gestures/4 Emojinator/gestures/1 \
      Emojinator/gestures/11 | tar -x -C /tmp/emoji
  /usr/bin/python3 tools/handsets/extract_emoji.py --src /tmp/emoji --out DIR
  [--folder Emojinator/gestures] [--poses 10=punch,4=palm,1=point,11=point] [--source emoji]
Writes DIR/palm/*.png, DIR/point/*.png, DIR/punch/*.png (1-bit) and DIR/manifest.csv
(file,pose,source,split,person,source_file,width_px,height_px,wrist_px).
Exit 0 on success, 2 on bad arguments or unreadable input (message on stderr).
"""
import argparse
import os
import re
import sys

import numpy as np

try:
    import cv2
except ImportError:  # pragma: no cover
    sys.stderr.write("extract_emoji: needs python3-opencv\n")
    sys.exit(2)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import handsil  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/
import ss_version  # noqa: E402

FOLDER = "Emojinator/gestures"
POSES = "10=punch,4=palm,1=point,11=point"
NAME = re.compile(r"^(\d+)\.jpg$")
ENLARGE = 4
HEADER = ["file", "pose", "source", "split", "person", "source_file", "width_px", "height_px",
          "wrist_px"]


def hand_mask(grey):
    big = cv2.resize((grey > 127).astype(np.float32), None, fx=ENLARGE, fy=ENLARGE,
                     interpolation=cv2.INTER_LINEAR)
    return (big >= 0.5).astype(np.uint8)


def parse_poses(text):
    """'ID=POSE,...' -> {id: pose}; None when malformed (an id not a number, a pose not one of
    palm, point, punch, or an id given twice)."""
    out = {}
    for item in text.split(","):
        gid, eq, pose = item.partition("=")
        if not eq or not gid.isdigit() or pose not in ("palm", "point", "punch") or gid in out:
            return None
        out[gid] = pose
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--src", required=True, help="folder holding the gesture folders' parent")
    ap.add_argument("--folder", default=FOLDER,
                    help=f"the gesture folders' parent under --src (default {FOLDER})")
    ap.add_argument("--poses", default=POSES,
                    help="gesture id = pose (palm, point, punch), comma-separated "
                    f"(default {POSES})")
    ap.add_argument("--source", default="emoji",
                    help="the manifest's source column (default emoji)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--stride", type=int, default=10,
                    help="take frames whose number is a multiple of this (default 10)")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    if a.stride < 1:
        sys.stderr.write(f"extract_emoji: --stride must be >= 1, got {a.stride}\n")
        return 2
    poses = parse_poses(a.poses)
    if poses is None:
        sys.stderr.write(f"extract_emoji: --poses '{a.poses}': expected ID=POSE,... with numeric "
                         "ids, each once, and poses palm, point or punch\n")
        return 2
    rows, skipped = [], {}
    for gid in sorted(poses, key=int):
        d = os.path.join(a.src, a.folder, gid)
        try:
            files = [f for f in os.listdir(d) if NAME.match(f)]
        except OSError as e:
            sys.stderr.write(f"extract_emoji: cannot list '{d}': {e}\n")
            return 2
        if not files:
            sys.stderr.write(f"extract_emoji: no <N>.jpg in '{d}'\n")
            return 2
        for nm in sorted(files, key=lambda f: int(NAME.match(f).group(1))):
            if int(NAME.match(nm).group(1)) % a.stride:
                continue
            g = cv2.imread(os.path.join(d, nm), cv2.IMREAD_GRAYSCALE)
            if g is None:
                sys.stderr.write(f"extract_emoji: cannot read '{os.path.join(d, nm)}'\n")
                return 2
            sil, wrist = handsil.normalise(hand_mask(g))
            if sil is None:
                skipped[wrist] = skipped.get(wrist, 0) + 1
                continue
            pose = poses[gid]
            name = f"{pose}/g{gid}_{os.path.splitext(nm)[0]}.png"
            handsil.write_png1(os.path.join(a.out, name), sil)
            rows.append([name, pose, a.source, "heldout", "unknown", f"gestures/{gid}/{nm}",
                         sil.shape[1], sil.shape[0], wrist])
    handsil.write_manifest(a.out, HEADER, rows)
    n = {p: sum(1 for r in rows if r[1] == p) for p in ("palm", "point", "punch")}
    print(f"{len(rows)} silhouettes -> {a.out} ({n}); skipped {skipped}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
