"""What the contact-timeline converters share (cost_timeline.py, socialtouch_timeline.py,
touchlog_timeline.py): the timeline's rows, the contact of a pressure or capacitive grid, the
sampling of placed tracks at the output frame rate, and the three output files.

TIMELINE_HEADER, timeline_row(seq, t, track, contact): one row of timeline.csv; contact None
  (the track hovers; track 0: no track in the frame) or (x_px, y_px, area_px).
grid_contacts(frames, base, rows, cols, cell_cm, threshold): per grid frame (rows x cols cells,
  row-major), None when no cell's value - base reaches threshold, else the touched cells'
  (value - base)-weighted centroid in image pixels (the grid centred on CENTRE_PX, PX_PER_CM)
  and their area in pixels.
sample_tracks(seq, n_frames, step, tracks): the rows of frames k * step, k < n_frames; tracks:
  (track, appear_ms, leave_ms, contact_at), a track present where appear <= t <= leave (1e-6 ms
  slack), contact_at(t) -> contact; a frame without a track gets one row of track 0.
write_outputs(out, timeline, truth, summary): timeline.csv, truth.csv and summary.txt into out
  (created), each written atomically; then the summary on stdout.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from atomic_write import write_atomic  # noqa: E402  (tools/atomic_write.py)

TIMELINE_HEADER = "sequence,time_ms,track,contact,x_px,y_px,area_px"
PX_PER_CM = 7.6              # the generator's robot rig
CENTRE_PX = (320.0, 240.0)   # where a grid's centre lands in the image


def timeline_row(seq, t, track, contact):
    if contact is None:
        return "%d,%.3f,%d,0,,," % (seq, t, track)
    return "%d,%.3f,%d,1,%.2f,%.2f,%.1f" % (seq, t, track, contact[0], contact[1], contact[2])


def grid_contacts(frames, base, rows, cols, cell_cm, threshold):
    r, c = np.divmod(np.arange(rows * cols), cols)
    cx, cy = (c + 0.5) * cell_cm, (r + 0.5) * cell_cm
    out = []
    for f in frames:
        w = f - base
        on = w >= threshold
        if not on.any():
            out.append(None)
            continue
        ww = np.where(on, w, 0.0)
        x_cm = float((ww * cx).sum() / ww.sum())
        y_cm = float((ww * cy).sum() / ww.sum())
        x = CENTRE_PX[0] + (x_cm - cols * cell_cm / 2) * PX_PER_CM
        y = CENTRE_PX[1] + (y_cm - rows * cell_cm / 2) * PX_PER_CM
        out.append((x, y, float(on.sum()) * cell_cm * cell_cm * PX_PER_CM * PX_PER_CM))
    return out


def sample_tracks(seq, n_frames, step, tracks):
    rows = []
    for k in range(n_frames):
        t = k * step
        frame = [timeline_row(seq, t, tr, contact_at(t)) for tr, appear, leave, contact_at in tracks
                 if appear - 1e-6 <= t <= leave + 1e-6]
        rows.extend(frame or [timeline_row(seq, t, 0, None)])
    return rows


def write_outputs(out, timeline, truth, summary):
    os.makedirs(out, exist_ok=True)
    write_atomic(os.path.join(out, "timeline.csv"), "\n".join(timeline) + "\n")
    write_atomic(os.path.join(out, "truth.csv"), "\n".join(truth) + "\n")
    write_atomic(os.path.join(out, "summary.txt"), summary)
    sys.stdout.write(summary)
