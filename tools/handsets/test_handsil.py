#!/usr/bin/python3
"""Checks of tools/handsets/handsil.py on synthetic hands whose answer is known exactly.

A hand drawn upright (fingers up) = 4 fingers (6 px wide, 30 long) on a palm (40 x 50) on a
wrist neck (20 wide, 4 rows) on a forearm (26 wide, 40 rows) cut by the image border. After
normalise() the forearm must be gone (cut at the neck's top row), the wrist at the bottom, for
every one of the four borders the arm can be cut by. Exit 0 when all pass, 1 otherwise.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import handsil  # noqa: E402


def upright_hand():
    h, w = 30 + 50 + 4 + 40, 80
    m = np.zeros((h, w), np.uint8)
    for k in range(4):  # fingers, 4 px gaps
        x0 = 20 + k * 10 + 2
        m[0:30, x0:x0 + 6] = 1
    m[30:80, 20:60] = 1      # palm 40 x 50
    m[80:84, 30:50] = 1      # wrist neck 20 wide
    m[84:124, 27:53] = 1     # forearm 26 wide, reaching the bottom border
    return np.pad(m, ((10, 0), (10, 10)))  # empty space above and at the sides


def main():
    fails = 0
    base = upright_hand()
    for k in range(4):  # arm cut by bottom, right, top, left border
        m = np.rot90(base, k=k)
        sil, wrist = handsil.normalise(m, min_area=100)
        want_h, want_w = 30 + 50 + 1, 40  # fingers + palm + the neck's top row
        got = None if sil is None else (sil.shape, wrist, int(sil.sum()))
        want = ((want_h, want_w), 20, 4 * 6 * 30 + 40 * 50 + 20)
        if got != want:
            print(f"rotation {k}: got {got}, want {want}")
            fails += 1
    # arm_down: the arm ends inside the image with a ragged, narrow end (must not be the cut)
    m = np.pad(upright_hand(), ((0, 12), (0, 0)))
    m[-12:-8, 38:42] = 1  # a 4 px stub below the forearm, like a ragged mask end
    sil, wrist = handsil.normalise(m, min_area=100, arm_down=True)
    got = None if sil is None else (sil.shape, wrist)
    if got != ((81, 40), 20):
        print(f"arm_down: got {got}, want ((81, 40), 20)")
        fails += 1
    # a hand touching no border is rejected with a reason, not cut somewhere
    sil, why = handsil.normalise(np.pad(upright_hand()[:-5], 3), min_area=100)
    if sil is not None or "border" not in why:
        print(f"no border: got {why!r}")
        fails += 1
    print("handsil: all checks passed" if not fails else f"handsil: {fails} check(s) failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
