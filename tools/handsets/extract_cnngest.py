#!/usr/bin/python3
"""Extract hand silhouettes from the gesture images of CNNGestureRecognizer (Abhishek Singh,
github.com/asingh33/CNNGestureRecognizer, MIT licence): 200x200 grey images of one hand in
front of a webcam, the background already masked out to black by the author's skin-colour filter
("SkinMask mode").

Source layout: SRC/imgfolder_b/<prefix><N>.png. Only the skin-mask images of two gestures are
used: `punch<N>.png` -> punch (a fist, knuckles towards the camera), `stop<N>.png` -> palm (a
flat hand, palm towards the camera, fingers together). The other prefixes (ppunch, pppunch,
sstop, ssstop: outline drawings of the author's "binary mode"; ok, peace, nothing) are not used.
The hand is every pixel brighter than 30 (the masked background is 0; the skin-colour filter's
blurred edge leaves a dark fringe of 1-30), a 3x3 opening; a hand touching the left, right or
top border of the frame is cut off by it and is skipped; the arm is cut by the bottom border.
tools/handsets/handsil.py then normalises the mask (largest component, holes filled, forearm cut
at the wrist, cropped). Every row is validation only: split = heldout. The source gives no
person ids (person = unknown).

Usage:
  git --git-dir=MIRROR archive e70d5fc1b848298b47c1274bcac195408c55d4fc imgfolder_b \
      | tar -x -C /tmp/cnngest
  /usr/bin/python3 tools/handsets/extract_cnngest.py --src /tmp/cnngest --out DIR
Writes DIR/palm/*.png, DIR/punch/*.png (1-bit) and DIR/manifest.csv
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
    sys.stderr.write("extract_cnngest: needs python3-opencv\n")
    sys.exit(2)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import handsil  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/
import ss_version  # noqa: E402

FOLDER = "imgfolder_b"
NAME = re.compile(r"^(punch|stop)(\d+)\.png$")  # exactly these prefixes: the skin-mask images
POSES = {"punch": "punch", "stop": "palm"}
HEADER = ["file", "pose", "source", "split", "person", "source_file", "width_px", "height_px",
          "wrist_px"]


def hand_mask(grey):
    m = (grey > 30).astype(np.uint8)
    return cv2.morphologyEx(m, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--src", required=True, help="folder holding imgfolder_b/")
    ap.add_argument("--out", required=True)
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    d = os.path.join(a.src, FOLDER)
    try:
        names = sorted(f for f in os.listdir(d) if NAME.match(f))
    except OSError as e:
        sys.stderr.write(f"extract_cnngest: cannot list '{d}': {e}\n")
        return 2
    if not names:
        sys.stderr.write(f"extract_cnngest: no punch<N>.png or stop<N>.png in '{d}'\n")
        return 2
    rows, skipped = [], {}
    for nm in sorted(names, key=lambda f: (NAME.match(f).group(1), int(NAME.match(f).group(2)))):
        g = cv2.imread(os.path.join(d, nm), cv2.IMREAD_GRAYSCALE)
        if g is None:
            sys.stderr.write(f"extract_cnngest: cannot read '{os.path.join(d, nm)}'\n")
            return 2
        m = handsil.largest_filled(hand_mask(g))
        if m is None:
            skipped["empty"] = skipped.get("empty", 0) + 1
            continue
        if m[0, :].any() or m[:, 0].any() or m[:, -1].any():
            skipped["cut by the left, right or top border"] = \
                skipped.get("cut by the left, right or top border", 0) + 1
            continue
        sil, wrist = handsil.normalise(m)
        if sil is None:
            skipped[wrist] = skipped.get(wrist, 0) + 1
            continue
        pose = POSES[NAME.match(nm).group(1)]
        name = f"{pose}/{os.path.splitext(nm)[0]}.png"
        handsil.write_png1(os.path.join(a.out, name), sil)
        rows.append([name, pose, "cnngest", "heldout", "unknown", f"{FOLDER}/{nm}", sil.shape[1],
                     sil.shape[0], wrist])
    handsil.write_manifest(a.out, HEADER, rows)
    n = {p: sum(1 for r in rows if r[1] == p) for p in ("palm", "punch")}
    print(f"{len(rows)} silhouettes -> {a.out} ({n}); skipped {skipped}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
