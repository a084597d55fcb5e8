#!/usr/bin/python3
"""Regenerate tests/data/densenet_tiny.ssdn: a compact DenseNet (growth 8, blocks 2-3-2,
init 16, bn_size 2, 7 classes) with random weights and calibrated-then-perturbed BatchNorm
statistics, plus an embedded self-test of 2 random 3x45x61 inputs and torchvision's logits for
them, and densenet_tiny_extreme_bn.ssdn (the same with extreme BatchNorm variances). Odd sizes exercise floor/ceil in every pooling. Run from the repository root:
    /usr/bin/python3 tools/make_densenet_fixture.py
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import densenet_to_model  # noqa: E402
import ss_version  # noqa: E402


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    ap.parse_args(argv)
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data",
                       "densenet_tiny.ssdn")
    common = [
        "--random-init", "--growth-rate", "8", "--block-config", "2", "3", "2",
        "--init-features", "16", "--bn-size", "2", "--num-classes", "7",
        "--class-names", "none", "hover", "palm", "fist", "finger", "poke", "punch",
        "--seed", "7", "--self-test", "2", "--crop", "61", "45", "--resize", "80", "60",
    ]
    densenet_to_model.main(common + ["-o", out])
    # The same network with BatchNorm variances of 0, 1e-9 and x1e6 in channels 0-2 of every norm.
    densenet_to_model.main(common + ["--extreme-bn", "-o", out.replace("tiny", "tiny_extreme_bn")])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
