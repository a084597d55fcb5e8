#!/usr/bin/python3
"""Scores ss_track's gesture rows (CSV, kind `gesture`) of rendered timelines against truth.csv.

For render_timeline.py's output: run ss_track once per sequence folder (with --timestamps from
frames.csv), then give each sequence's CSV here. The rule is ss_timeline_eval's (the issue 23
protocols in docs/validation_protocol.md) with one difference: ss_track numbers its own tracks,
so a prediction belongs to a truth by time alone (its interval overlaps the truth's, widened by
one frame interval), not by track id. That is unambiguous only when one hand touches at a time,
as in the touchscreen records (one finger per stream); do not use it for multi-hand timelines.
Last word per (track, start_ms); double_tap counts as tap; the first prediction of the truth's
gesture is a true positive (latency = its frame time - the truth's end), further ones of that
gesture are ignored, others are false positives; unmatched predictions are false positives.

Usage:
  /usr/bin/python3 tools/realhand/score_gesture_rows.py --truth truth.csv --fps 30
      SEQ=EVENTS.csv [SEQ=EVENTS.csv ...]
"""
import argparse
import csv
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/
import ss_version  # noqa: E402

GESTURES = ["tap", "double_tap", "pat", "stroke", "rub", "hold", "hit", "hug", "punch",
            "two_hands"]


def fail(msg):
    print("score_gesture_rows.py: error: " + msg, file=sys.stderr)
    sys.exit(2)


def read_events(path):
    last = {}
    try:
        with open(path, newline="") as fh:
            for n, r in enumerate(csv.DictReader(fh), start=2):
                if r.get("kind") != "gesture":
                    continue
                g = r["touch_gesture"]
                if g not in GESTURES:
                    fail("%s line %d: unknown touch_gesture '%s'" % (path, n, g))
                try:
                    key = (int(r["track_id"]), float(r["start_ms"]))
                    last[key] = ("tap" if g == "double_tap" else g, float(r["start_ms"]),
                                 float(r["end_ms"]), float(r["timestamp_ms"]))
                except (TypeError, ValueError) as e:
                    fail("%s line %d: %s" % (path, n, e))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e))
    return list(last.values())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--truth", required=True)
    ap.add_argument("--fps", type=float, required=True)
    ap.add_argument("events", nargs="+", help="SEQ=ss_track CSV of that sequence")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    if not 5 <= a.fps <= 240:
        fail("--fps must be in [5, 240]")
    widen = 1000.0 / a.fps
    truth = {}
    try:
        with open(a.truth, newline="") as fh:
            for r in csv.DictReader(fh):
                truth.setdefault(int(r["sequence"]), []).append(
                    (r["gesture"], float(r["start_ms"]), float(r["end_ms"])))
    except (OSError, KeyError, ValueError) as e:
        fail("cannot read %s: %s" % (a.truth, e))
    tp = {g: 0 for g in GESTURES}
    fp, fn = dict(tp), dict(tp)
    lat = []
    conf = {}
    for spec in a.events:
        if "=" not in spec:
            fail("expected SEQ=EVENTS.csv, got '%s'" % spec)
        seq, path = spec.split("=", 1)
        events = read_events(path)
        used = [False] * len(events)
        for g, s, e in truth.get(int(seq), []):
            hit, other = False, None
            for k, (pg, ps, pe, pt) in enumerate(events):
                if used[k] or pe < s - widen or ps > e + widen:
                    continue
                used[k] = True
                if pg == g:
                    if not hit:
                        hit = True
                        tp[g] += 1
                        lat.append(pt - e)
                else:
                    fp[pg] += 1
                    other = other or pg
            if not hit:
                fn[g] += 1
            key = (g, g if hit else (other or "none"))
            conf[key] = conf.get(key, 0) + 1
        for k, ev in enumerate(events):
            if not used[k]:
                fp[ev[0]] += 1
                conf[("none", ev[0])] = conf.get(("none", ev[0]), 0) + 1
    f1s = []
    print("gesture      precision recall  F1     n_true")
    for g in GESTURES:
        if tp[g] + fp[g] + fn[g] == 0:
            continue
        p = tp[g] / (tp[g] + fp[g]) if tp[g] + fp[g] else 0.0
        r = tp[g] / (tp[g] + fn[g]) if tp[g] + fn[g] else 0.0
        f = 2 * p * r / (p + r) if p + r else 0.0
        f1s.append(f)
        print("%-12s %.3f     %.3f   %.3f  %d" % (g, p, r, f, tp[g] + fn[g]))
    lat.sort()
    q = lambda x: lat[min(len(lat) - 1, int(x * (len(lat) - 1) + 0.5))] if lat else 0.0
    print("macro-F1 %.4f; latency p50 %.0f ms, p90 %.0f ms"
          % (sum(f1s) / len(f1s) if f1s else 0.0, q(0.5), q(0.9)))
    print("confusion (truth -> predicted: count): " +
          ", ".join("%s->%s: %d" % (t, p, c) for (t, p), c in sorted(conf.items())))


if __name__ == "__main__":
    main()
