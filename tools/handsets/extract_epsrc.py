#!/usr/bin/python3
"""Extract hand silhouettes from the EPSRC NUMBERS Human-Robot Finger-Counting Dataset
(github.com/EPSRC-NUMBERS/Human-Robot_Finger-Counting_Dataset, CC BY-SA 4.0): binary
silhouettes (640x480 PNG) segmented by the authors from photographs of a human hand counting
on its fingers.

Source layout: SRC/Example_Datasets/Human_Fingers_1000_200_200/{training_set,testing_set}/
silhouettes/{one,two,three,four,five}_N.png. Only the human hand is used (not the iCub robot).
Pose mapping: five and four -> palm, one -> point (a single raised finger); two/three are none
of our poses. Split: the source's training_set -> `train`, its testing_set -> `heldout`.
The authors pasted the silhouettes upright (arm down, ending inside the image) onto
backgrounds; tools/handsets/handsil.py normalises each mask with arm_down (largest component,
holes filled, forearm cut at the wrist, cropped). The source gives no person ids (person = unknown).

Usage:
  git --git-dir=MIRROR archive 94e7f61a848bcc85035fe91b6592c73d08abdccb \
      Example_Datasets/Human_Fingers_1000_200_200 | tar -x -C /tmp/epsrc
  /usr/bin/python3 tools/handsets/extract_epsrc.py --src /tmp/epsrc --out DIR
Writes DIR/palm/*.png, DIR/point/*.png (1-bit) and DIR/manifest.csv
(file,pose,source,split,person,source_file,width_px,height_px,wrist_px).
Exit 0 on success, 2 on bad arguments or unreadable input (message on stderr).
"""
import argparse
import os
import sys

try:
    import cv2
except ImportError:  # pragma: no cover
    sys.stderr.write("extract_epsrc: needs python3-opencv\n")
    sys.exit(2)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import handsil  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/
import ss_version  # noqa: E402

BASE = "Example_Datasets/Human_Fingers_1000_200_200"
SPLITS = {"training_set": "train", "testing_set": "heldout"}
POSES = {"five": "palm", "four": "palm", "one": "point"}
HEADER = ["file", "pose", "source", "split", "person", "source_file", "width_px", "height_px",
          "wrist_px"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--src", required=True, help="folder holding Example_Datasets/")
    ap.add_argument("--out", required=True)
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    rows, skipped = [], {}
    for sdir, split in SPLITS.items():
        d = os.path.join(a.src, BASE, sdir, "silhouettes")
        try:
            names = sorted(f for f in os.listdir(d) if f.endswith(".png"))
        except OSError as e:
            sys.stderr.write(f"extract_epsrc: cannot list '{d}': {e}\n")
            return 2
        names = [n for n in names if n.split("_")[0] in POSES]
        if not names:
            sys.stderr.write(f"extract_epsrc: no silhouettes of five/four/one in '{d}'\n")
            return 2
        for nm in names:
            m = cv2.imread(os.path.join(d, nm), cv2.IMREAD_GRAYSCALE)
            if m is None:
                sys.stderr.write(f"extract_epsrc: cannot read '{os.path.join(d, nm)}'\n")
                return 2
            pose = POSES[nm.split("_")[0]]
            sil, wrist = handsil.normalise(m > 127, arm_down=True)
            if sil is None:
                skipped[wrist] = skipped.get(wrist, 0) + 1
                continue
            name = f"{pose}/{split}_{os.path.splitext(nm)[0]}.png"
            handsil.write_png1(os.path.join(a.out, name), sil)
            rows.append([name, pose, "epsrc", split, "unknown", f"{sdir}/silhouettes/{nm}",
                         sil.shape[1], sil.shape[0], wrist])
    handsil.write_manifest(a.out, HEADER, rows)
    n = {p: sum(1 for r in rows if r[1] == p) for p in ("palm", "point")}
    print(f"{len(rows)} silhouettes -> {a.out} ({n}); skipped {skipped}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
