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


def in_process(ss, frames, samples, model):
    """Python calls against the module's own C++ loops (_update_loop, _classify_loop) on the same
    frames, alternating pass by pass in one process, so both see the same load at almost the
    same moment; returns {benchmark: (C++ ns, Python ns, median of the paired overheads in %)}."""
    from shadowsense import _shadowsense as native
    out = {}
    for size, rig in RIGS:
        images, calibration = frames[rig]
        seg = ss.Segmenter(ss.load_calibration(calibration))
        py_pipe, cpp_pipe = ss.TouchPipeline(seg), ss.TouchPipeline(seg)
        classifier = ss.Classifier(model)
        ten = images[:10]
        state = {"t_py": 0.0, "t_cpp": 0.0}

        def py_track():
            for f in images:
                state["t_py"] += 10
                py_pipe.update(f, state["t_py"])

        def cpp_track():
            state["t_cpp"] = native._update_loop(cpp_pipe, images, state["t_cpp"] + 10, 10) - 10

        def py_classify():
            for f in ten:
                classifier.classify(f)

        def cpp_classify():
            native._classify_loop(classifier, ten)

        for name, n, py_fn, cpp_fn in (("TouchPipeline.update", len(images), py_track, cpp_track),
                                       ("Classifier.classify", len(ten), py_classify, cpp_classify)):
            py_fn(), cpp_fn()  # warm-up
            pairs = []
            for k in range(samples):
                order = (cpp_fn, py_fn) if k % 2 else (py_fn, cpp_fn)
                took = {}
                for fn in order:
                    t0 = time.perf_counter_ns()
                    fn()
                    took[fn] = (time.perf_counter_ns() - t0) / n
                pairs.append((took[cpp_fn], took[py_fn]))
            c = statistics.median(p[0] for p in pairs)
            q = statistics.median(p[1] for p in pairs)
            over = statistics.median((p[1] - p[0]) / p[0] * 100 for p in pairs)
            out[f"{name} {size}"] = (c, q, over)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", default=str(ROOT / "build"))
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--samples", type=int, default=20)
    parser.add_argument("--in-process", action="store_true",
                        help="compare against the module's own C++ loops in this process, pass "
                             "by pass (less disturbed by other load than separate programs)")
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
        if args.in_process:
            print(f"{'benchmark (in process)':34} {'C++ ms/frame':>13} {'Python ms/frame':>16} "
                  f"{'overhead (median of pairs)':>27}")
            for name, (c, q, over) in in_process(ss, frames, args.samples, model).items():
                print(f"{name:34} {c / 1e6:13.3f} {q / 1e6:16.3f} {over:26.1f}%")
            print(f"({os.cpu_count()} cores; {args.samples} alternating pass pairs; the target is "
                  "<= 5%)")
            return
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
