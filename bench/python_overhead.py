#!/usr/bin/env python3
"""Python overhead per frame: TouchPipeline.update and Classifier.classify through the Python
module against the same loops in C++ (the Catch2 bench bench_python), on the same frames
(ss_python_fixture bench), at 200x205 and 635x350, one thread.

    /usr/bin/python3 bench/python_overhead.py [--build build] [--rounds 3] [--samples 20]

Each round runs the C++ bench (Catch2, mean of --samples samples) and then the Python loop
(mean of --samples timed passes after one warm-up pass) of the same unit of work - 40 frames of
TouchPipeline.update, 10 frames of Classifier.classify - and the rounds alternate, so both
sides see the same machine load. Printed: per round, and over the rounds the fastest (the least
disturbed by other load, the headline figure) and the median, ms per frame for C++ and Python
and the overhead in percent.
"""
import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

ROOT = pathlib.Path(__file__).resolve().parent.parent
RIGS = [("200x205", "tracking_box"), ("635x350", "robot")]
UNITS = {"TouchPipeline.update": 40, "Classifier.classify": 10}  # frames per sample


def cpp_means(build, samples):
    """{benchmark name: mean ns per sample} of one run of the Catch2 bench."""
    out = subprocess.run([str(build / "bench" / "bench_python"), "--benchmark-samples",
                          str(samples), "-r", "xml"], check=True, capture_output=True,
                         text=True).stdout
    means = {}
    for result in ET.fromstring(out).iter("BenchmarkResults"):
        means[result.get("name")] = float(result.find("mean").get("value"))
    return means


def python_means(ss, frames, samples, model):
    """The same benchmarks through the Python module, in ns per sample."""
    means = {}
    for size, rig in RIGS:
        images, calibration = frames[rig]
        pipeline = ss.TouchPipeline(ss.Segmenter(ss.load_calibration(calibration)))
        classifier = ss.Classifier(model)
        t = 0.0

        def track():
            nonlocal t
            n = 0
            for f in images:
                t += 10
                n += len(pipeline.update(f, t).tracks)
            return n

        def classify():
            return sum(classifier.classify(images[i]).index for i in range(10))

        for name, fn in (("TouchPipeline.update", track), ("Classifier.classify", classify)):
            fn()  # warm-up
            times = []
            for _ in range(samples):
                t0 = time.perf_counter_ns()
                fn()
                times.append(time.perf_counter_ns() - t0)
            means[f"{name} {size}, {UNITS[name]} frames"] = statistics.fmean(times)
    return means


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", default=str(ROOT / "build"))
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--samples", type=int, default=20)
    args = parser.parse_args()
    build = pathlib.Path(args.build).resolve()
    sys.path.insert(0, str(build / "python"))
    sys.path.insert(0, str(ROOT / "python" / "tests"))
    import numpy as np
    import shadowsense as ss
    from results import Frames

    model = str(ROOT / "models" / "default.ssm")
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([str(build / "python" / "ss_python_fixture"), "bench", tmp], check=True)
        frames = {}
        for _, rig in RIGS:
            f = Frames(pathlib.Path(tmp) / rig)
            frames[rig] = ([np.ascontiguousarray(i) for i in f.images], f.calibration_path)
        rounds = []
        for r in range(args.rounds):
            cpp = cpp_means(build, args.samples)
            py = python_means(ss, frames, args.samples, model)
            rounds.append((cpp, py))
    names = list(rounds[0][0])
    print(f"{'benchmark':44} {'C++ ms/frame':>13} {'Python ms/frame':>16} {'overhead':>9}")
    for name in names:
        per_frame = int(name.rsplit(", ", 1)[1].split()[0])
        overheads = []
        for r, (cpp, py) in enumerate(rounds, 1):
            c, p = cpp[name] / per_frame / 1e6, py[name] / per_frame / 1e6
            overheads.append((p - c) / c * 100)
            print(f"{name + f' (round {r})':44} {c:13.3f} {p:16.3f} {overheads[-1]:8.1f}%")
        for label, pick in (("fastest", min), ("median", statistics.median)):
            c = pick(cpp[name] for cpp, _ in rounds) / per_frame / 1e6
            p = pick(py[name] for _, py in rounds) / per_frame / 1e6
            print(f"{name + f' ({label})':44} {c:13.3f} {p:16.3f} {(p - c) / c * 100:8.1f}%")
    print(f"({os.cpu_count()} cores; C++ and Python rounds alternate; the target is <= 5%)")


if __name__ == "__main__":
    main()
