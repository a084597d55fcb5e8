"""The same generated frames through C++ (ss_python_fixture) and through the Python module give
the same tracks, events, temporal gestures and probabilities (within 1e-6), and the same event
files."""
import numpy as np
import pytest

import shadowsense as ss
from results import differences, format_frame


def make_runtime(sequence, model_path, **config):
    calibration = ss.load_calibration(sequence.calibration_path)
    pipeline = ss.TouchPipeline(ss.Segmenter(calibration))
    return ss.Runtime(pipeline, ss.Classifier(model_path), **config)


def test_runtime_matches_cpp(sequence, model_path, tmp_path):
    sense = make_runtime(sequence, model_path)
    lines = []
    with ss.CsvSink(str(tmp_path / "events.csv")) as csv, \
            ss.JsonLinesSink(str(tmp_path / "events.jsonl")) as json:
        for frame, t in zip(sequence.images, sequence.timestamps):
            lines += format_frame(sense.update(frame, t))
            csv.write(sense.output())
            json.write(sense.output())
        lines += format_frame(sense.flush(sequence.timestamps[-1] + 33.25))
        csv.write(sense.output())
        json.write(sense.output())
    expected = (sequence.folder / "cpp_results.txt").read_text().splitlines()
    assert differences(expected, lines) == []
    # The sequence exercises what is compared: touches, moves, lifts, gestures, the gate.
    text = "\n".join(expected)
    for what in (" appear touch ", " touch move ", " lift none ", "touch_gesture ", " palm "):
        assert what in text
    assert (tmp_path / "events.csv").read_bytes() == (sequence.folder / "cpp_events.csv").read_bytes()
    assert (tmp_path / "events.jsonl").read_bytes() == \
        (sequence.folder / "cpp_events.jsonl").read_bytes()


def test_classifier_alone_gives_the_runtimes_probabilities(sequence, model_path):
    classifier = ss.Classifier(model_path)
    expected = {}
    for line in (sequence.folder / "cpp_results.txt").read_text().splitlines():
        w = line.split()
        if w[0] == "frame" and w[3] == "1":  # classified on this frame
            expected[int(w[1])] = (w[4], np.array([float(p) for p in w[7:]]))
    assert len(expected) >= 10
    for index, (label, probabilities) in expected.items():
        c = classifier.classify(sequence.images[index - 1])
        assert c.label == label
        assert c.probabilities.dtype == np.float32
        assert c.probabilities.shape == (len(classifier.class_names),)
        np.testing.assert_allclose(c.probabilities, probabilities, rtol=0, atol=1e-6)
        assert classifier.class_names[c.index] == label


def test_touch_pipeline_gives_the_runtimes_touch_events(sequence):
    pipeline = ss.TouchPipeline(ss.Segmenter(ss.load_calibration(sequence.calibration_path)))
    got = []
    for frame, t in zip(sequence.images, sequence.timestamps):
        got += [(e.track_id, e.from_state, e.to_state, e.direction, e.timestamp_ms)
                for e in pipeline.update(frame, t).events]
    got += [(e.track_id, e.from_state, e.to_state, e.direction, e.timestamp_ms)
            for e in pipeline.flush(sequence.timestamps[-1] + 33.25).events]
    expected = []
    for line in (sequence.folder / "cpp_results.txt").read_text().splitlines():
        w = line.split()
        if w[0] == "event":
            expected.append((int(w[2]), w[3], w[4], w[5], float(w[8])))
    assert got == expected
    assert len(expected) >= 4


def test_calibration_round_trip(sequence, tmp_path):
    calibration = ss.load_calibration(sequence.calibration_path)
    assert calibration.mode == "relative"
    h, w = sequence.images.shape[1:3]
    assert calibration.empty_skin_size == (w, h)
    ss.save_calibration(calibration, str(tmp_path / "copy.calib"))
    assert (tmp_path / "copy.calib").read_bytes() == \
        open(sequence.calibration_path, "rb").read()


def test_calibrate_from_frames(sequence):
    empty = [sequence.images[0], sequence.images[1], sequence.images[2]]
    result = ss.calibrate_from_frames(empty)
    assert [w.issue for w in result.warnings] == ["no_touch_frames"]
    assert isinstance(result.warnings[0], ss.CalibrationWarning)
    assert "touch" in result.warnings[0].message
    assert result.calibration.empty_skin_size == (sequence.images.shape[2],
                                                  sequence.images.shape[1])
    # A labelled touch frame: the palm of frame 6, boxes from the C++ run's track.
    track = next(line.split() for line in
                 (sequence.folder / "cpp_results.txt").read_text().splitlines()
                 if line.startswith("track 6 "))
    shadow_box = tuple(int(v) for v in track[9:13])
    cx, cy = float(track[5]), float(track[6])
    contact_box = (int(cx) - 15, int(cy) - 15, 30, 30)
    result = ss.calibrate_from_frames(empty, [(sequence.images[5], shadow_box, contact_box,
                                               "palm")])
    assert "no_touch_frames" not in [w.issue for w in result.warnings]
    assert len(result.groups) >= 1 and result.groups[0].touch_frames == 1
    # The fitted calibration finds the palm's shadow inside the labelled box, and nothing on
    # the empty skin.
    segmenter = ss.Segmenter(result.calibration)
    s = segmenter.segment(sequence.images[5])
    assert len(s.shadows) == 1
    x, y, w, h = s.shadow_box
    assert shadow_box[0] - 8 <= x and x + w <= shadow_box[0] + shadow_box[2] + 8
    assert shadow_box[1] - 8 <= y and y + h <= shadow_box[1] + shadow_box[3] + 8
    assert segmenter.segment(sequence.images[0]).shadows == []


def test_the_camera_scale_is_recorded_and_used(sequence, model_path, tmp_path):
    calibration = ss.load_calibration(sequence.calibration_path)
    assert calibration.px_per_cm == 0
    calibration.px_per_cm = 2 * 242.5 / 32  # hands twice the network's size
    path = tmp_path / "scaled.calib"
    ss.save_calibration(calibration, str(path))
    assert b"shadowsense_segmenter_calibration 3\n" in path.read_bytes()
    assert ss.load_calibration(str(path)).px_per_cm == calibration.px_per_cm
    plain = ss.Classifier(model_path)
    same = ss.load_calibration(sequence.calibration_path)
    same.px_per_cm = 242.5 / 32  # the network's own scale: frames untouched
    at_network = ss.Classifier(model_path, calibration=same, scale_to_network=True)
    scaled = ss.Classifier(model_path, calibration=calibration, scale_to_network=True)
    unscaled = ss.Classifier(model_path, calibration=calibration)  # off by default
    changed = 0
    for frame in sequence.images[::8]:
        p = plain.classify(frame).probabilities
        np.testing.assert_array_equal(at_network.classify(frame).probabilities, p)
        np.testing.assert_array_equal(unscaled.classify(frame).probabilities, p)
        changed += int(np.abs(scaled.classify(frame).probabilities - p).max() > 1e-4)
    assert changed > 0
    with pytest.raises(ss.InvalidArgument, match="px_per_cm"):
        ss.Classifier(model_path, calibration=ss.load_calibration(sequence.calibration_path),
                      scale_to_network=True)
    calibration.px_per_cm = -1
    with pytest.raises(ss.InvalidArgument, match="px_per_cm"):
        ss.save_calibration(calibration, str(tmp_path / "bad.calib"))
