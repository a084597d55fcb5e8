#!/usr/bin/python3
"""The segmenter's calibration file (include/shadowsense/sense/calibration_file.hpp,
docs/calibration.md) as far as the classifier's training needs it: the empty-skin model and
the camera's scale.

  read_empty_skin(path)  -> numpy float32 H x W x 3 (B, G, R: the file's order exactly), or None
                            when the file holds no empty-skin model (version 1, or a version-2/3
                            file without one). Raises CalibrationFileError naming the path for
                            anything malformed: wrong header, a cut or changed file (the CRC-32
                            of the end line), a model block that does not fit.
  read_px_per_cm(path)   -> the camera's scale (px_per_cm, version 3), 0.0 when not recorded;
                            the same errors.
  write_calibration(path, empty_skin)
                         -> writes a version-2 file with the library's default thresholds and
                            the given model (float32 H x W x 3, BGR), atomically; the C++
                            load_calibration reads it (tests/data/encoding_calibration.calib).

  /usr/bin/python3 tools/calibration_file.py FILE   prints the model's size and range
"""
import argparse
import os
import sys
import zlib

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from atomic_write import write_atomic  # noqa: E402

MAGIC = "shadowsense_segmenter_calibration"
MAX_BYTES = 512 << 20  # kMaxCalibrationFileBytes


class CalibrationFileError(ValueError):
    pass


def read_empty_skin(path):
    return _read(path)[0]


def read_px_per_cm(path):
    return _read(path)[1]


def _read(path):
    try:
        size = os.path.getsize(path)
        if size > MAX_BYTES:
            raise CalibrationFileError(f"{path}: {size} bytes, expected at most {MAX_BYTES}")
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise CalibrationFileError(f"{path}: cannot read the calibration file ({e})") from None
    pos, version, model, line_no, px_per_cm = 0, None, None, 0, 0.0
    while pos < len(data):
        nl = data.find(b"\n", pos)
        if nl < 0:
            raise CalibrationFileError(f"{path}: cut in line {line_no + 1} (no newline)")
        line_no += 1
        try:
            text = data[pos:nl].decode("utf-8").split("#", 1)[0].strip()
        except UnicodeDecodeError:
            raise CalibrationFileError(f"{path}: line {line_no} is not UTF-8 text") from None
        words = text.split()
        if not words:
            pos = nl + 1
            continue
        if version is None:
            if len(words) != 2 or words[0] != MAGIC or words[1] not in ("1", "2", "3"):
                raise CalibrationFileError(f"{path}: line {line_no}: expected '{MAGIC} 1|2|3', "
                                           f"got '{text}' (not a calibration file)")
            version = int(words[1])
        elif words[0] == "end" and version >= 2:
            if len(words) != 2 or int(words[1], 16) != zlib.crc32(data[:pos]):
                raise CalibrationFileError(f"{path}: checksum mismatch in the end line "
                                           f"(the file was cut or changed)")
            if nl + 1 != len(data):
                raise CalibrationFileError(f"{path}: bytes after the end line")
            return model, px_per_cm
        elif words[0] == "px_per_cm" and version == 3:
            try:
                px_per_cm = float(words[1]) if len(words) == 2 else -1.0
            except ValueError:
                px_per_cm = -1.0
            if not (0.05 <= px_per_cm <= 10000):
                raise CalibrationFileError(f"{path}: line {line_no}: px_per_cm must be one "
                                           f"number in [0.05, 10000], got '{text}'")
        elif words[0] == "empty_skin" and version >= 2:
            if model is not None or len(words) != 4 or words[3] != "f32":
                raise CalibrationFileError(f"{path}: line {line_no}: expected one "
                                           f"'empty_skin W H f32', got '{text}'")
            w, h = int(words[1]), int(words[2])
            n = w * h * 3 * 4
            if not (w >= 1 and h >= 1 and nl + 1 + n + 1 <= len(data)
                    and data[nl + 1 + n:nl + 2 + n] == b"\n"):
                raise CalibrationFileError(f"{path}: the {w} x {h} empty-skin block is cut")
            model = np.frombuffer(data, dtype="<f4", count=w * h * 3, offset=nl + 1)
            model = model.reshape(h, w, 3).astype(np.float32)
            if not np.isfinite(model).all() or model.min() < 0 or model.max() > 8:
                raise CalibrationFileError(f"{path}: the empty-skin model holds values outside "
                                           f"[0, 8] or not finite")
            pos = nl + 2 + n
            continue
        pos = nl + 1
    if version == 1:
        return None, 0.0
    raise CalibrationFileError(f"{path}: no end line (the file was cut)")


def write_calibration(path, empty_skin):
    m = np.ascontiguousarray(empty_skin, dtype="<f4")
    if m.ndim != 3 or m.shape[2] != 3:
        raise ValueError("empty_skin: expected H x W x 3 float32")
    text = ("# shadowsense segmenter calibration (see docs/calibration.md)\n"
            f"{MAGIC} 2\nmode relative\nshadow_range 0 0 0 120 120 120\n"
            "contact_range 0 0 40 90 110 160\nshadow_darkness 0.200000003\n"
            "contact_darkness 0.449999988\ncontact_warmth 0.0799999982\n"
            "reference_percentile 0.899999976\n"
            f"empty_skin {m.shape[1]} {m.shape[0]} f32\n").encode()
    out = text + m.tobytes() + b"\n"
    out += f"end {zlib.crc32(out):08x}\n".encode()
    write_atomic(path, out)


def main(argv=None):
    import ss_version
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("calibration")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    args = ap.parse_args(argv)
    try:
        m = read_empty_skin(args.calibration)
    except CalibrationFileError as e:
        print(f"calibration_file.py: {e}", file=sys.stderr)
        return 2
    if m is None:
        print(f"{args.calibration}: no empty-skin model")
    else:
        print(f"{args.calibration}: empty-skin model {m.shape[1]} x {m.shape[0]}, values "
              f"{m.min():.4f}..{m.max():.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
