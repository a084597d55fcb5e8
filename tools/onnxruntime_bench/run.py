#!/usr/bin/python3
"""Side-by-side: ONNX Runtime and the shadowsense forward pass, alternately in one run, on the
models written by make_models.py, at 1 and 2 threads. Each round runs ONNX Runtime then ours
(fresh process each, warm-up excluded); the table gives the median over all rounds, the ratio
ours / ONNX Runtime, GFLOP/s (2 x multiply-adds / time) and each engine's logits against
PyTorch's (max relative difference, argmax agreement); then each engine's process CPU time per
pass (all its threads; median over rounds), their ratio, and the 1-minute load average when the
row was measured (the machine may be shared: at 1 thread the CPU time is the fairer figure).

usage: /usr/bin/python3 tools/onnxruntime_bench/run.py MODELS_DIR FORWARD_TIME ORT_NODE_MODULES
       [--rounds R] [--iterations N] [--threads 1,2]
  FORWARD_TIME      path of the built bench/forward_time program
  ORT_NODE_MODULES  the node_modules folder holding onnxruntime-node
"""
import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))  # tools/
import ss_version  # noqa: E402


def run_json(cmd, env=None):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise SystemExit(f"run.py: error: {' '.join(cmd)} failed:\n{r.stderr}")
    return json.loads(r.stdout)


def rel_diff(a, ref):
    a, ref = np.asarray(a, np.float64), np.asarray(ref, np.float64)
    return float(np.max(np.abs(a - ref)) / max(np.max(np.abs(ref)), 1e-30))


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("models_dir")
    ap.add_argument("forward_time")
    ap.add_argument("ort_node_modules")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--iterations", type=int, default=10)
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    a = ap.parse_args(argv)
    if a.rounds < 1 or a.iterations < 1:
        ap.error("--rounds and --iterations must be >= 1")
    threads = [int(t) for t in a.threads.split(",")]
    env = dict(os.environ, NODE_PATH=os.path.abspath(a.ort_node_modules))
    models = json.load(open(os.path.join(a.models_dir, "models.json")))
    for m in models:  # the .onnx and PyTorch's logits were made from this exact file
        with open(m["ssm"], "rb") as f:
            digest = hashlib.sha256(f.read()).hexdigest()
        if digest != m.get("sha256", digest):
            print(f"run.py: error: {m['ssm']} changed since make_models.py wrote "
                  f"{a.models_dir}; run make_models.py again", file=sys.stderr)
            return 2
    print(f"{'model':12} {'thr':>3} {'ORT ms':>8} {'ours ms':>8} {'ratio':>6} "
          f"{'ORT GF/s':>8} {'ours GF/s':>9} {'ORT rel':>8} {'ours rel':>8} argmax "
          f"{'ORT cpu':>8} {'ours cpu':>8} {'cpu ratio':>9} {'load':>5}")
    for m in models:
        base = os.path.join(a.models_dir, m["name"])
        ref = np.fromfile(base + ".torch.f32", dtype="<f4")
        for t in threads:
            ort_ms, our_ms, ort_cpu, our_cpu = [], [], [], []
            for _ in range(a.rounds):
                o = run_json(["node", os.path.join(HERE, "ort_time.js"), base + ".onnx",
                              base + ".input.f32", str(m["h"]), str(m["w"]), str(t),
                              str(a.iterations)], env)
                s = run_json([a.forward_time, m["ssm"], base + ".input.f32", str(m["h"]),
                              str(m["w"]), str(t), str(a.iterations)])
                ort_ms += o["ms"]
                our_ms += s["ms"]
                ort_cpu.append(o["cpu_ms"])
                our_cpu.append(s["cpu_ms"])
            load = os.getloadavg()[0]
            oc, sc = statistics.median(ort_cpu), statistics.median(our_cpu)
            om, sm = statistics.median(ort_ms), statistics.median(our_ms)
            flop = 2.0 * s["macs"]
            same = int(np.argmax(o["logits"])) == int(np.argmax(ref)) == int(np.argmax(s["logits"]))
            print(f"{m['name']:12} {t:>3} {om:8.2f} {sm:8.2f} {sm / om:6.2f} "
                  f"{flop / om / 1e6:8.1f} {flop / sm / 1e6:9.1f} {rel_diff(o['logits'], ref):8.1e} "
                  f"{rel_diff(s['logits'], ref):8.1e} {'same' if same else 'DIFFERS':6} "
                  f"{oc:8.2f} {sc:8.2f} {sc / oc:9.2f} {load:5.2f}   "
                  f"(kernel {s['kernel']})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
