"""examples/python/track_folder.py on the generated sequence written as images: the same touch
events as the C++ run (its frames are timed by --fps, so the rows are compared without times).
Needs OpenCV's Python module (python3-opencv) to write and read the images: skipped without."""
import csv
import os
import pathlib
import subprocess
import sys

import pytest

cv2 = pytest.importorskip("cv2")

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "python" / "track_folder.py"


def touch_rows(path):
    with open(path, newline="") as f:
        return [(r["frame"], r["track_id"], r["from"], r["to"], r["direction"], r["gesture"])
                for r in csv.DictReader(f) if r["kind"] == "touch"]


def test_track_folder(sequence, model_path, tmp_path):
    images = tmp_path / "frames"
    images.mkdir()
    for i, image in enumerate(sequence.images):
        cv2.imwrite(str(images / f"{i:03d}.png"), image)
    out = tmp_path / "events.csv"
    run = subprocess.run([sys.executable, str(EXAMPLE), "--calibration",
                          sequence.calibration_path, "--model", model_path, "--csv", str(out),
                          str(images)], capture_output=True, text=True, env=os.environ)
    assert run.returncode == 0, run.stderr
    assert "appear -> touch" in run.stdout
    expected = touch_rows(sequence.folder / "cpp_events.csv")
    assert touch_rows(out) == expected and len(expected) >= 4
    bad = subprocess.run([sys.executable, str(EXAMPLE), "--calibration", str(tmp_path / "none"),
                          str(images)], capture_output=True, text=True, env=os.environ)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
