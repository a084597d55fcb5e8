#!/usr/bin/python3
"""Corpus of Social Touch (CoST) -> contact timelines for the temporal gesture recogniser.

Implements the recipe pre-registered in docs/validation_protocol.md ("Issue 23: independent
real timing"); change nothing here without an entry in that section's "Changes" list.

Input: CoST.csv as published (one row per 135 Hz frame: subject, variant, gesture, frame
counter 1..n, ch1..ch64; a header row). Output (a folder, each file written atomically):

  timeline.csv  sequence,time_ms,track,contact,x_px,y_px,area_px
                one row per (output frame, track present); a frame with no track has one row
                with track 0. contact 0: the track hovers (x, y, area empty).
  truth.csv     sequence,track,gesture,start_ms,end_ms,cost_gesture,subject,variant,capture
  summary.txt   counts: captures read, mapped, left out (not mapped / no contact)

Usage:
  /usr/bin/python3 tools/realhand/cost_timeline.py --cost CoST.csv --out DIR [--fps 30]
"""
import argparse
import csv
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from atomic_write import write_atomic  # noqa: E402  (tools/atomic_write.py)

COST_GESTURES = ["grab", "hit", "massage", "pat", "pinch", "poke", "press", "rub", "scratch",
                 "slap", "squeeze", "stroke", "tap", "tickle"]
VARIANTS = ["gentle", "normal", "rough"]
MAPPING = {"tap": "tap", "poke": "tap", "pat": "pat", "stroke": "stroke", "rub": "rub",
           "press": "hold", "hit": "hit", "slap": "hit"}

COST_HZ = 135.0
CELL_CM = 2.0               # grid pitch
PRESSED = 50.0              # value - baseline for a pressed cell
BASELINE_PERCENTILE = 10.0  # per subject and channel
PX_PER_CM = 7.6
CENTRE_PX = (320.0, 240.0)
GAP_MS = 1000.0             # no track between captures


def fail(msg):
    print("cost_timeline.py: error: " + msg, file=sys.stderr)
    sys.exit(2)


def read_cost(path):
    """-> list of captures (subject, variant, gesture, frames[n, 64] float) in file order."""
    try:
        raw = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as e:
        fail("cannot read %s as CoST.csv (header + numeric rows): %s" % (path, e))
    if raw.shape[1] != 68:
        fail("%s: %d columns, CoST.csv has 68 (subject, variant, gesture, frame, ch1..ch64)"
             % (path, raw.shape[1]))
    captures = []
    start = 0
    for i in range(1, raw.shape[0] + 1):
        if i == raw.shape[0] or raw[i, 3] == 1 or any(raw[i, :3] != raw[start, :3]):
            s, v, g = (int(x) for x in raw[start, :3])
            if not (1 <= v <= 3 and 1 <= g <= 14):
                fail("%s: row %d: variant %d / gesture %d out of range" % (path, start + 2, v, g))
            captures.append((s, v, g, raw[start:i, 4:]))
            start = i
    return captures


def baselines(captures):
    by_subject = {}
    for s, _, _, f in captures:
        by_subject.setdefault(s, []).append(f)
    return {s: np.percentile(np.concatenate(fs), BASELINE_PERCENTILE, axis=0)
            for s, fs in by_subject.items()}


_rows, _cols = np.divmod(np.arange(64), 8)
CELL_X_CM = (_cols + 0.5) * CELL_CM
CELL_Y_CM = (_rows + 0.5) * CELL_CM


def contacts(frames, base):
    """-> per CoST frame: None or (x_px, y_px, area_px)."""
    out = []
    for f in frames:
        w = f - base
        pressed = w >= PRESSED
        if not pressed.any():
            out.append(None)
            continue
        ww = np.where(pressed, w, 0.0)
        x_cm = float((ww * CELL_X_CM).sum() / ww.sum())
        y_cm = float((ww * CELL_Y_CM).sum() / ww.sum())
        grid_half = 4 * CELL_CM
        x = CENTRE_PX[0] + (x_cm - grid_half) * PX_PER_CM
        y = CENTRE_PX[1] + (y_cm - grid_half) * PX_PER_CM
        area = float(pressed.sum()) * CELL_CM * CELL_CM * PX_PER_CM * PX_PER_CM
        out.append((x, y, area))
    return out


def build(captures, fps):
    base = baselines(captures)
    step = 1000.0 / fps
    timeline = ["sequence,time_ms,track,contact,x_px,y_px,area_px"]
    truth = ["sequence,track,gesture,start_ms,end_ms,cost_gesture,subject,variant,capture"]
    counts = {"read": len(captures), "mapped": 0, "not_mapped": 0, "no_contact": 0}
    # one sequence per (subject, variant), captures in file order
    seqs = {}
    for idx, (s, v, g, f) in enumerate(captures):
        seqs.setdefault((s, v), []).append((idx, g, f))
    for seq_id, ((s, v), caps) in enumerate(sorted(seqs.items()), start=1):
        # place the captures on the sequence's clock (ms), each with its own track
        placed = []  # (track, t0, contacts per CoST frame, first, last, gesture, idx)
        t = 0.0
        track = 0
        for idx, g, f in caps:
            name = COST_GESTURES[g - 1]
            if name not in MAPPING:
                counts["not_mapped"] += 1
                continue
            cs = contacts(f, base[s])
            on = [i for i, c in enumerate(cs) if c is not None]
            if not on:
                counts["no_contact"] += 1
                continue
            counts["mapped"] += 1
            track += 1
            first, last = on[0], on[-1]
            t0 = t + step  # one output frame of hover before the first contact
            placed.append((track, t0 - first * 1000.0 / COST_HZ, cs, first, last, name, idx))
            lift_ms = (last + 1) * 1000.0 / COST_HZ
            start_ms = t0
            end_ms = t0 + lift_ms - first * 1000.0 / COST_HZ
            truth.append("%d,%d,%s,%.3f,%.3f,%s,%d,%s,%d" % (
                seq_id, track, MAPPING[name], start_ms, end_ms, name, s, VARIANTS[v - 1], idx))
            t = end_ms + step + GAP_MS
        if not placed:
            continue
        n_frames = int(t // step) + 1
        for k in range(n_frames):
            tk = k * step
            rows = []
            for tr, origin, cs, first, last, _, _ in placed:
                # the track lives from one output frame before its first contact to one after
                # its lift
                appear = origin + first * 1000.0 / COST_HZ - step
                leave = origin + (last + 1) * 1000.0 / COST_HZ + step
                if tk < appear - 1e-6 or tk > leave + 1e-6:
                    continue
                i = int(round((tk - origin) * COST_HZ / 1000.0))
                c = cs[i] if first <= i <= last else None
                if c is None:
                    rows.append("%d,%.3f,%d,0,,," % (seq_id, tk, tr))
                else:
                    rows.append("%d,%.3f,%d,1,%.2f,%.2f,%.1f" % (seq_id, tk, tr, c[0], c[1], c[2]))
            if not rows:
                rows.append("%d,%.3f,0,0,,," % (seq_id, tk))
            timeline.extend(rows)
    return timeline, truth, counts


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cost", required=True, help="CoST.csv as published")
    ap.add_argument("--out", required=True, help="output folder (created)")
    ap.add_argument("--fps", type=float, default=30.0, help="output frame rate (5..240)")
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    import ss_version  # tools/ss_version.py
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    if not (5 <= a.fps <= 240):
        fail("--fps must be in [5, 240], got %g" % a.fps)
    captures = read_cost(a.cost)
    if not captures:
        fail("%s: no captures" % a.cost)
    timeline, truth, counts = build(captures, a.fps)
    os.makedirs(a.out, exist_ok=True)
    write_atomic(os.path.join(a.out, "timeline.csv"), "\n".join(timeline) + "\n")
    write_atomic(os.path.join(a.out, "truth.csv"), "\n".join(truth) + "\n")
    summary = "".join("%s %d\n" % kv for kv in counts.items()) + "fps %g\n" % a.fps
    write_atomic(os.path.join(a.out, "summary.txt"), summary)
    sys.stdout.write(summary)


if __name__ == "__main__":
    main()
