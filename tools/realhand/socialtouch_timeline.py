#!/usr/bin/python3
"""SocialTouch capacitive records -> contact timelines for the temporal gesture recogniser.

Implements the recipe pre-registered in docs/validation_protocol.md ("Issue 23 (third source):
SocialTouch capacitive records"); change nothing here without an entry in that section's
"Changes" list.

Input: a folder of the source's csv files (touch_p<P>_g<G>-<date>.csv: a header row, then one row
per frame: participantID, gesture, repetition, frameID, time (ms from 0 in each repetition),
pixel0..pixel455 = 19 x 24 cells row-major, 0..255) and the gesture names (its
audio/GesturesRated.csv: id, gesture_name, ...; row k names gesture id k). Output (a folder,
each file written atomically), as tools/realhand/cost_timeline.py writes them:

  timeline.csv  sequence,time_ms,track,contact,x_px,y_px,area_px
  truth.csv     sequence,track,gesture,start_ms,end_ms,source_gesture,participant,repetition
  summary.txt   counts: repetitions read, mapped, left out (not mapped / no contact)

Usage:
  /usr/bin/python3 tools/realhand/socialtouch_timeline.py --data DIR --names GesturesRated.csv
      --out DIR [--fps 30] [--pitch-cm 1]
Exit 0 on success, 2 on bad arguments or input (message on stderr naming the file and line).
"""
import argparse
import csv
import glob
import os
import sys

import numpy as np

from timeline_io import TIMELINE_HEADER, grid_contacts, sample_tracks, write_outputs  # noqa: E402

ROWS, COLS = 19, 24
MAPPING = {
    "finger_touch_short_light": "tap", "finger_touch_short_strong": "tap", "poke_short": "tap",
    "poke_strong": "tap", "tap_light": "tap", "tap_multiple": "tap",
    "pat_short": "pat", "pat_long": "pat",
    "stroke_leftright": "stroke", "stroke_topdown": "stroke",
    "finger_stroke_surface_slow": "stroke", "finger_stroke_surface_fast": "stroke",
    "finger_touch_long_light": "hold", "finger_touch_long_strong": "hold",
    "contact_one_hand": "hold",
    "slap_strong": "hit", "slap_mid": "hit", "hit_side": "hit", "hit_top": "hit",
}
TOUCHED = 13.0              # value - baseline for a touched cell (5% of 8 bits)
BASELINE_PERCENTILE = 10.0  # per participant and cell
GAP_MS = 1000.0             # no track between repetitions


def fail(msg):
    print("socialtouch_timeline.py: error: " + msg, file=sys.stderr)
    sys.exit(2)


def read_names(path):
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e))
    if not rows or rows[0][:2] != ["id", "gesture_name"]:
        fail("%s: expected a header starting with id,gesture_name" % path)
    names = {}
    for n, r in enumerate(rows[1:], start=2):
        try:
            names[int(r[0])] = r[1]
        except (ValueError, IndexError):
            fail("%s line %d: expected id,gesture_name" % (path, n))
    return names


def read_file(path):
    """-> list of repetitions (participant, gesture, repetition, times[n], frames[n, 456])."""
    try:
        raw = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as e:
        fail("cannot read %s (header + numeric rows): %s" % (path, e))
    if raw.shape[1] != 5 + ROWS * COLS:
        fail("%s: %d columns, expected %d (participantID, gesture, repetition, frameID, time, "
             "pixel0..pixel%d)" % (path, raw.shape[1], 5 + ROWS * COLS, ROWS * COLS - 1))
    reps = []
    start = 0
    for i in range(1, raw.shape[0] + 1):
        if i == raw.shape[0] or any(raw[i, :3] != raw[start, :3]):
            t = raw[start:i, 4]
            if np.any(np.diff(t) <= 0):
                fail("%s line %d: the times of the repetition starting here must increase" % (path, start + 2))
            p, g, r = (int(x) for x in raw[start, :3])
            reps.append((p, g, r, t, raw[start:i, 5:].astype(np.float32)))
            start = i
    return reps


def contacts(frames, base, pitch):
    """-> per record frame: None or (x_px, y_px, area_px)."""
    return grid_contacts(frames, base, ROWS, COLS, pitch, TOUCHED)


def build(files, names, fps, pitch):
    """files: list of (file name, repetitions) in name order."""
    by_participant = {}
    for _, reps in files:
        for p, _, _, _, f in reps:
            by_participant.setdefault(p, []).append(f)
    base = {p: np.percentile(np.concatenate(fs), BASELINE_PERCENTILE, axis=0)
            for p, fs in by_participant.items()}
    step = 1000.0 / fps
    timeline = [TIMELINE_HEADER]
    truth = ["sequence,track,gesture,start_ms,end_ms,source_gesture,participant,repetition"]
    counts = {"read": 0, "mapped": 0, "not_mapped": 0, "no_contact": 0}
    seq_id = 0
    for _, reps in files:
        placed = []  # (track, origin, times, contacts, first, last)
        t = 0.0
        track = 0
        counts["read"] += len(reps)
        for p, g, r, times, frames in reps:
            if g not in names:
                fail("gesture id %d has no name in the names file" % g)
            name = names[g]
            if name not in MAPPING:
                counts["not_mapped"] += 1
                continue
            cs = contacts(frames, base[p], pitch)
            on = [i for i, c in enumerate(cs) if c is not None]
            if not on:
                counts["no_contact"] += 1
                continue
            counts["mapped"] += 1
            if track == 0:
                seq_id += 1
            track += 1
            first, last = on[0], on[-1]
            # the lift: the first record frame after the last contact (or one median frame
            # interval after it when the repetition ends in contact)
            lift = times[last + 1] if last + 1 < len(times) else (
                times[last] + (float(np.median(np.diff(times))) if len(times) > 1 else step))
            t0 = t + step  # one output frame of hover before the first contact
            origin = t0 - times[first]
            placed.append((track, origin, times, cs, first, last, lift))
            truth.append("%d,%d,%s,%.3f,%.3f,%s,%d,%d" % (
                seq_id, track, MAPPING[name], t0, origin + lift, name, p, r))
            t = origin + lift + step + GAP_MS
        if not placed:
            continue
        tracks = []
        for tr, origin, times, cs, first, last, lift in placed:
            def contact_at(tk, origin=origin, times=times, cs=cs, first=first, last=last,
                           lift=lift):
                rel = tk - origin  # on the repetition's own clock
                if not times[first] - 1e-6 <= rel < lift - 1e-6:  # hover before and after
                    return None
                i = int(np.argmin(np.abs(times - rel)))  # the nearest record frame
                return cs[i] if first <= i <= last else None
            tracks.append((tr, origin + times[first] - step, origin + lift + step, contact_at))
        timeline.extend(sample_tracks(seq_id, int(t // step) + 1, step, tracks))
    return timeline, truth, counts


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="folder of touch_p*_g*.csv files")
    ap.add_argument("--names", required=True, help="the source's audio/GesturesRated.csv")
    ap.add_argument("--out", required=True, help="output folder (created)")
    ap.add_argument("--fps", type=float, default=30.0, help="output frame rate (5..240)")
    ap.add_argument("--pitch-cm", type=float, default=1.0,
                    help="the grid's cell pitch in cm (not published; the recipe's headline is "
                         "1, with 0.75 and 1.5 beside it)")
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    import ss_version  # tools/ss_version.py
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    if not (5 <= a.fps <= 240):
        fail("--fps must be in [5, 240], got %g" % a.fps)
    if not (0.1 <= a.pitch_cm <= 10):
        fail("--pitch-cm must be in [0.1, 10], got %g" % a.pitch_cm)
    names = read_names(a.names)
    paths = sorted(glob.glob(os.path.join(a.data, "touch_p*_g*.csv")))
    if not paths:
        fail("%s: no touch_p*_g*.csv files" % a.data)
    files = [(os.path.basename(p), read_file(p)) for p in paths]
    timeline, truth, counts = build(files, names, a.fps, a.pitch_cm)
    summary = "".join("%s %d\n" % kv for kv in counts.items()) + "fps %g\npitch_cm %g\n" % (
        a.fps, a.pitch_cm)
    write_outputs(a.out, timeline, truth, summary)

if __name__ == "__main__":
    main()
