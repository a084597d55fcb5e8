#!/usr/bin/python3
"""Real touchscreen records -> contact timelines for the temporal gesture recogniser.

Implements the recipe pre-registered in docs/validation_protocol.md ("Issue 23 (second
source): real touchscreen records"); change nothing here without an entry in that section's
"Changes (touchscreen records)" list. Two inputs:

  --bioident DIR   BioIdent raw data (Antal et al.): DIR holds rawdata.csv and devices.csv as in
                   BIOIDENT_RAWDATA.ZIP (or give the .zip itself).
  --aosp FILE      Android frameworks/native libs/input/tests/VelocityTracker_test.cpp: its 18
                   "SailfishFling*" recordings (Pixel, 1080 x 1920 px, 441 ppi).

Output (a folder, each file written atomically), the layout ss_timeline_eval and
render_timeline.py read:

  timeline.csv  sequence,time_ms,track,contact,x_px,y_px,area_px (one row per output frame and
                present track; track 0 = a frame without any track; contact 0 = hovering)
  truth.csv     sequence,track,gesture,start_ms,end_ms,touches,path_cm,source_key
  summary.txt   counts (touches, truths per gesture, truths without a contact frame) and the
                stroke path lengths in cm (a property of the records, not a score)

Usage:
  /usr/bin/python3 tools/realhand/touchlog_timeline.py (--bioident DIR|ZIP | --aosp FILE)
      --out DIR [--fps 30]
"""
import argparse
import bisect
import csv
import io
import math
import os
import re
import sys
import zipfile

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from timeline_io import TIMELINE_HEADER, timeline_row, write_outputs  # noqa: E402

PX_PER_CM = 7.6            # the recogniser's default image scale
CENTRE_PX = (320.0, 240.0)  # the screen centre goes here
FINGER_CM2 = 1.5           # every contact is a fingertip (the logs have no physical area)
SAME_TRACK_GAP_MS = 1000.0  # lift -> next down within this: the finger stays (same track)
MAX_GAP_MS = 2000.0        # longer gaps are shortened to this
DOUBLE_TAP_GAP_MS = 300.0  # Android's DOUBLE_TAP_TIMEOUT: taps closer than this are one truth
SAILFISH_PPI = 441.0
SAILFISH_RES = (1080, 1920)


def fail(msg):
    print("touchlog_timeline.py: error: " + msg, file=sys.stderr)
    sys.exit(2)


class Touch:
    """One finger from touch-down to lift: samples (t_ms, x_cm, y_cm, x_raw, y_raw)."""

    def __init__(self, samples, key):
        self.samples = samples
        self.key = key

    @property
    def down(self):
        return self.samples[0][0]

    @property
    def up(self):
        return self.samples[-1][0]

    def displaced(self):
        x0, y0 = self.samples[0][3], self.samples[0][4]
        return any(s[3] != x0 or s[4] != y0 for s in self.samples)

    def path_cm(self):
        return sum(math.hypot(b[1] - a[1], b[2] - a[2])
                   for a, b in zip(self.samples, self.samples[1:]))


# ------------------------------------------------------------------------------ readers

def _open_bioident(path):
    """-> (rawdata text, devices text)."""
    try:
        if os.path.isdir(path):
            with open(os.path.join(path, "rawdata.csv"), newline="") as fh:
                raw = fh.read()
            with open(os.path.join(path, "devices.csv"), newline="") as fh:
                dev = fh.read()
            return raw, dev
        with zipfile.ZipFile(path) as z:
            names = {os.path.basename(n).lower(): n for n in z.namelist()}
            if "rawdata.csv" not in names or "devices.csv" not in names:
                fail("%s: the zip holds no rawdata.csv and devices.csv" % path)
            return (z.read(names["rawdata.csv"]).decode("utf-8"),
                    z.read(names["devices.csv"]).decode("utf-8"))
    except (OSError, zipfile.BadZipFile, UnicodeDecodeError) as e:
        fail("cannot read BioIdent data from %s: %s" % (path, e))


def read_bioident(path):
    """-> list of streams (key, width_cm, height_cm, [Touch]) in first-appearance order."""
    raw, dev = _open_bioident(path)
    devices = {}
    for n, r in enumerate(csv.DictReader(io.StringIO(dev)), start=2):
        try:
            w, h = (int(v) for v in r["resolution"].lower().split("x"))
            devices[r["device_id"].strip()] = (float(r["xdpi"]), float(r["ydpi"]), w, h)
        except (KeyError, ValueError, AttributeError) as e:
            fail("devices.csv line %d: %s" % (n, e))
    streams = {}
    open_touch = {}
    orphans = [0]
    rd = csv.DictReader(io.StringIO(raw))
    need = {"device_id", "user_id", "doc_type", "time", "action", "x_coor", "y_coor"}
    if not rd.fieldnames or not need <= set(rd.fieldnames):
        fail("rawdata.csv: header must hold %s" % ",".join(sorted(need)))
    for n, r in enumerate(rd, start=2):
        try:
            key = (r["device_id"].strip(), r["user_id"].strip(), r["doc_type"].strip())
            t = float(r["time"])
            a = int(r["action"])
            xr, yr = float(r["x_coor"]), float(r["y_coor"])
        except (TypeError, ValueError) as e:
            fail("rawdata.csv line %d: %s" % (n, e))
        if key[0] not in devices:
            fail("rawdata.csv line %d: device %s not in devices.csv" % (n, key[0]))
        xdpi, ydpi, _, _ = devices[key[0]]
        s = (t, xr / xdpi * 2.54, yr / ydpi * 2.54, xr, yr)
        if key not in streams:
            w, h = devices[key[0]][2] / xdpi * 2.54, devices[key[0]][3] / ydpi * 2.54
            streams[key] = ("bioident d%s u%s doc%s" % key, w, h, [])
        cur = open_touch.get(key)
        if cur and t < cur[-1][0]:
            fail("rawdata.csv line %d: time goes backwards within a touch" % n)
        if a == 0:
            if cur:
                fail("rawdata.csv line %d: touch-down before the previous touch's lift" % n)
            open_touch[key] = [s]
        elif a in (1, 2):
            if not cur:
                # a sample after the lift (BioIdent logs a move at the lift's time after some
                # lifts): it belongs to no touch (pre-registration, "Changes")
                orphans[0] += 1
                continue
            cur.append(s)
            if a == 1:
                streams[key][3].append(Touch(cur, streams[key][0]))
                open_touch[key] = None
        else:
            fail("rawdata.csv line %d: action must be 0, 1 or 2, got %d" % (n, a))
    if orphans[0]:
        print("touchlog_timeline.py: %d samples without a touch-down (after a lift) were left "
              "out" % orphans[0])
    left = sum(1 for v in open_touch.values() if v)
    if left:
        print("touchlog_timeline.py: %d touches without a lift at the end were left out" % left)
    return [v for v in streams.values() if v[3]]


def read_aosp(path):
    try:
        with open(path) as fh:
            text = fh.read()
    except OSError as e:
        fail("cannot read %s: %s" % (path, e))
    cm = 2.54 / SAILFISH_PPI
    touches = []
    for m in re.finditer(r"TEST_F\(VelocityTrackerTest,\s*(SailfishFling\w+)\)\s*\{(.*?)\n\}",
                         text, re.S):
        name, body = m.group(1), m.group(2)
        entries = re.findall(
            r"\{\s*(\d+)(ns|us|ms)\s*,\s*\{\{\s*([-\d.]+)\s*,\s*([-\d.]+)\s*\}\}\s*\}", body)
        if len(entries) < 2:
            fail("%s: %s has fewer than 2 samples" % (path, name))
        scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0}
        t0 = int(entries[0][0]) * scale[entries[0][1]]
        samples = [(int(t) * scale[u] - t0, float(x) * cm, float(y) * cm, float(x), float(y))
                   for t, u, x, y in entries]
        if any(b[0] < a[0] for a, b in zip(samples, samples[1:])):
            fail("%s: %s: time goes backwards" % (path, name))
        # on one clock: each touch-down 2000 ms after the previous lift
        start = touches[-1].up + MAX_GAP_MS if touches else 0.0
        samples = [(s[0] + start,) + s[1:] for s in samples]
        touches.append(Touch(samples, "aosp " + name))
    if len(touches) != 18:
        fail("%s: expected the 18 SailfishFling recordings, found %d" % (path, len(touches)))
    w, h = SAILFISH_RES[0] * cm, SAILFISH_RES[1] * cm
    # one sequence, each fling its own touch 2000 ms after the previous lift
    return [("aosp sailfish", w, h, touches)]


# ------------------------------------------------------------------------------ timeline

def place(touches):
    """Shortens long gaps: -> per touch its time offset (added to its log times), and the
    original gap before it (inf for the first)."""
    offsets, gaps = [], []
    t_end = None
    for tc in touches:
        if t_end is None:
            offset = MAX_GAP_MS - tc.down  # the first touch-down at 2000 ms
            gap = math.inf
        else:
            gap = tc.down - prev_up
            offset = t_end + min(gap, MAX_GAP_MS) - tc.down
        offsets.append(offset)
        gaps.append(gap)
        prev_up = tc.up
        t_end = tc.up + offset
    return offsets, gaps


def build(streams, fps):
    step = 1000.0 / fps
    area_px = FINGER_CM2 * PX_PER_CM * PX_PER_CM
    timeline = [TIMELINE_HEADER]
    truth = ["sequence,track,gesture,start_ms,end_ms,touches,path_cm,source_key"]
    counts = {"sequences": 0, "touches": 0, "truth_tap": 0, "truth_stroke": 0,
              "taps_merged_into_multi_tap_truths": 0, "truths_without_contact_frame": 0}
    paths = []
    for seq, (key, w_cm, h_cm, touches) in enumerate(streams, start=1):
        counts["sequences"] += 1
        counts["touches"] += len(touches)
        offsets, gaps = place(touches)
        # tracks: touches closer than SAME_TRACK_GAP_MS share one
        track_of, track = [], 0
        for g in gaps:
            if g > SAME_TRACK_GAP_MS:
                track += 1
            track_of.append(track)

        def to_img(xc, yc):
            return (CENTRE_PX[0] + (xc - w_cm / 2) * PX_PER_CM,
                    CENTRE_PX[1] + (yc - h_cm / 2) * PX_PER_CM)

        # placed touches: (track, down, up, times, points)
        placed = []
        for tc, off, tr in zip(touches, offsets, track_of):
            times = [s[0] + off for s in tc.samples]
            pts = [to_img(s[1], s[2]) for s in tc.samples]
            placed.append((tr, times[0], times[-1], times, pts))

        def frames_in(a, b):
            """frame indices k with a <= k * step < b"""
            return range(int(math.ceil(a / step - 1e-9)), int(math.ceil(b / step - 1e-9)))

        # truth, with consecutive no-displacement touches of one track <= 300 ms apart merged
        i = 0
        while i < len(touches):
            tc = touches[i]
            tr, down, up = placed[i][0], placed[i][1], placed[i][2]
            if tc.displaced():
                gesture, j = "stroke", i + 1
                paths.append(tc.path_cm())
            else:
                gesture, j = "tap", i + 1
                while (j < len(touches) and track_of[j] == tr and not touches[j].displaced()
                       and gaps[j] <= DOUBLE_TAP_GAP_MS):
                    j += 1
                if j - i > 1:
                    counts["taps_merged_into_multi_tap_truths"] += j - i
                up = placed[j - 1][2]
            if not any(len(frames_in(placed[k][1], placed[k][2])) for k in range(i, j)):
                counts["truths_without_contact_frame"] += 1
            counts["truth_" + gesture] += 1
            path = sum(touches[k].path_cm() for k in range(i, j))
            truth.append("%d,%d,%s,%.3f,%.3f,%d,%.3f,%s" % (seq, tr, gesture, down, up, j - i,
                                                          path, key))
            i = j

        # frames: a track is present from one frame before its first contact frame (or its
        # first touch-down when no frame falls inside its touches) to one frame after its last
        spans = {}
        for tr, down, up, _, _ in placed:
            ks = frames_in(down, up)
            first = ks[0] if len(ks) else int(math.floor(down / step))
            last = ks[-1] if len(ks) else int(math.ceil(up / step))
            a, b = spans.get(tr, (first, last))
            spans[tr] = (min(a, first - 1), max(b, last + 1))
        by_track = {}
        for p in placed:
            by_track.setdefault(p[0], []).append(p)
        downs = {tr: [p[1] for p in ps] for tr, ps in by_track.items()}
        order = sorted((a, b, tr) for tr, (a, b) in spans.items())
        n_frames = max(b for _, b, _ in order) + 2
        active, nxt = [], 0
        for k in range(n_frames):
            t = k * step
            while nxt < len(order) and order[nxt][0] <= k:
                active.append(order[nxt])
                nxt += 1
            active = [s for s in active if s[1] >= k]
            rows = []
            for _, _, tr in sorted(active, key=lambda s: s[2]):
                contact = None
                i = bisect.bisect_right(downs[tr], t) - 1
                if i >= 0:
                    _, down, up, times, pts = by_track[tr][i]
                    if down <= t < up:
                        contact = pts[bisect.bisect_right(times, t) - 1]
                rows.append(timeline_row(seq, t, tr + 1,
                                         None if contact is None else (*contact, area_px)))
            timeline.extend(rows or [timeline_row(seq, t, 0, None)])
    # track ids in truth are 1-based like the timeline's
    truth = [truth[0]] + [_shift_track(r) for r in truth[1:]]
    return timeline, truth, counts, paths


def _shift_track(row):
    f = row.split(",", 2)
    return "%s,%d,%s" % (f[0], int(f[1]) + 1, f[2])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--bioident", help="folder with rawdata.csv + devices.csv, or the zip")
    src.add_argument("--aosp", help="frameworks/native libs/input/tests/VelocityTracker_test.cpp")
    ap.add_argument("--out", required=True, help="output folder (created)")
    ap.add_argument("--fps", type=float, default=30.0, help="output frame rate (5..240)")
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    import ss_version  # tools/ss_version.py
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    if not (5 <= a.fps <= 240):
        fail("--fps must be in [5, 240], got %g" % a.fps)
    streams = read_bioident(a.bioident) if a.bioident else read_aosp(a.aosp)
    if not streams:
        fail("no touches read")
    timeline, truth, counts, paths = build(streams, a.fps)
    summary = "".join("%s %d\n" % kv for kv in counts.items()) + "fps %g\n" % a.fps
    if paths:
        p = sorted(paths)
        q = [p[min(len(p) - 1, int(f * len(p)))] for f in (0.05, 0.25, 0.5, 0.75, 0.95)]
        summary += ("stroke path cm p5/p25/p50/p75/p95 %s; < 3 cm: %d of %d\n"
                    % ("/".join("%.2f" % v for v in q), sum(1 for v in p if v < 3.0), len(p)))
    write_outputs(a.out, timeline, truth, summary)


if __name__ == "__main__":
    main()
