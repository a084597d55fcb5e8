"""Shared steps of the tools/handsets extractors: one binary hand mask in, one normalised
silhouette out (the normalisation of tools/realhand/extract_silhouettes.py, plus a wrist cut).

normalise(mask) -> (silhouette uint8 0/1, wrist width px) or (None, reason):
  1. largest 8-connected component, holes filled;
  2. rotated by a multiple of 90 degrees so that the image border the arm is cut by (the
     border with the most hand pixels) is the bottom row (arm_down=True: the source's hands
     are upright and their arm ends inside the image: no rotation);
  3. forearm removed: the mask is cut at the wrist, the narrowest row in the lower half
     (tools/realhand's renderer scales the silhouette height to a hand length, so a forearm
     left in would shrink the hand);
  4. cropped to the hand; silhouettes wider than 1.2x their length are rejected (a hand
     seen edge-on or cut in the wrong place).
write_png1(path, sil): 1-bit PNG, written to a temporary name and renamed (atomic).
write_manifest(folder, header, rows): manifest.csv, atomic (temp + fsync + rename).
Single-threaded helpers without state.
"""
import os

import numpy as np
import cv2


def largest_filled(m):
    m = (m > 0).astype(np.uint8)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    if n <= 1:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    m = (lab == k).astype(np.uint8)
    p = np.pad(m, 1)
    flood = p.copy()
    cv2.floodFill(flood, None, (0, 0), 1)
    p[flood == 0] = 1
    return p[1:-1, 1:-1]


def wrist_to_bottom(m, inset=0):
    """Rotate so the border (read `inset` pixels inside) with most hand pixels is the bottom."""
    if inset:
        m = m[inset:-inset, inset:-inset]
    sides = [int(m[-1, :].sum()), int(m[:, -1].sum()), int(m[0, :].sum()), int(m[:, 0].sum())]
    s = int(np.argmax(sides))  # 0 bottom, 1 right, 2 top, 3 left
    if sides[s] < 4:
        return None
    r = {0: m, 1: np.rot90(m, k=-1), 2: np.rot90(m, k=2), 3: np.rot90(m, k=1)}[s]
    r = np.ascontiguousarray(r)
    if int(r[-1, :].sum()) != sides[s]:
        raise RuntimeError("rotation bug: wrist not at the bottom")
    return r


def crop(m):
    ys, xs = np.nonzero(m)
    return m[ys.min():ys.max() + 1, xs.min():xs.max() + 1]


def cut_at_wrist(m, lower=0.5, skip=0.0):
    """Cut at the narrowest row of the lower `lower` share of the silhouette (wrist at bottom).
    Width of a row = span of its hand pixels. The highest row within 4% of the minimum width is
    taken (the forearm near the wrist is nearly as narrow as the wrist itself). The bottom `skip`
    share is not searched (a ragged arm end inside the image is narrower than any wrist)."""
    m = crop(m)
    h = m.shape[0]
    top = int(h * (1 - lower))
    widths = []
    for y in range(top, h - int(h * skip)):
        xs = np.nonzero(m[y])[0]
        widths.append(xs.max() - xs.min() + 1 if len(xs) else 10 ** 9)
    widths = np.array(widths)
    wmin = widths.min()
    cand = np.nonzero(widths <= wmin * 1.04)[0]
    y = top + int(cand.min())
    out = m[:y + 1].copy()
    out = largest_filled(out)
    if out is None:
        return None, 0
    out = crop(out)
    # the cut row must stay the bottom row: keep it even if crop() moved it
    return out, int(out[-1].sum())


def normalise(mask, inset=0, min_area=300, arm_down=False):
    """arm_down: the source's hands are upright with the arm ending inside the image (not cut
    by a border); the lowest part of the mask is then taken as the arm."""
    m = largest_filled(mask)
    if m is None or int(m.sum()) < min_area:
        return None, "empty or too small"
    r = crop(m) if arm_down else wrist_to_bottom(m, inset)
    if r is None:
        return None, "hand does not touch a border (no wrist)"
    r, wrist = cut_at_wrist(r, skip=0.12 if arm_down else 0.0)
    if r is None or r.shape[0] < 24 or r.shape[1] < 12:
        return None, "too small after the wrist cut"
    if wrist < 4:
        return None, "wrist row too narrow"
    if r.shape[1] > 1.2 * r.shape[0]:
        return None, "wider than long (hand seen edge-on or badly cut)"
    return r, wrist


def write_png1(path, sil):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    ok, buf = cv2.imencode(".png", (sil * 255).astype(np.uint8), [cv2.IMWRITE_PNG_BILEVEL, 1])
    if not ok:
        raise OSError(f"cannot encode {path}")
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(buf.tobytes())
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def write_manifest(folder, header, rows):
    tmp = os.path.join(folder, "manifest.csv.tmp")
    with open(tmp, "w") as out:
        out.write(",".join(header) + "\n")
        for r in rows:
            out.write(",".join(str(v) for v in r) + "\n")
        out.flush()
        os.fsync(out.fileno())
    os.replace(tmp, os.path.join(folder, "manifest.csv"))


def split_of(key, heldout_share):
    """Deterministic split by a stable hash of the source file name (no RNG, no order)."""
    import zlib
    return "heldout" if (zlib.crc32(key.encode()) % 1000) < heldout_share * 1000 else "train"
