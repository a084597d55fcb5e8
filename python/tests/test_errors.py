"""The library's errors arrive as one Python exception class per C++ type, with the C++
message."""
import pytest

import shadowsense as ss


def test_the_exception_classes():
    for name in ("InvalidArgument", "ModelFileError", "CalibrationFileError", "DatasetError",
                 "IoError", "ConcurrentUseError"):
        assert issubclass(getattr(ss, name), ss.Error)
    assert issubclass(ss.CalibrationFileError, ss.ModelFileError)
    assert issubclass(ss.Error, RuntimeError)
    assert issubclass(ss.InvalidArgument, ValueError)
    assert issubclass(ss.IoError, OSError)


def test_io_and_model_file_errors(tmp_path, test_data):
    with pytest.raises(ss.IoError, match="missing.calib"):
        ss.load_calibration(str(tmp_path / "missing.calib"))
    (tmp_path / "bad.calib").write_text("shadowsense_segmenter_calibration 2\nmode sideways\n")
    with pytest.raises(ss.CalibrationFileError, match="bad.calib"):
        ss.load_calibration(str(tmp_path / "bad.calib"))
    (tmp_path / "bad.ssm").write_bytes(b"not a model")
    with pytest.raises(ss.ModelFileError) as e:
        ss.Classifier(str(tmp_path / "bad.ssm"))
    assert not isinstance(e.value, ss.CalibrationFileError)
    with pytest.raises(ss.IoError):
        ss.CsvSink(str(tmp_path / "no such folder" / "events.csv"))


def test_invalid_arguments_keep_the_cpp_message(sequence, model_path):
    calibration = ss.load_calibration(sequence.calibration_path)
    pipeline = ss.TouchPipeline(ss.Segmenter(calibration))
    pipeline.update(sequence.images[0], 10.0)
    with pytest.raises(ss.InvalidArgument, match="TouchPipeline::update") as e:
        pipeline.update(sequence.images[1], 10.0)  # not after the previous timestamp
    assert isinstance(e.value, ValueError)
    pipeline.update(sequence.images[1], 20.0)  # still usable
    with pytest.raises(ss.InvalidArgument, match="the segmenter is not calibrated"):
        ss.TouchPipeline(ss.Segmenter())
    ss.TouchPipeline(ss.Segmenter(), uncalibrated=True)  # the opt-in by name
    with pytest.raises(ss.InvalidArgument, match="classify_every is 0"):
        ss.Runtime(pipeline, classify_every=0)
    with pytest.raises(ss.InvalidArgument, match="no empty-skin frames"):
        ss.calibrate_from_frames([])
    with pytest.raises(ValueError, match="shadow_box"):
        ss.calibrate_from_frames([sequence.images[0]], [(sequence.images[5], (1, 2, 3), None)])
    with pytest.raises(ss.InvalidArgument, match="no frame yet"):
        ss.Runtime(pipeline).output()


def test_a_classifier_moved_into_a_runtime_is_empty(sequence, model_path):
    classifier = ss.Classifier(model_path)
    pipeline = ss.TouchPipeline(ss.Segmenter(ss.load_calibration(sequence.calibration_path)))
    runtime = ss.Runtime(pipeline, classifier)
    assert runtime.has_classifier
    with pytest.raises(ss.InvalidArgument, match="moved into a Runtime"):
        classifier.classify(sequence.images[5])


def test_sinks_refuse_a_write_after_close(sequence, tmp_path):
    runtime = ss.Runtime(ss.TouchPipeline(ss.Segmenter(ss.load_calibration(
        sequence.calibration_path))))
    runtime.update(sequence.images[0], 1.0)
    sink = ss.CsvSink(str(tmp_path / "e.csv"), source="cam0")
    sink.write(runtime.output())
    assert not (tmp_path / "e.csv").exists()  # written atomically, on close
    sink.close()
    assert (tmp_path / "e.csv").read_text() == ss.event_csv_header + "\n"
    with pytest.raises(ss.InvalidArgument, match="after close"):
        sink.write(runtime.output())
    with pytest.raises(ss.InvalidArgument, match="port"):
        ss.TuioSink("127.0.0.1", 70000)
