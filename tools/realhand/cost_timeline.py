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
import os
import sys

import numpy as np

from timeline_io import TIMELINE_HEADER, grid_contacts, sample_tracks, write_outputs  # noqa: E402

COST_GESTURES = ["grab", "hit", "massage", "pat", "pinch", "poke", "press", "rub", "scratch",
                 "slap", "squeeze", "stroke", "tap", "tickle"]
VARIANTS = ["gentle", "normal", "rough"]
MAPPING = {"tap": "tap", "poke": "tap", "pat": "pat", "stroke": "stroke", "rub": "rub",
           "press": "hold", "hit": "hit", "slap": "hit"}

COST_HZ = 135.0
CELL_CM = 2.0               # grid pitch
PRESSED = 50.0              # value - baseline for a pressed cell
BASELINE_PERCENTILE = 10.0  # per subject and channel
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


def contacts(frames, base):
    """-> per CoST frame: None or (x_px, y_px, area_px)."""
    return grid_contacts(frames, base, 8, 8, CELL_CM, PRESSED)


def build(captures, fps):
    base = baselines(captures)
    step = 1000.0 / fps
    timeline = [TIMELINE_HEADER]
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
        tracks = []
        for tr, origin, cs, first, last, _, _ in placed:
            # the track lives from one output frame before its first contact to one after its
            # lift
            def contact_at(tk, origin=origin, cs=cs, first=first, last=last):
                i = int(round((tk - origin) * COST_HZ / 1000.0))
                return cs[i] if first <= i <= last else None
            tracks.append((tr, origin + first * 1000.0 / COST_HZ - step,
                           origin + (last + 1) * 1000.0 / COST_HZ + step, contact_at))
        timeline.extend(sample_tracks(seq_id, int(t // step) + 1, step, tracks))
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
    summary = "".join("%s %d\n" % kv for kv in counts.items()) + "fps %g\n" % a.fps
    write_outputs(a.out, timeline, truth, summary)

if __name__ == "__main__":
    main()
