#!/usr/bin/python3
"""Time torchvision's DenseNet forward (batch 1, eval, no_grad) on this machine for the
comparison in bench/bench_densenet.cpp. Prints one line per run:
    torch <arch> threads=<t> ms=<median ms> cpu_ms=<process CPU time per forward>
          peak_mb=<RSS growth of the first forward, MB>
Usage: /usr/bin/python3 tools/bench_torch.py [--archs densenet121 densenet161]
       [--threads 1 2] [--size 150 220] [--reps 10]
"""
import argparse
import resource
import statistics
import time

import torch
import torchvision

import ss_version


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--archs", nargs="+", default=["densenet121", "densenet161"])
    ap.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--size", nargs=2, type=int, default=[150, 220], metavar=("H", "W"))
    ap.add_argument("--reps", type=int, default=10)
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    args = ap.parse_args()
    torch.manual_seed(0)
    x = torch.randn(1, 3, args.size[0], args.size[1])
    for arch in args.archs:
        model = getattr(torchvision.models, arch)(num_classes=5).eval()
        for t in args.threads:
            torch.set_num_threads(t)
            with torch.no_grad():
                before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
                model(x)
                peak_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
                for _ in range(3):
                    model(x)
                times = []
                cpu0 = time.process_time()
                for _ in range(args.reps):
                    t0 = time.perf_counter()
                    model(x)
                    times.append((time.perf_counter() - t0) * 1000)
                cpu_ms = (time.process_time() - cpu0) * 1000 / args.reps
            print(f"torch {arch} threads={t} ms={statistics.median(times):.2f} "
                  f"cpu_ms={cpu_ms:.2f} peak_mb={peak_mb:.1f}", flush=True)


if __name__ == "__main__":
    main()
