#!/usr/bin/python3
"""Checks of tools/handsets/extract_emoji.py on synthetic masks whose answer is known exactly.

1. hand_mask: a block of hand values (> 127) with a grey JPEG-like fringe (<= 127) around it
   becomes exactly the block enlarged 4x less its four corner pixels: along an edge the bilinear
   step crosses one half at the enlarged edge (5/8 inside, 3/8 outside, no pixel in doubt); at a
   corner the two weights multiply, (5/8)^2 < 1/2, so the corner is rounded off - the smoothing
   the enlargement is for.
2. The whole extractor on a tiny source tree (one synthetic hand per gesture folder, as frames 5
   and 10): with the default stride only frame 10 is taken; the poses are punch (10), palm (4),
   point (1 and 11); a non-image file stops it with exit 2.
3. --folder, --poses and --source (another source of the same format): only the named ids are
   read, with their poses and the source name in the manifest; a malformed --poses is exit 2.
Exit 0 when all pass, 1 otherwise.
"""
import csv
import os
import subprocess
import sys
import tempfile

import numpy as np
import cv2

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import extract_emoji  # noqa: E402
from test_handsil import upright_hand  # noqa: E402


def small_hand():
    """The synthetic upright hand of test_handsil at 50 px height, arm on the bottom border."""
    m = upright_hand()
    w = round(m.shape[1] * 50 / m.shape[0])
    m = cv2.resize(m, (w, 50), interpolation=cv2.INTER_NEAREST)
    out = np.zeros((50, 50), np.uint8)
    out[:, (50 - w) // 2:(50 - w) // 2 + w] = m * 255
    return out


def run_extractor(src, out, *extra):
    return subprocess.run([sys.executable, os.path.join(HERE, "extract_emoji.py"), "--src", src,
                           "--out", out, *extra], capture_output=True, text=True)


def main():
    fails = 0
    g = np.zeros((50, 50), np.uint8)
    g[9:41, 14:36] = 100   # fringe, must read as background
    g[10:40, 15:35] = 200  # hand
    got = extract_emoji.hand_mask(g)
    want = np.zeros((200, 200), np.uint8)
    want[40:160, 60:140] = 1
    want[40, 60] = want[40, 139] = want[159, 60] = want[159, 139] = 0
    if got.shape != want.shape or not np.array_equal(got, want):
        print(f"hand_mask: {int((got != want).sum())} pixels differ from the 4x block")
        fails += 1

    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "src")
        for gid in ("1", "4", "10", "11"):
            d = os.path.join(src, "Emojinator", "gestures", gid)
            os.makedirs(d)
            for n in (5, 10):  # PNG bytes under a .jpg name: imread reads the content
                ok, buf = cv2.imencode(".png", small_hand())
                assert ok
                with open(os.path.join(d, f"{n}.jpg"), "wb") as f:
                    f.write(buf.tobytes())
        out = os.path.join(tmp, "out")
        r = run_extractor(src, out)
        rows = []
        if r.returncode == 0:
            with open(os.path.join(out, "manifest.csv")) as f:
                rows = list(csv.DictReader(f))
        got = sorted((row["source_file"], row["pose"], row["split"]) for row in rows)
        want = sorted([("gestures/1/10.jpg", "point", "heldout"),
                       ("gestures/4/10.jpg", "palm", "heldout"),
                       ("gestures/10/10.jpg", "punch", "heldout"),
                       ("gestures/11/10.jpg", "point", "heldout")])
        if r.returncode != 0 or got != want:
            print(f"extract: exit {r.returncode} {r.stderr.strip()!r}, rows {got}, want {want}")
            fails += 1
        for row in rows:
            sil = cv2.imread(os.path.join(out, row["file"]), cv2.IMREAD_GRAYSCALE)
            if sil is None or sil.shape != (int(row["height_px"]), int(row["width_px"])):
                print(f"extract: {row['file']} missing or not its manifest size")
                fails += 1
        other = os.path.join(tmp, "other")
        r = run_extractor(os.path.dirname(os.path.join(src, "Emojinator")), other, "--folder",
                          "Emojinator/gestures", "--poses", "4=point,11=palm", "--source", "x")
        rows = []
        if r.returncode == 0:
            with open(os.path.join(other, "manifest.csv")) as f:
                rows = list(csv.DictReader(f))
        got = sorted((row["source_file"], row["pose"], row["source"]) for row in rows)
        want = sorted([("gestures/4/10.jpg", "point", "x"), ("gestures/11/10.jpg", "palm", "x")])
        if r.returncode != 0 or got != want:
            print(f"--poses: exit {r.returncode} {r.stderr.strip()!r}, rows {got}, want {want}")
            fails += 1
        for bad in ("4=fist", "4=palm,4=point", "x=palm", "4palm"):
            r = run_extractor(src, os.path.join(tmp, "badposes"), "--poses", bad)
            if r.returncode != 2 or "--poses" not in r.stderr:
                print(f"--poses {bad}: exit {r.returncode}, stderr {r.stderr.strip()!r}")
                fails += 1
        with open(os.path.join(src, "Emojinator", "gestures", "4", "20.jpg"), "w") as f:
            f.write("not an image")
        r = run_extractor(src, os.path.join(tmp, "bad"))
        if r.returncode != 2 or "cannot read" not in r.stderr:
            print(f"bad image: exit {r.returncode}, stderr {r.stderr.strip()!r}")
            fails += 1
    print("extract_emoji: all checks passed" if not fails else
          f"extract_emoji: {fails} check(s) failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
