#!/usr/bin/python3
"""Renders contact timelines (cost_timeline.py's timeline.csv) into shadow frames with render.py.

Issue 23's independent real timing: the timing comes from a real touch record, the hands from
real silhouettes (data/realhand or any folder render.py reads), the lens, fabric, light and
noise from render.py; nothing from the C++ generator. Per sequence one user, one lighting
(daylight) and one fabric; per frame and track: the contact point (image px at 7.6 px/cm around
(320, 240), as cost_timeline.py wrote it) becomes a position on the skin in cm (centred on the
rig's view, shifted 3 cm towards the fingers' side so a hand fits); a contact of >= 12 cm² is
a palm pressed flat, a smaller one a pointing fingertip; a track without contact is the same
pose hovering HOVER_CM above the skin. Contact points are approximate: a fingertip lands near,
not exactly on, the recorded point (render.py puts the fingertip 2 cm into view).

Output (atomic writes): OUT/<sequence>/frame_NNNNN.png, OUT/frames.csv
(sequence,frame,file,time_ms), OUT/truth.csv (copied). The rig's scale (render.py's box rig,
7.7 px/cm) is printed at the end, for ss_track --px-per-cm. Scoring the rendered frames (ss_track
plus a scorer of its gesture rows) is not written yet.

Usage:
  /usr/bin/python3 tools/realhand/render_timeline.py --timeline DIR --out OUT
      [--hands data/realhand] [--seed 1] [--max-sequences N]
"""
import argparse
import csv
import math
import os
import shutil
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import render as R  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/
import ss_version  # noqa: E402

HOVER_CM = 3.0
PX_PER_CM_TIMELINE = 7.6
CENTRE_TIMELINE = (320.0, 240.0)
PALM_MIN_CM2 = 12.0


def fail(msg):
    print("render_timeline.py: error: " + msg, file=sys.stderr)
    sys.exit(2)


def read_timeline(path):
    seqs = {}
    try:
        with open(path, newline="") as fh:
            rd = csv.DictReader(fh)
            need = {"sequence", "time_ms", "track", "contact", "x_px", "y_px", "area_px"}
            if not rd.fieldnames or not need <= set(rd.fieldnames):
                fail("%s: header must hold %s" % (path, ",".join(sorted(need))))
            for n, row in enumerate(rd, start=2):
                try:
                    s, t, k = int(row["sequence"]), float(row["time_ms"]), int(row["track"])
                    c = None
                    if row["contact"] == "1":
                        c = (float(row["x_px"]), float(row["y_px"]), float(row["area_px"]))
                except (TypeError, ValueError) as e:
                    fail("%s line %d: %s" % (path, n, e))
                frames = seqs.setdefault(s, [])
                if not frames or frames[-1][0] != t:
                    frames.append((t, []))
                if k:
                    frames[-1][1].append((k, c))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e))
    return seqs


def pose_parts(rig, user, pose, rng, centre, height):
    """A palm or pointing hand with its fingers' end near `centre` (cm), pressed or hovering."""
    L = R.POSE_LEN_CM[pose] * user["scale"]
    if pose == "point" and height == 0:
        centre = (centre[0], centre[1] + 2)
    wrist = (centre[0], centre[1] + L / 2)
    if height > 0:
        return R.hand_parts(rig, user, pose, rng, wrist, 0.0, height, "none") or []
    return R.hand_parts(rig, user, pose, rng, wrist, 0.0, 0.0,
                        "tip" if pose == "point" else "all") or []


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--timeline", required=True, help="folder with timeline.csv and truth.csv")
    ap.add_argument("--out", required=True)
    ap.add_argument("--hands", default="data/realhand", help="silhouette folder (render.py)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-sequences", type=int, default=0, help="0: all")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args()
    if a.max_sequences < 0:
        fail("--max-sequences must be >= 0")
    seqs = read_timeline(os.path.join(a.timeline, "timeline.csv"))
    truth_in = os.path.join(a.timeline, "truth.csv")
    if not os.path.isfile(truth_in):
        fail("no truth.csv in %s" % a.timeline)
    sils = R.load_silhouettes(a.hands)
    if "palm" not in sils or "point" not in sils:
        fail("%s: needs palm and point silhouettes" % a.hands)
    rig = R.Rig(**R.BOX)
    lines = ["sequence,frame,file,time_ms"]
    keys = sorted(seqs)[: a.max_sequences or None]
    for s in keys:
        rng = R.rng_for(a.seed, "timeline", s)
        user = R.make_user(300 + s, sils, R.rng_for(a.seed, "tluser", s))
        light = R.light_preset("daylight", R.LEVEL["daylight"], rng)
        alb, tint = R.fabric(rig, rng)
        body_seed = int(rng.integers(0, 1 << 62))
        pose_of = {}
        for _, tracks in seqs[s]:  # the hover before a track's first contact: that contact's pose
            for k, c in tracks:
                if c is not None and k not in pose_of:
                    pose_of[k] = "palm" if c[2] / PX_PER_CM_TIMELINE ** 2 >= PALM_MIN_CM2 else "point"
                    pose_of[(k, "at")] = ((c[0] - CENTRE_TIMELINE[0]) / PX_PER_CM_TIMELINE,
                                          (c[1] - CENTRE_TIMELINE[1]) / PX_PER_CM_TIMELINE - 3.0)
        for i, (t, tracks) in enumerate(seqs[s]):
            parts = []
            for k, c in tracks:
                if c is not None:
                    area_cm2 = c[2] / PX_PER_CM_TIMELINE ** 2
                    pose_of[k] = "palm" if area_cm2 >= PALM_MIN_CM2 else "point"
                    pos = ((c[0] - CENTRE_TIMELINE[0]) / PX_PER_CM_TIMELINE,
                           (c[1] - CENTRE_TIMELINE[1]) / PX_PER_CM_TIMELINE - 3.0)
                    pose_of[(k, "at")] = pos
                pose = pose_of.get(k, "palm")
                pos = pose_of.get((k, "at"), (0.0, -3.0))
                prng = np.random.default_rng([body_seed, k])  # one body per track
                parts += pose_parts(rig, user, pose, prng, pos, 0.0 if c else HOVER_CM)
            frng = np.random.default_rng([body_seed, 1 << 20, i])
            occ, occ_vis, con = R.compose(rig, parts, light, frng, False)
            img = R.finish(rig, occ_vis, con, light, user["skin"], frng, alb, tint)
            name = "%d/frame_%05d.png" % (s, i)
            R.write_png(os.path.join(a.out, name), img)
            lines.append("%d,%d,%s,%.3f" % (s, i, name, t))
    R.write_text(os.path.join(a.out, "frames.csv"), lines)
    tmp = os.path.join(a.out, "truth.csv.tmp")
    shutil.copyfile(truth_in, tmp)
    os.replace(tmp, os.path.join(a.out, "truth.csv"))
    print("%d sequences, %d frames, rig %.2f px/cm -> %s" % (len(keys), len(lines) - 1,
                                                            rig.px_per_cm, a.out))


if __name__ == "__main__":
    main()
