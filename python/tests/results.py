"""The text form of a Runtime's results that fixture.cpp (format_frame) also writes, and its
comparison: the C++ and Python runs of the same frames are compared line by line, words equal,
numbers within 1e-6."""
import math

import numpy as np


def _num(v):
    return "nan" if v is None or (isinstance(v, float) and math.isnan(v)) else repr(float(v))


def _word(s):
    return s if s else "-"


def format_frame(r):
    """The lines of one RuntimeFrame, as fixture.cpp's format_frame writes them."""
    g = r.gesture
    lines = [" ".join(["frame", str(r.frame_index), _num(r.timestamp_ms), str(int(r.classified)),
                       _word(g.label), _num(g.confidence), str(g.frame_index)]
                      + [_num(p) for p in g.probabilities])]
    i = str(r.frame_index)
    for t in r.touch.tracks:
        c = t.contact or (None, None)
        x, y, w, h = t.shadow_box
        lines.append(" ".join(["track", i, str(t.id), str(int(t.matched)), t.state, _num(c[0]),
                               _num(c[1]), _num(t.position[0]), _num(t.position[1]), str(x),
                               str(y), str(w), str(h), _num(t.contact_area)]))
    for e in r.touch.events:
        p = e.position or (None, None)
        lines.append(" ".join(["event", i, str(e.track_id), e.from_state, e.to_state,
                               e.direction, _num(p[0]), _num(p[1]), _num(e.timestamp_ms)]))
    for ge in r.touch_gestures:
        lines.append(" ".join(["touch_gesture", i, ge.gesture, ge.phase, str(ge.track_id),
                               _num(ge.start_ms), _num(ge.end_ms), _num(ge.decided_ms),
                               _num(ge.length_px), _num(ge.speed_px_s), str(ge.repetitions),
                               _word(ge.hand_shape), _num(ge.confidence)]))
    return lines


def _is_number(word):
    try:
        float(word)
        return True
    except ValueError:
        return False


def differences(expected_lines, actual_lines, tolerance=1e-6):
    """Every difference between two result texts (empty: equal): words must be equal, numbers
    within `tolerance` (nan equals nan)."""
    out = []
    if len(expected_lines) != len(actual_lines):
        out.append(f"{len(expected_lines)} lines expected, {len(actual_lines)} got")
    for n, (e, a) in enumerate(zip(expected_lines, actual_lines), 1):
        ew, aw = e.split(), a.split()
        if len(ew) != len(aw):
            out.append(f"line {n}: {e!r} != {a!r}")
            continue
        for x, y in zip(ew, aw):
            if _is_number(x) and _is_number(y):
                fx, fy = float(x), float(y)
                if not (math.isnan(fx) and math.isnan(fy)) and not abs(fx - fy) <= tolerance:
                    out.append(f"line {n}: {x} != {y} in {e!r}")
            elif x != y:
                out.append(f"line {n}: {x!r} != {y!r} in {e!r}")
    return out


class Frames:
    """Frames written by ss_python_fixture: frames.u8 (N x H x W x 3) and frames.txt."""

    def __init__(self, folder):
        with open(folder / "frames.txt") as f:
            n, h, w = (int(v) for v in f.readline().split())
            self.timestamps = [float(line) for line in f if line.strip()]
        self.images = np.fromfile(folder / "frames.u8", dtype=np.uint8).reshape(n, h, w, 3)
        self.calibration_path = str(folder / "skin.calib")
