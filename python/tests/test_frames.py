"""Frames are read in place (no copy, no reference kept) and a wrong array is a one-line
ValueError, never a crash."""
import sys

import numpy as np
import pytest

import shadowsense as ss
from shadowsense import _shadowsense


@pytest.fixture
def runtime(sequence):
    return ss.Runtime(ss.TouchPipeline(ss.Segmenter(ss.load_calibration(
        sequence.calibration_path))))


def test_the_frame_is_read_in_place(sequence):
    frame = sequence.images[5]  # a view into the whole file's array: no copy of its own
    assert _shadowsense._frame_address(frame) == frame.ctypes.data
    readonly = frame.copy()
    readonly.setflags(write=False)  # read in place: a read-only buffer is fine
    assert _shadowsense._frame_address(readonly) == readonly.ctypes.data


def test_no_reference_is_kept(sequence, runtime):
    frame = sequence.images[5].copy()
    before = sys.getrefcount(frame)
    runtime.update(frame, 1.0)
    assert sys.getrefcount(frame) == before
    # The same buffer changed in place is seen as changed: the empty skin there now.
    assert len(runtime.update(frame, 2.0).touch.shadow_boxes) == 1
    frame[:] = sequence.images[0]
    assert runtime.update(frame, 3.0).touch.shadow_boxes == []


WRONG = {
    "non-contiguous": lambda f: f[:, ::2],
    "float": lambda f: f.astype(np.float32),
    "4-channel": lambda f: np.concatenate([f, f[:, :, :1]], axis=2),
    "empty": lambda f: f[:0],
    "grey": lambda f: f[:, :, 0].copy(),
    "int16": lambda f: f.astype(np.int16),
}


@pytest.mark.parametrize("kind", sorted(WRONG))
def test_a_wrong_array_is_a_one_line_value_error(sequence, runtime, kind, model_path):
    bad = WRONG[kind](sequence.images[5])
    classifier = ss.Classifier(model_path)
    segmenter = ss.Segmenter(ss.load_calibration(sequence.calibration_path))
    for call in (lambda: runtime.update(bad, 1.0), lambda: classifier.classify(bad),
                 lambda: segmenter.segment(bad), lambda: ss.calibrate_from_frames([bad])):
        with pytest.raises(ValueError) as e:
            call()
        message = str(e.value)
        assert "\n" not in message
        assert "expected" in message or "C-contiguous" in message
    assert runtime.update(sequence.images[0], 1.0).frame_index == 1  # still usable


def test_the_messages_name_what_is_wrong(sequence, runtime):
    f = sequence.images[5]
    with pytest.raises(ValueError, match=r"dtype float32"):
        runtime.update(f.astype(np.float32), 1.0)
    with pytest.raises(ValueError, match=r"shape \(350, 635, 4\)"):
        runtime.update(np.zeros((350, 635, 4), np.uint8), 1.0)
    with pytest.raises(ValueError, match=r"not C-contiguous"):
        runtime.update(f[::2], 1.0)
    with pytest.raises(ValueError, match=r"empty"):
        runtime.update(np.zeros((0, 635, 3), np.uint8), 1.0)


def test_a_black_frame_is_a_camera_fault_not_a_touch(sequence):
    pipeline = ss.TouchPipeline(ss.Segmenter(ss.load_calibration(sequence.calibration_path)))
    first = pipeline.update(sequence.images[0], 1.0)
    assert first.camera == "none"
    black = np.zeros_like(sequence.images[0])
    frame = pipeline.update(black, 2.0)
    assert (frame.camera, frame.camera_before) == ("dark", "none")
    assert frame.shadow_boxes == [] and frame.events == []
