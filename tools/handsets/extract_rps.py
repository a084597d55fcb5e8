#!/usr/bin/python3
"""Extract hand silhouettes from the Rock-Paper-Scissors images of J. de la Bruere-Terreault
(rps-cv, CC BY-SA 4.0): RGB photographs, 300x200, of a hand on a green background.

Source layout: SRC/rock/*.png, SRC/paper/*.png (SRC/scissors is not used: two fingers is none
of our poses). Pose mapping: rock -> punch, paper -> palm (a flat hand, fingers together).
The hand is everything that is not the green screen (HSV hue 35-90, saturation > 60), then
tools/handsets/handsil.py normalises it (largest component, holes filled, wrist at the bottom,
forearm cut at the wrist, cropped). Split: `heldout` for a fixed 20% by a hash of the file name,
`train` for the rest. The source gives no person ids (person = unknown).

Usage:
  git --git-dir=MIRROR archive a0ca246b3dcbd0b5664f66954e3b360f5ec7f7fa rps-cv-images | tar -x -C /tmp/rps
  /usr/bin/python3 tools/handsets/extract_rps.py --src /tmp/rps/rps-cv-images --out DIR
Writes DIR/palm/*.png, DIR/punch/*.png (1-bit) and DIR/manifest.csv
(file,pose,source,split,person,source_file,width_px,height_px,wrist_px).
Exit 0 on success, 2 on bad arguments or unreadable input (message on stderr).
"""
import argparse
import os
import sys

import numpy as np

try:
    import cv2
except ImportError:  # pragma: no cover
    sys.stderr.write("extract_rps: needs python3-opencv\n")
    sys.exit(2)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import handsil  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/
import ss_version  # noqa: E402

POSES = {"rock": "punch", "paper": "palm"}
HEADER = ["file", "pose", "source", "split", "person", "source_file", "width_px", "height_px",
          "wrist_px"]


def hand_mask(img):
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    h, s = hsv[..., 0], hsv[..., 1]
    green = (h > 35) & (h < 90) & (s > 60)
    m = (~green).astype(np.uint8)
    # the left edge of some frames shows the rig (dark); the hand always enters from the right
    m = cv2.morphologyEx(m, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--src", required=True, help="folder with rock/ and paper/")
    ap.add_argument("--out", required=True)
    ap.add_argument("--heldout-share", type=float, default=0.2)
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    if not 0 <= a.heldout_share <= 1:
        ap.error("--heldout-share must be in [0, 1]")
    rows, skipped = [], {}
    for cls, pose in POSES.items():
        d = os.path.join(a.src, cls)
        try:
            names = sorted(f for f in os.listdir(d) if f.lower().endswith(".png"))
        except OSError as e:
            sys.stderr.write(f"extract_rps: cannot list '{d}': {e}\n")
            return 2
        if not names:
            sys.stderr.write(f"extract_rps: no .png files in '{d}'\n")
            return 2
        for nm in names:
            img = cv2.imread(os.path.join(d, nm), cv2.IMREAD_COLOR)
            if img is None:
                sys.stderr.write(f"extract_rps: cannot read '{os.path.join(d, nm)}'\n")
                return 2
            sil, wrist = handsil.normalise(hand_mask(img), inset=1)
            if sil is None:
                skipped[wrist] = skipped.get(wrist, 0) + 1
                continue
            # the hand must enter from the right border of the photograph (the rig's framing)
            name = f"{pose}/{os.path.splitext(nm)[0]}.png"
            handsil.write_png1(os.path.join(a.out, name), sil)
            rows.append([name, pose, "rps", handsil.split_of(nm, a.heldout_share), "unknown",
                         f"{cls}/{nm}", sil.shape[1], sil.shape[0], wrist])
    handsil.write_manifest(a.out, HEADER, rows)
    n = {p: sum(1 for r in rows if r[1] == p) for p in POSES.values()}
    print(f"{len(rows)} silhouettes -> {a.out} ({n}); skipped {skipped}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
