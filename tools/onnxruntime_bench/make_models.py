#!/usr/bin/python3
"""Writes the models of the ONNX Runtime comparison into OUT: for DenseNet-121, DenseNet-161
(random weights with non-trivial BatchNorm statistics, tools/densenet_to_model.py
--random-init) and the shipped models/default.ssm, the shadowsense model file NAME.ssm, the same
network exported by torch.onnx (opset 13) as NAME.onnx, one preprocessed input NAME.input.f32
(1 x 3 x H x W float32, little-endian) and PyTorch's logits for it, NAME.torch.f32, plus
models.json listing name, H, W and the .ssm's SHA-256 (run.py refuses a model file that changed
since: the .onnx and the logits would no longer match it). The shipped model is copied into OUT, so
the set stays consistent when models/default.ssm is retrained. Both engines run the identical weights: the ONNX graph is
exported from the model file read back into torchvision.

usage: /usr/bin/python3 tools/onnxruntime_bench/make_models.py OUT
"""
import argparse
import hashlib
import json
import os
import subprocess
import sys

import torch

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import ss_version  # noqa: E402
import train  # noqa: E402  (read_model_file / load_backbone)


def atomic_write(path, data):
    tmp = f"{path}.tmp{os.getpid()}"
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", metavar="OUT", help="folder to write the models into")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    out = ap.parse_args(argv[1:]).out
    os.makedirs(out, exist_ok=True)
    models = []
    for name, h, w in (("densenet121", 150, 220), ("densenet161", 150, 220)):
        path = os.path.join(out, f"{name}.ssm")
        subprocess.run([sys.executable, os.path.join(ROOT, "tools", "densenet_to_model.py"),
                        "--arch", name, "--random-init", "--seed", "1", "-o", path], check=True)
        models.append((name, path, h, w))
    shipped = os.path.join(out, "shipped.ssm")
    with open(os.path.join(ROOT, "models", "default.ssm"), "rb") as f:
        atomic_write(shipped, f.read())
    _, pre, _, _ = train.read_model_file(shipped)
    models.append(("shipped", shipped, pre["resize_height"], pre["resize_width"]))
    listing = []
    gen = torch.Generator().manual_seed(7)
    for name, path, h, w in models:
        model = train.load_backbone(path)[0].eval()
        x = torch.randn(1, 3, h, w, generator=gen)
        with torch.no_grad():
            logits = model(x)
        onnx_path = os.path.join(out, f"{name}.onnx")
        torch.onnx.export(model, x, onnx_path + ".tmp", opset_version=13,
                          input_names=["input"], output_names=["logits"])
        os.replace(onnx_path + ".tmp", onnx_path)
        atomic_write(os.path.join(out, f"{name}.input.f32"), x.numpy().astype("<f4").tobytes())
        atomic_write(os.path.join(out, f"{name}.torch.f32"),
                     logits.numpy().astype("<f4").tobytes())
        with open(path, "rb") as f:
            digest = hashlib.sha256(f.read()).hexdigest()
        listing.append({"name": name, "ssm": os.path.abspath(path), "sha256": digest, "h": h,
                        "w": w})
    atomic_write(os.path.join(out, "models.json"), json.dumps(listing, indent=1).encode())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
