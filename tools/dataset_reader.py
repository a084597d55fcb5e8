#!/usr/bin/python3
"""Strict reader of the shadowsense dataset format (docs/dataset_format.md), in Python.

Applies the same rules, with the same kind of messages (file:line: column N 'name': ...), as
the C++ readers in include/shadowsense/io/dataset.hpp (read_metadata, read_sequences,
check_images, read_sequence_metadata) and include/shadowsense/io/temporal_dataset.hpp
(read_temporal_sequences, read_temporal_sequence): both run tests/data/bad_inputs/ with the
same accept/reject verdicts (tests/data/bad_inputs/cases.txt, checked by `--check-corpus`).

Library use:
    rows = read_metadata(csv_path)          # list of dicts, raises DatasetError
    check_images(csv_path, rows)            # image headers, symlinks, boxes inside
    seqs = read_sequences(csv_path)
    md = read_sequence_metadata(sequences_csv, seq_row)
    rows_for_training(root)                 # what tools/train.py uses (SystemExit on error)
  Temporal gesture sequences (OUT/temporal):
    rows = read_temporal_sequences(dir_or_sequences_csv)   # the rows of sequences.csv
    seq = read_temporal_sequence(dir_or_sequences_csv, row)
        # frames.csv and gestures.csv checked (row counts against sequences.csv, strictly
        # increasing frames and timestamps, track ids, intervals, ...); the images unread
    check_temporal_images(seq)              # each frame's image header, as ss_track_eval
                                            # --temporal resolves it (inside the folder)

Command line:
    dataset_reader.py CSV...                 read each metadata.csv, slide sequences.csv or
                                             temporal sequences.csv (told apart by the header)
                                             with every sequence and image header; exit 2 on
                                             the first error
    dataset_reader.py --check-corpus DIR     run the shared bad-input corpus
    dataset_reader.py --help | --version
  Exit 0 when everything read is valid, 2 on bad data or a bad command line (message on
  stderr), 1 when --check-corpus found wrong verdicts.
"""

import math
import os
import re
import stat
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ss_version  # noqa: E402

METADATA_COLUMNS = ["file_name", "class", "user", "lighting", "lighting_level", "session",
                    "frame_index", "timestamp_ms", "shadow_x", "shadow_y", "shadow_w",
                    "shadow_h", "contact_x", "contact_y", "contact_w", "contact_h",
                    "contact_cx", "contact_cy", "px_per_cm"]
SLIDE_COLUMNS = ["gesture", "direction"]
SEQUENCE_COLUMNS = ["sequence", "gesture", "direction", "num_frames", "distance_cm", "fps",
                    "user", "lighting", "lighting_level"]
TEMPORAL_SEQUENCE_COLUMNS = ["sequence", "fps", "user", "frames", "gestures", "lighting_level",
                             "px_per_cm"]
TEMPORAL_FRAME_COLUMNS = ["frame", "file_name", "timestamp_ms", "duplicate", "shape",
                          "shape_confidence"]
TEMPORAL_GESTURE_COLUMNS = ["gesture", "track_id", "start_ms", "end_ms", "repetitions",
                            "direction"]
LIGHTING_LEVEL = {"daylight": 1.0, "dusk": 0.5, "night": 0.0}
MAX_WIDTH = MAX_HEIGHT = 8192
MAX_FILE_BYTES = 256 << 20
MAX_CSV_BYTES = 1 << 30
MAX_TIMESTAMP_MS = 1e12
INT_MAX = 2147483647

_INT = re.compile(r"-?[0-9]+\Z")
_REAL = re.compile(r"-?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?\Z")


class DatasetError(ValueError):
    pass


def _fmt(v):
    """Like C++ ostream << double (6 significant digits, %g)."""
    return "%g" % v


class _Row:
    def __init__(self, path, line, header, fields):
        self.path, self.line, self.header, self.fields = path, line, header, fields

    def fail(self, col, what):
        raise DatasetError(f"{self.path}:{self.line}: column {col + 1} '{self.header[col]}': "
                           f"{what}; got '{self.fields[col]}'")

    def empty(self, col):
        return self.fields[col] == ""

    def text(self, col):
        if self.empty(col):
            self.fail(col, "must not be empty")
        if any(c in self.fields[col] for c in "\"\n\r"):
            self.fail(col, "holds a quote or a line break; fields are never quoted in this format")
        return self.fields[col]

    def integer(self, col, lo, hi):
        s = self.fields[col]
        if not _INT.match(s) or not -2**31 <= int(s) < 2**31:
            self.fail(col, "expected an integer")
        v = int(s)
        if v < lo or v > hi:
            self.fail(col, f"expected an integer in [{lo}, {hi}]")
        return v

    def real(self, col, lo, hi):
        s = self.fields[col]
        try:
            v = float(s) if _REAL.match(s) else math.nan
        except (ValueError, OverflowError):
            v = math.nan
        if v == 0 and re.search("[1-9]", re.split("[eE]", s)[0]):
            v = math.nan  # underflow: std::from_chars reports it out of range
        if not math.isfinite(v):
            self.fail(col, "expected a finite number")
        if v < lo or v > hi:
            self.fail(col, f"expected a number in [{_fmt(lo)}, {_fmt(hi)}]")
        return v

    def choice(self, col, allowed, what):
        s = self.fields[col]
        if s not in allowed:
            self.fail(col, f"unknown {what} '{s}'; expected {allowed_text(allowed)}")
        return s

    def box(self, col):
        empties = sum(1 for i in range(col, col + 4) if self.empty(i))
        if empties == 4:
            return None
        for i in range(col, col + 4):
            if self.empty(i):
                self.fail(i, "a box needs all of x, y, w, h or none")
        return (self.integer(col, 0, 1 << 20), self.integer(col + 1, 0, 1 << 20),
                self.integer(col + 2, 1, 1 << 20), self.integer(col + 3, 1, 1 << 20))


def allowed_text(allowed):
    return ", ".join(allowed[:-1]) + " or " + allowed[-1]


LIGHTINGS = ["daylight", "dusk", "night", "custom"]
GESTURES = ["palm", "finger"]
DIRECTIONS = ["left", "right", "front", "back"]
TOUCH_GESTURES = ["tap", "double_tap", "pat", "stroke", "rub", "hold", "hit", "hug", "punch",
                  "two_hands"]
WHOLE_FRAME_GESTURES = ("hug", "punch", "two_hands")  # on track 0


def _read_csv_bytes(path):
    """A regular file of at most MAX_CSV_BYTES (no FIFO hang, no /dev/zero)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as e:
        raise DatasetError(f"{path}: cannot open the csv file: {e.strerror}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise DatasetError(f"{path}: not a regular file (a folder, device or pipe); "
                               "expected the csv file")
        if st.st_size > MAX_CSV_BYTES:
            raise DatasetError(f"{path}: the file has {st.st_size} bytes; the limit is "
                               f"{MAX_CSV_BYTES}")
        chunks, got = [], 0
        while got < st.st_size:
            b = os.pread(fd, st.st_size - got, got)
            if not b:
                break
            chunks.append(b)
            got += len(b)
        return b"".join(chunks)
    finally:
        os.close(fd)


def _lines(path):
    data = _read_csv_bytes(path)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]
    while lines and lines[-1] == "":
        lines.pop()
    if not lines:
        raise DatasetError(f"{path}:1: the csv file is empty; expected a header row")
    return lines


def _fields(path, line, text, width):
    if '"' in text:
        raise DatasetError(f"{path}:{line}: quoted fields are not supported")
    f = text.split(",")
    if len(f) != width:
        raise DatasetError(f"{path}:{line}: row has {len(f)} columns; expected {width} "
                           "(as in the header)")
    return f


def _check_relative(r, col):
    s = r.text(col)
    if s.startswith("/") or "\\" in s:
        r.fail(col, "expected a path relative to the csv's folder")
    if ".." in s.split("/"):
        r.fail(col, "the path must not leave the dataset folder ('..')")
    return s


def _check_level(r, col, lighting, level):
    if lighting != "custom" and level != LIGHTING_LEVEL[lighting]:
        r.fail(col, f"does not match the lighting preset '{lighting}' "
                    f"(level {LIGHTING_LEVEL[lighting]:.6f})")


def read_metadata(path):
    """Rows of a metadata.csv as dicts (csv strings plus parsed values under the same keys:
    user/frame_index int, lighting_level/timestamp_ms/px_per_cm float, boxes as tuples)."""
    lines = _lines(path)
    header = lines[0].split(",")
    if header == METADATA_COLUMNS:
        slide = False
    elif header == METADATA_COLUMNS + SLIDE_COLUMNS:
        slide = True
    else:
        raise DatasetError(f"{path}:1: unexpected header '{lines[0]}'; expected "
                           f"'{','.join(METADATA_COLUMNS)}' (slide sequences add "
                           f"',{','.join(SLIDE_COLUMNS)}')")
    rows, first = [], {}
    for i, text in enumerate(lines[1:], start=2):
        f = _fields(path, i, text, len(header))
        r = _Row(path, i, header, f)
        d = {"line": i, "slide": slide}
        d["file_name"] = _check_relative(r, 0)
        d["class"] = r.text(1)
        d["user"] = r.integer(2, 0, 1000000)
        d["lighting"] = r.choice(3, LIGHTINGS, "lighting")
        d["lighting_level"] = r.real(4, 0.0, 1.0)
        _check_level(r, 4, d["lighting"], d["lighting_level"])
        d["session"] = r.text(5)
        d["frame_index"] = r.integer(6, 0, 1 << 30)
        d["timestamp_ms"] = r.real(7, 0.0, 1e15)
        d["shadow_box"] = r.box(8)
        d["contact_box"] = r.box(12)
        if r.empty(16) != r.empty(17):
            r.fail(16 if r.empty(16) else 17,
                   "contact_cx and contact_cy must both be set or both empty")
        d["contact_point"] = None
        if not r.empty(16):
            d["contact_point"] = (r.real(16, -1.0, 1 << 20), r.real(17, -1.0, 1 << 20))
        if (d["contact_point"] is None) != (d["contact_box"] is None):
            r.fail(16, "the contact point must be present exactly when the contact box is")
        if d["contact_box"] is not None and d["shadow_box"] is None:
            r.fail(8, "a frame with a contact box must have a shadow box")
        d["px_per_cm"] = r.real(18, 1e-6, 1e6)
        if slide:
            d["gesture"] = r.choice(19, GESTURES, "slide gesture")
            d["direction"] = r.choice(20, DIRECTIONS, "direction")
        if d["file_name"] in first:
            r.fail(0, f"duplicate row: the same file is already listed on line "
                      f"{first[d['file_name']]}")
        first[d["file_name"]] = i
        rows.append(d)
    if not rows:
        raise DatasetError(f"{path}:2: no data rows; expected at least one row after the header")
    return rows


def read_sequences(path):
    lines = _lines(path)
    header = lines[0].split(",")
    if header != SEQUENCE_COLUMNS:
        raise DatasetError(f"{path}:1: unexpected header '{lines[0]}'; expected "
                           f"'{','.join(SEQUENCE_COLUMNS)}'")
    rows, first = [], {}
    for i, text in enumerate(lines[1:], start=2):
        f = _fields(path, i, text, len(header))
        r = _Row(path, i, header, f)
        d = {"line": i}
        d["sequence"] = _check_relative(r, 0)
        d["gesture"] = r.choice(1, GESTURES, "slide gesture")
        d["direction"] = r.choice(2, DIRECTIONS, "direction")
        d["num_frames"] = r.integer(3, 1, 1 << 24)
        d["distance_cm"] = r.real(4, 0.0, 1e4)
        d["fps"] = r.real(5, 1e-3, 1e4)
        d["user"] = r.integer(6, 0, 1000000)
        d["lighting"] = r.choice(7, LIGHTINGS, "lighting")
        d["lighting_level"] = r.real(8, 0.0, 1.0)
        _check_level(r, 8, d["lighting"], d["lighting_level"])
        if d["sequence"] in first:
            r.fail(0, f"duplicate row: the same sequence is already listed on line "
                      f"{first[d['sequence']]}")
        first[d["sequence"]] = i
        rows.append(d)
    if not rows:
        raise DatasetError(f"{path}:2: no data rows; expected at least one sequence")
    return rows


def _where(csv_path, line, col, name):
    return f"{csv_path}:{line}: column {col + 1} '{name}': "


def _inside(folder, relative, at):
    base = os.path.realpath(folder)
    full = os.path.realpath(os.path.join(folder, relative))
    if os.path.commonpath([base, full]) != base:
        raise DatasetError(f"{at}'{relative}' resolves to '{full}', outside the dataset folder "
                           f"'{base}' (a symlink leaves it)")
    return os.path.join(folder, relative)


def image_header(path):
    """(format, width, height) from the header bytes, with the C++ reader's checks."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as e:
        raise DatasetError(f"{path}: cannot open the image: {e.strerror}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise DatasetError(f"{path}: not a regular file (a folder, device or pipe); "
                               "expected the image")
        if st.st_size > MAX_FILE_BYTES:
            raise DatasetError(f"{path}: the file has {st.st_size} bytes; the limit is "
                               f"{MAX_FILE_BYTES}")

        def read_at(off, n):
            return os.pread(fd, n, off)

        h = read_at(0, 32)
        if h[:8] == b"\x89PNG\r\n\x1a\n":
            if len(h) < 24:
                raise DatasetError(f"{path}: truncated PNG: the IHDR chunk is incomplete")
            if h[12:16] != b"IHDR" or struct.unpack(">I", h[8:12])[0] != 13:
                raise DatasetError(f"{path}: malformed PNG: the first chunk is not a 13-byte IHDR")
            fmt, (w, hh) = "png", struct.unpack(">II", h[16:24])
        elif h[:3] == b"\xff\xd8\xff":
            fmt, (w, hh) = "jpeg", _jpeg_size(path, read_at)
        elif h[:2] == b"BM":
            if len(h) < 26:
                raise DatasetError(f"{path}: truncated BMP header")
            dib = struct.unpack("<I", h[14:18])[0]
            fmt = "bmp"
            if dib == 12:
                w, hh = struct.unpack("<HH", h[18:22])
            elif 40 <= dib <= 124:
                w, hh = struct.unpack("<ii", h[18:26])
                hh = abs(hh)
            else:
                raise DatasetError(f"{path}: malformed BMP: unknown info header size {dib}")
        else:
            raise DatasetError(f"{path}: unknown image format; expected PNG, JPEG or BMP")
    finally:
        os.close(fd)
    if w < 1 or hh < 1:
        raise DatasetError(f"{path}: the {fmt} header gives a size of {w}x{hh}; "
                           "expected at least 1x1")
    if w > MAX_WIDTH or hh > MAX_HEIGHT:
        raise DatasetError(f"{path}: the image is {w}x{hh} pixels; the limit is "
                           f"{MAX_WIDTH}x{MAX_HEIGHT} (ImageLimits)")
    return fmt, w, hh


def _jpeg_size(path, read_at):
    pos = 2
    for _ in range(4096):
        m = read_at(pos, 2)
        if len(m) < 2:
            raise DatasetError(f"{path}: truncated JPEG: no SOF segment before the end of the file")
        if m[0] != 0xFF:
            raise DatasetError(f"{path}: malformed JPEG: expected a segment marker at byte {pos}")
        if m[1] == 0xFF:
            pos += 1
            continue
        marker = m[1]
        pos += 2
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            continue
        if marker in (0xD9, 0xDA):
            raise DatasetError(f"{path}: malformed JPEG: image data starts before any SOF segment")
        seg = read_at(pos, 7)
        if len(seg) < 2:
            raise DatasetError(f"{path}: truncated JPEG segment header")
        length = struct.unpack(">H", seg[:2])[0]
        if length < 2:
            raise DatasetError(f"{path}: malformed JPEG: segment length below 2")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            if len(seg) < 7 or length < 7:
                raise DatasetError(f"{path}: truncated JPEG SOF segment")
            hh, w = struct.unpack(">HH", seg[3:7])
            return w, hh
        pos += length
    raise DatasetError(f"{path}: malformed JPEG: no SOF segment in the first 4096 segments")


def check_images(csv_path, rows):
    folder = os.path.dirname(csv_path)
    for r in rows:
        at = _where(csv_path, r["line"], 0, "file_name")
        p = _inside(folder, r["file_name"], at)
        try:
            _, w, h = image_header(p)
        except DatasetError as e:
            raise DatasetError(at + str(e)) from None
        for col, name, key, what in ((8, "shadow_x", "shadow_box", "the shadow box"),
                                     (12, "contact_x", "contact_box", "the contact box")):
            b = r[key]
            if b is not None and (b[0] + b[2] > w or b[1] + b[3] > h):
                raise DatasetError(_where(csv_path, r["line"], col, name) +
                                   f"{what} ({b[0]}, {b[1]}, {b[2]}, {b[3]}) is not inside the "
                                   f"{w}x{h} image")
        cp = r["contact_point"]
        if cp is not None and not (0 <= cp[0] < w and 0 <= cp[1] < h):
            raise DatasetError(_where(csv_path, r["line"], 16, "contact_cx") +
                               f"the contact point is not inside the {w}x{h} image")


def read_sequence_metadata(sequences_csv, seq):
    folder = _inside(os.path.dirname(sequences_csv), seq["sequence"],
                     _where(sequences_csv, seq["line"], 0, "sequence"))
    csv_path = os.path.join(folder, "metadata.csv")
    rows = read_metadata(csv_path)
    other = f" disagrees with {sequences_csv}:{seq['line']}"
    if not rows[0]["slide"]:
        raise DatasetError(f"{csv_path}:1: a slide sequence's csv needs the gesture and "
                           f"direction columns;{other}")
    if len(rows) != seq["num_frames"]:
        raise DatasetError(_where(sequences_csv, seq["line"], 3, "num_frames") +
                           f"{seq['num_frames']} frames, but {csv_path} has {len(rows)} rows")
    for r in rows:
        for col, name in ((19, "gesture"), (20, "direction"), (2, "user"), (3, "lighting"),
                          (4, "lighting_level")):
            if r[name] != seq[name]:
                raise DatasetError(_where(csv_path, r["line"], col, name) +
                                   f"the value{other} (column '{name}')")
    return csv_path, rows


def _parse_rows(path, columns, parse_row):
    """Each row of a csv with exactly `columns`, handed to parse_row(_Row, line)."""
    lines = _lines(path)
    header = lines[0].split(",")
    if header != columns:
        raise DatasetError(f"{path}:1: unexpected header '{lines[0]}'; expected "
                           f"'{','.join(columns)}'")
    for i, text in enumerate(lines[1:], start=2):
        parse_row(_Row(path, i, header, _fields(path, i, text, len(columns))), i)


def _temporal_root(dir_or_csv):
    """The dataset folder and its sequences.csv, given either (a path named sequences.csv is
    the csv)."""
    if os.path.basename(dir_or_csv) == "sequences.csv":
        return os.path.dirname(dir_or_csv), dir_or_csv
    return dir_or_csv, os.path.join(dir_or_csv, "sequences.csv")


def read_temporal_sequences(sequences_csv_or_dir):
    """Rows of a temporal dataset's sequences.csv as dicts: sequence (folder, relative), fps,
    user, frames, gestures (the row counts of the sequence's csv files), lighting_level (-1:
    unknown), px_per_cm, line."""
    _, path = _temporal_root(sequences_csv_or_dir)
    rows = []

    def parse(r, line):
        d = {"line": line}
        d["sequence"] = _check_relative(r, 0)
        d["fps"] = r.real(1, 1e-3, 1000)
        d["user"] = r.integer(2, 0, INT_MAX)
        d["frames"] = r.integer(3, 1, 1 << 30)
        d["gestures"] = r.integer(4, 0, 1 << 30)
        d["lighting_level"] = -1.0 if r.empty(5) else r.real(5, 0, 1)
        d["px_per_cm"] = r.real(6, 1e-3, 1e6)
        rows.append(d)

    _parse_rows(path, TEMPORAL_SEQUENCE_COLUMNS, parse)
    return rows


def read_temporal_sequence(root, row):
    """One sequence of a temporal dataset (root: its folder or sequences.csv; row: from
    read_temporal_sequences) as a dict: row, folder, frames_csv, gestures_csv, frames (dicts:
    frame, file_name, timestamp_ms, duplicate (bool), shape ('' none), shape_confidence, line)
    and gestures (dicts: gesture, track_id, start_ms, end_ms, repetitions, direction ('' none),
    line). The images are not read (check_temporal_images)."""
    root, sequences_csv = _temporal_root(root)
    folder = _inside(root, row["sequence"], _where(sequences_csv, row["line"], 0, "sequence"))
    seq = {"row": row, "folder": folder, "frames_csv": os.path.join(folder, "frames.csv"),
           "gestures_csv": os.path.join(folder, "gestures.csv"), "frames": [], "gestures": []}
    frames, gestures = seq["frames"], seq["gestures"]

    def frame(r, line):
        d = {"line": line}
        d["frame"] = r.integer(0, 0, INT_MAX)
        d["file_name"] = _check_relative(r, 1)
        d["timestamp_ms"] = r.real(2, -MAX_TIMESTAMP_MS, MAX_TIMESTAMP_MS)
        d["duplicate"] = r.integer(3, 0, 1) == 1
        d["shape"] = "" if r.empty(4) else r.text(4)
        if (d["shape"] == "") != r.empty(5):
            r.fail(5, "must be given exactly when the shape column is")
        d["shape_confidence"] = 0.0 if r.empty(5) else r.real(5, 0, 1)
        if frames:
            prev = frames[-1]
            if not d["frame"] > prev["frame"]:
                r.fail(0, "frame indices must be strictly increasing (the previous row has "
                          f"{prev['frame']})")
            if not d["timestamp_ms"] > prev["timestamp_ms"]:
                r.fail(2, "timestamps must be strictly increasing (the previous row has "
                          f"{prev['timestamp_ms']:.3f})")
        frames.append(d)

    def gesture(r, line):
        d = {"line": line}
        d["gesture"] = r.choice(0, TOUCH_GESTURES, "gesture")
        d["track_id"] = r.integer(1, 0, INT_MAX)
        if (d["gesture"] in WHOLE_FRAME_GESTURES) != (d["track_id"] == 0):
            r.fail(1, "expected " + ("a track id > 0 for " if d["track_id"] == 0
                                     else "track id 0 for ") + d["gesture"] +
                   " (hug, punch and two_hands are whole-frame gestures on track 0, the others "
                   "are on a hand's track)")
        d["start_ms"] = r.real(2, -MAX_TIMESTAMP_MS, MAX_TIMESTAMP_MS)
        d["end_ms"] = r.real(3, -MAX_TIMESTAMP_MS, MAX_TIMESTAMP_MS)
        if not d["end_ms"] > d["start_ms"]:
            r.fail(3, "must be after start_ms")
        d["repetitions"] = r.integer(4, 1, 1000000)
        d["direction"] = "" if r.empty(5) else r.choice(5, DIRECTIONS, "direction")
        gestures.append(d)

    _parse_rows(seq["frames_csv"], TEMPORAL_FRAME_COLUMNS, frame)
    _parse_rows(seq["gestures_csv"], TEMPORAL_GESTURE_COLUMNS, gesture)
    for csv, got, key, what, col in ((seq["frames_csv"], len(frames), "frames", "frame", 3),
                                     (seq["gestures_csv"], len(gestures), "gestures", "gesture",
                                      4)):
        if got != row[key]:
            raise DatasetError(f"{csv}: has {got} {what} rows; " +
                               _where(sequences_csv, row["line"], col, key) +
                               f"expects {row[key]} (a truncated or mismatched file)")
    return seq


def check_temporal_images(seq):
    """Each frame's image resolved inside the sequence's folder (no symlink out) and its header
    checked (a regular PNG/JPEG/BMP file within the limits), with ss_track_eval --temporal's
    messages; returns nothing, raises DatasetError."""
    for f in seq["frames"]:
        at = f"{seq['frames_csv']}:{f['line']}: "
        p = _inside(seq["folder"], f["file_name"], at + "column 2 'file_name': ")
        try:
            image_header(p)
        except DatasetError as e:
            raise DatasetError(at + "cannot read image: " + str(e)) from None


def read_case(kind, path):
    """What the corpus checks: a metadata.csv with its images, a sequences.csv with every
    sequence and its images, or a temporal sequences.csv with every sequence and its images'
    headers."""
    if kind == "metadata":
        check_images(path, read_metadata(path))
    elif kind == "sequences":
        for s in read_sequences(path):
            csv_path, rows = read_sequence_metadata(path, s)
            check_images(csv_path, rows)
    elif kind == "temporal":
        for row in read_temporal_sequences(path):
            check_temporal_images(read_temporal_sequence(path, row))
    else:
        raise ValueError(f"unknown case kind {kind}")


def run_corpus(root):
    """Runs tests/data/bad_inputs/cases.txt: `<kind> <csv path> accept|reject [expected text]`.
    Returns the number of wrong verdicts (printed)."""
    wrong = 0
    with open(os.path.join(root, "cases.txt")) as f:
        for ln in f:
            ln = ln.strip()
            if not ln or ln.startswith("#"):
                continue
            parts = ln.split(None, 3)
            kind, rel, verdict = parts[:3]
            expect = parts[3] if len(parts) > 3 else ""
            try:
                read_case(kind, os.path.join(root, rel))
                got, msg = "accept", ""
            except DatasetError as e:
                got, msg = "reject", str(e)
            ok = got == verdict and expect in msg
            print(("ok   " if ok else "WRONG ") + f"{rel}: {got}" + (f": {msg}" if msg else ""))
            wrong += 0 if ok else 1
    return wrong


def rows_for_training(root):
    """tools/train.py's rows: the checked metadata.csv of `root`, each row with its image
    path under "path" (SystemExit with the reader's message on bad data)."""
    path = os.path.join(root, "metadata.csv")
    try:
        rows = read_metadata(path)
        check_images(path, rows)
    except DatasetError as e:
        raise SystemExit(str(e)) from None
    for r in rows:
        r["user"] = str(r["user"])  # train.py selects users by their csv text
        r["path"] = os.path.join(root, r["file_name"])
    return rows


def _kind_of(path):
    """metadata for a metadata.csv; a sequences.csv is a slide or a temporal dataset's, told
    apart by its header (a header of neither kind gets the slide reader's message)."""
    if os.path.basename(path) != "sequences.csv":
        return "metadata"
    header = _lines(path)[0].split(",")
    return "temporal" if header == TEMPORAL_SEQUENCE_COLUMNS else "sequences"


def main(argv):
    if argv and argv[0] in ("-h", "--help"):
        print(__doc__.strip())
        return 0
    if argv and argv[0] == "--version":
        print(ss_version.line("dataset_reader.py"))
        return 0
    if not argv:
        print("usage: dataset_reader.py CSV... | --check-corpus DIR (--help for more)",
              file=sys.stderr)
        return 2
    unknown = [a for i, a in enumerate(argv)
               if a.startswith("-") and (i, a) != (0, "--check-corpus")]
    if unknown:
        print(f"dataset_reader.py: unknown option '{unknown[0]}' (--help for usage)",
              file=sys.stderr)
        return 2
    if argv[0] == "--check-corpus":
        if len(argv) != 2:
            print("usage: dataset_reader.py --check-corpus DIR", file=sys.stderr)
            return 2
        return 1 if run_corpus(argv[1]) else 0
    try:
        for p in argv:
            read_case(_kind_of(p), p)
            print(f"{p}: ok")
    except DatasetError as e:
        print(str(e), file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
