"""Threads: the GIL is released while a frame is processed, so instances in different threads
run at once and give the same results as alone; one instance used from two threads at once
raises ConcurrentUseError (which can only happen because the GIL was released), never crashes."""
import threading

import shadowsense as ss
from results import format_frame


def run(sequence, runtime):
    lines = []
    for frame, t in zip(sequence.images, sequence.timestamps):
        lines += format_frame(runtime.update(frame, t))
    return lines


def new_runtime(sequence):
    return ss.Runtime(ss.TouchPipeline(ss.Segmenter(ss.load_calibration(
        sequence.calibration_path))))


def test_one_instance_per_thread_gives_the_serial_results(sequence):
    expected = run(sequence, new_runtime(sequence))
    results = [None] * 3

    def work(k):
        results[k] = run(sequence, new_runtime(sequence))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results == [expected] * 3


def test_one_instance_shared_by_two_threads_raises(sequence):
    segmenter = ss.Segmenter(ss.load_calibration(sequence.calibration_path))
    frame = sequence.images[5]
    errors, results = [], []
    stop = threading.Event()

    def work():
        for _ in range(400):
            if stop.is_set():
                return
            try:
                results.append(len(segmenter.segment(frame).shadows))
            except ss.ConcurrentUseError as e:
                errors.append(str(e))
                stop.set()

    threads = [threading.Thread(target=work) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors, "two threads never overlapped inside one Segmenter"
    assert "one instance is used from two threads at once" in errors[0]
    assert set(results) == {1}  # every call that ran gave the right result
    assert len(segmenter.segment(frame).shadows) == 1  # and the instance is still usable
