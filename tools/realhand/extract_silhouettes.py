#!/usr/bin/python3
"""Extract the committed hand silhouettes of the independent validation set.

Source: github.com/stes/gestures (Binary Hand Gesture Dataset, CC BY 4.0), commit
9dbdff4269ffd4920cad2041172aba6d7da785bc, file data/gestures_64px.hdf5: 64x64 binary masks of
real hands photographed and segmented from the background (classes fist, thumb, pistol, three,
four, five, peace; arrays Xt/yt = train split, Xv/yv = test split).

We take, per pose, silhouettes spread evenly over both splits (consecutive samples are video
frames of one hand, so an even spread maximises variety), clean them (largest component, holes
filled), rotate them by a multiple of 90 degrees so the wrist (the image border the hand is cut
by) is at the bottom, crop them to the hand and write 1-bit PNGs plus manifest.csv.

Pose mapping: fist -> punch, pistol -> point, five and four -> palm.

Usage:
  git clone https://github.com/stes/gestures && git -C gestures checkout 9dbdff42
  /usr/bin/python3 tools/realhand/extract_silhouettes.py --hdf5 gestures/data/gestures_64px.hdf5 \
      --out data/realhand [--per-pose 80]
Exit 0 on success, 2 on bad arguments or input (message on stderr).
"""
import argparse
import os
import sys

import numpy as np

try:
    import cv2
except ImportError as e:  # pragma: no cover
    sys.stderr.write(f"extract_silhouettes: {e}; install python3-opencv\n")
    sys.exit(2)

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/
import ss_version  # noqa: E402

SOURCE_CLASSES = {"fist": 0, "thumb": 1, "pistol": 2, "three": 3, "four": 4, "five": 5, "peace": 6}
POSES = {"punch": ["fist"], "point": ["pistol"], "palm": ["five", "four"]}


def want_share(n, k):
    return max(1, n // k)


def clean(m):
    m = (m > 0).astype(np.uint8)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    if n <= 1:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    m = (lab == k).astype(np.uint8)
    # fill holes: flood the background from a padded border
    p = np.pad(m, 1)
    flood = p.copy()
    cv2.floodFill(flood, None, (0, 0), 1)
    holes = (flood == 0)
    p[holes] = 1
    return p[1:-1, 1:-1]


def wrist_to_bottom(m):
    """Rotate so the border with the most hand pixels (the cut wrist) is the bottom row.

    The source masks have a one-pixel empty frame, so the border is read one pixel inside.
    Ties prefer bottom, then right, top, left (the source's usual framing)."""
    m = m[1:-1, 1:-1]
    sides = [int(m[-1, :].sum()), int(m[:, -1].sum()), int(m[0, :].sum()), int(m[:, 0].sum())]
    s = int(np.argmax(sides))  # 0 bottom, 1 right, 2 top, 3 left
    if sides[s] < 4:
        return None, 0
    r = {0: m, 1: np.rot90(m, k=-1), 2: np.rot90(m, k=2), 3: np.rot90(m, k=1)}[s]
    r = np.ascontiguousarray(r)
    if int(r[-1, :].sum()) != sides[s]:
        raise RuntimeError("rotation bug: wrist not at the bottom")
    return r, sides[s]


def crop(m):
    ys, xs = np.nonzero(m)
    return m[ys.min():ys.max() + 1, xs.min():xs.max() + 1]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hdf5", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--per-pose", type=int, default=80)
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    if a.per_pose < 1:
        ap.error("--per-pose must be >= 1")
    try:
        import h5py
    except ImportError as e:
        sys.stderr.write(f"extract_silhouettes: {e}; install python3-h5py\n")
        return 2
    try:
        f = h5py.File(a.hdf5, "r")
        arrays = {"Xt": (f["Xt"][:], f["yt"][:]), "Xv": (f["Xv"][:], f["yv"][:])}
    except (OSError, KeyError) as e:
        sys.stderr.write(f"extract_silhouettes: cannot read '{a.hdf5}': {e}\n")
        return 2
    rows = []
    for pose, names in POSES.items():
        os.makedirs(os.path.join(a.out, pose), exist_ok=True)
        taken = 0
        # a quarter from the test split (other recordings), the rest from the train split,
        # each spread evenly over its samples
        for arr, share in (("Xv", want_share(a.per_pose, 4)), ("Xt", None)):
            X, y = arrays[arr]
            cands = sorted(int(i) for nm in names for i in np.nonzero(y == SOURCE_CLASSES[nm])[0])
            goal = share if share is not None else a.per_pose - taken
            got = 0
            for p in np.linspace(0, len(cands) - 1, goal * 3).astype(int):
                if got >= goal:
                    break
                i = cands[p]
                nm = [n for n in names if SOURCE_CLASSES[n] == y[i]][0]
                m = clean(X[i])
                if m is None or m.sum() < 300:
                    continue
                r, wrist = wrist_to_bottom(m)
                if r is None:
                    continue
                r = crop(r)
                if r.shape[0] < 24 or r.shape[1] < 12:
                    continue
                name = f"{pose}/{arr}_{i:05d}.png"
                if not cv2.imwrite(os.path.join(a.out, name), (r * 255).astype(np.uint8),
                                   [cv2.IMWRITE_PNG_BILEVEL, 1]):
                    sys.stderr.write(f"extract_silhouettes: cannot write {name}\n")
                    return 2
                rows.append((name, pose, nm, arr, i, r.shape[1], r.shape[0], wrist))
                got += 1
            taken += got
    tmp = os.path.join(a.out, "manifest.csv.tmp")
    with open(tmp, "w") as out:
        out.write("file,pose,source_class,source_array,source_index,person,width_px,height_px,"
                  "wrist_px\n")
        for r in rows:
            out.write(f"{r[0]},{r[1]},{r[2]},{r[3]},{r[4]},unknown,{r[5]},{r[6]},{r[7]}\n")
        out.flush()
        os.fsync(out.fileno())
    os.replace(tmp, os.path.join(a.out, "manifest.csv"))
    print(f"{len(rows)} silhouettes -> {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
