#!/usr/bin/python3
"""Convert a torchvision DenseNet into a shadowsense model file (docs/model_format.md).

Sources (exactly one):
  --torchvision NAME      densenet121/161/169/201 built by torchvision; add --pretrained to use
                          torchvision's ImageNet weights (downloads them: needs internet)
  --state-dict PATH       a state_dict or a checkpoint holding one (keys 'state_dict',
                          'model_state_dict' or 'model'), e.g. saved by a training script
  --random-init           random weights AND non-trivial BatchNorm running statistics
                          (for tests); the architecture comes from --arch or the growth options

Architecture: --arch densenet121|161|169|201, or --growth-rate/--block-config/
--init-features/--bn-size; --num-classes (default: inferred from the classifier weights).
--self-test N embeds N random inputs and torchvision's logits for them, which the C++ loader
re-runs at load time.

Preprocessing recorded in the file (format version 2): --resize, --crop, --contrast,
--brightness, --mean, --std, --lighting-normalise (the model was trained on lighting-normalised
images; the C++ Classifier then normalises every frame), --lighting-target, --dark-threshold X
(the dark-frame rule: a frame whose mean luminance 0.2989 R + 0.587 G + 0.114 B, in 0..1, is
below X gets the brightness factor; 0 = never; default 0.165).

Upgrading a version-1 file (what the library read before lighting normalisation and the dark
rule were recorded) to version 2, weights and self-test unchanged:
  /usr/bin/python3 tools/densenet_to_model.py --upgrade OLD.ssm -o NEW.ssm \
      [--lighting-normalise] [--lighting-target T] [--dark-threshold X]
Without --dark-threshold an upgraded file keeps version 1's behaviour (threshold 0: no frame is
dark by the rule). -o may name OLD.ssm itself: the write is atomic.

Bad values (a zero std, a NaN factor, an empty or zero block config, ...) are rejected with a
message and exit status 2, before anything is written; every file is written atomically (a
temporary file in the same folder, fsync, rename; removed on failure).

Run with Debian's python: /usr/bin/python3 tools/densenet_to_model.py ...
"""
import argparse
import math
import os
import re
import struct
import sys

import torch
import torchvision

from atomic_write import write_atomic

# The format's constants live in model_header.py (torch-free, shared with the readers).
from model_header import (DEFAULT_LIGHTING_TARGET, INPUT_ENCODINGS, MAGIC,  # noqa: F401
                          VERSION, VERSION_ENCODED, checksum)
MAX_SIDE = 4096  # preprocess_max_side in include/shadowsense/classify/preprocess_params.hpp
DEFAULT_DARK_THRESHOLD = 0.165  # default_dark_luminance_threshold (same header)
ARCHS = {
    "densenet121": (32, (6, 12, 24, 16), 64),
    "densenet161": (48, (6, 12, 36, 24), 96),
    "densenet169": (32, (6, 12, 32, 32), 64),
    "densenet201": (32, (6, 12, 48, 32), 64),
}


def expected_keys(growth, blocks, init, bn_size, classes):
    keys = []

    def bn(prefix, c):
        for p in ("weight", "bias", "running_mean", "running_var"):
            keys.append((f"{prefix}.{p}", (c,)))

    keys.append(("features.conv0.weight", (init, 3, 7, 7)))
    bn("features.norm0", init)
    c = init
    inner = bn_size * growth
    for b, n in enumerate(blocks):
        for l in range(n):
            layer = f"features.denseblock{b + 1}.denselayer{l + 1}"
            cin = c + l * growth
            bn(layer + ".norm1", cin)
            keys.append((layer + ".conv1.weight", (inner, cin, 1, 1)))
            bn(layer + ".norm2", inner)
            keys.append((layer + ".conv2.weight", (growth, inner, 3, 3)))
        c += n * growth
        if b + 1 < len(blocks):
            bn(f"features.transition{b + 1}.norm", c)
            keys.append((f"features.transition{b + 1}.conv.weight", (c // 2, c, 1, 1)))
            c //= 2
    bn("features.norm5", c)
    keys.append(("classifier.weight", (classes, c)))
    keys.append(("classifier.bias", (classes,)))
    return keys


def normalise_state_dict(sd):
    """Accept checkpoints, DataParallel 'module.' prefixes and the old torchvision key style
    ('norm.1' instead of 'norm1')."""
    for k in ("state_dict", "model_state_dict", "model"):
        if isinstance(sd, dict) and k in sd and isinstance(sd[k], dict):
            sd = sd[k]
    if isinstance(sd, torch.nn.Module):
        sd = sd.state_dict()
    old = re.compile(r"^(.*denselayer\d+\.(?:norm|relu|conv))\.((?:[12])\.(?:weight|bias|running_mean|running_var))$")
    out = {}
    for k, v in sd.items():
        if k.startswith("module."):
            k = k[len("module."):]
        m = old.match(k)
        if m:
            k = m.group(1) + m.group(2)
        out[k] = v
    return out


def randomise_bn(model, gen, h=64, w=64):
    """Non-trivial BatchNorm statistics that keep activations well scaled: gamma/beta away
    from (1, 0), then running statistics measured on random inputs (so every layer sees
    roughly normalised data and the logits stay O(1)) and perturbed per channel, so a wrong
    folding, a swapped tensor or a mean/var mix-up shows in the logits."""
    with torch.no_grad():
        for m in model.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                c = m.num_features
                m.weight.copy_(1.0 + 0.25 * torch.randn(c, generator=gen))
                m.bias.copy_(0.1 * torch.randn(c, generator=gen))
                m.reset_running_stats()
                m.momentum = None  # cumulative average over the calibration batch
            elif isinstance(m, torch.nn.Linear):
                m.bias.copy_(0.1 * torch.randn(m.bias.shape, generator=gen))
        model.train()
        model(torch.randn(4, 3, h, w, generator=gen))
        model.eval()
        for m in model.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                c = m.num_features
                sd = m.running_var.sqrt()
                m.running_mean.add_(0.1 * sd * torch.randn(c, generator=gen))
                m.running_var.mul_(torch.exp(0.3 * torch.randn(c, generator=gen)))
                m.momentum = 0.1


def extreme_bn(model):
    """Hard cases for the folding: in every BatchNorm, channel 0 gets running_var 0 (only eps
    keeps the scale finite), channel 1 a variance of 1e-9 and channel 2 a variance 1e6 times
    larger than measured; gamma is rescaled so activations keep their size (otherwise the
    logits explode to 1e18 through the depth) while the arithmetic sees the extreme values."""
    with torch.no_grad():
        for m in model.modules():
            if isinstance(m, torch.nn.BatchNorm2d) and m.num_features >= 3:
                v = m.running_var
                for c, new in ((0, 0.0), (1, 1e-9), (2, float(v[2]) * 1e6)):
                    m.weight[c] *= ((new + m.eps) / (float(v[c]) + m.eps)) ** 0.5
                    v[c] = new


def build_model(args):
    if args.arch:
        growth, blocks, init = ARCHS[args.arch]
    else:
        growth, blocks, init = args.growth_rate, tuple(args.block_config), args.init_features
    if args.torchvision:
        growth, blocks, init = ARCHS[args.torchvision]
        kwargs = {}
        if args.pretrained:
            kwargs["weights"] = "IMAGENET1K_V1"
        model = getattr(torchvision.models, args.torchvision)(**kwargs)
        if args.num_classes and args.num_classes != model.classifier.out_features:
            model.classifier = torch.nn.Linear(model.classifier.in_features, args.num_classes)
    elif args.state_dict:
        sd = normalise_state_dict(torch.load(args.state_dict, map_location="cpu"))
        classes = args.num_classes or sd["classifier.weight"].shape[0]
        model = torchvision.models.DenseNet(growth, blocks, init, args.bn_size, 0, classes)
        model.load_state_dict(sd)
    else:
        classes = args.num_classes or 1000
        torch.manual_seed(args.seed)
        model = torchvision.models.DenseNet(growth, blocks, init, args.bn_size, 0, classes)
        gen = torch.Generator().manual_seed(args.seed)
        randomise_bn(model, gen)
        if args.extreme_bn:
            extreme_bn(model)
    model.eval()
    return model, growth, blocks, init


def write_model(path, model, growth, blocks, init, bn_size, class_names, pre, self_test):
    sd = model.state_dict()
    classes = sd["classifier.weight"].shape[0]
    eps = None
    for m in model.modules():
        if isinstance(m, torch.nn.BatchNorm2d):
            eps = m.eps if eps is None else eps
            if m.eps != eps:
                raise SystemExit("all BatchNorm layers must share one eps")
    out = bytearray()
    u32 = lambda v: out.extend(struct.pack("<I", v))
    f32 = lambda v: out.extend(struct.pack("<f", v))
    encoding = INPUT_ENCODINGS.index(pre.get("input_encoding", "colour"))
    out.extend(MAGIC)
    u32(VERSION_ENCODED if encoding else VERSION)
    for v in (growth, bn_size, init, classes):
        u32(v)
    f32(eps)
    u32(len(blocks))
    for b in blocks:
        u32(b)
    for v in (pre["resize_width"], pre["resize_height"], pre["crop_width"], pre["crop_height"]):
        u32(v)
    f32(pre["contrast"])
    f32(pre["brightness"])
    for v in list(pre["mean"]) + list(pre["std"]):
        f32(v)
    u32(0)  # the network expects RGB
    u32(1 if pre.get("lighting_normalise") else 0)  # version 2
    f32(pre.get("lighting_target", DEFAULT_LIGHTING_TARGET))
    f32(pre.get("dark_threshold", DEFAULT_DARK_THRESHOLD))
    if encoding:
        u32(encoding)  # version 4
    if len(class_names) != classes:
        raise SystemExit(f"{len(class_names)} class names for {classes} classes")
    u32(classes)
    for n in class_names:
        b = n.encode("utf-8")
        u32(len(b))
        out.extend(b)
    keys = expected_keys(growth, blocks, init, bn_size, classes)
    u32(len(keys))
    for name, shape in keys:
        t = sd[name].detach().to(torch.float32).contiguous()
        if tuple(t.shape) != shape:
            raise SystemExit(f"{name}: shape {tuple(t.shape)}, expected {shape}")
        b = name.encode()
        u32(len(b))
        out.extend(b)
        u32(len(shape))
        for d in shape:
            u32(d)
        out.extend(t.numpy().astype("<f4").tobytes())
    if self_test is None:
        u32(0)
    else:
        x, logits, tol = self_test
        u32(1)
        for d in x.shape:
            u32(d)
        out.extend(x.contiguous().numpy().astype("<f4").tobytes())
        out.extend(logits.contiguous().numpy().astype("<f4").tobytes())
        f32(tol)
    if encoding:
        u32(0)  # version 4: no int8 section
    out.extend(struct.pack("<I", checksum(out)))
    write_atomic(path, out)


def upgrade(data, lighting_normalise, lighting_target, dark_threshold, path="model file"):
    """Version-1 bytes -> version-2 bytes with the given preprocessing options; weights,
    names and self-test unchanged. Raises ValueError with a message on a bad file."""
    if len(data) < 12 or data[:8] != MAGIC:
        raise ValueError(f"{path}: not a shadowsense model file (wrong magic number)")
    if checksum(data[:-4]) != struct.unpack("<I", data[-4:])[0]:
        raise ValueError(f"{path}: checksum mismatch (corrupt or truncated)")
    version = struct.unpack_from("<I", data, 8)[0]
    if version == VERSION:
        raise ValueError(f"{path}: already version {VERSION}; nothing to upgrade")
    if version != 1:
        raise ValueError(f"{path}: format version {version}, expected 1 to upgrade")
    if len(data) < 40:
        raise ValueError(f"{path}: truncated header")
    blocks = struct.unpack_from("<I", data, 8 + 4 + 5 * 4)[0]
    if not 1 <= blocks <= 16:
        raise ValueError(f"{path}: {blocks} dense blocks, expected 1..16")
    # magic, version, 5 architecture fields, block count + blocks, then the 13 version-1
    # preprocessing fields (4 sizes, 2 factors, 6 mean/std, channel order).
    at = 8 + 4 + 5 * 4 + 4 + 4 * blocks + 13 * 4
    if len(data) < at + 8:
        raise ValueError(f"{path}: truncated before the class names")
    extra = struct.pack("<Iff", 1 if lighting_normalise else 0, lighting_target, dark_threshold)
    out = bytearray(data[:8]) + struct.pack("<I", VERSION) + data[12:at] + extra + data[at:-4]
    out.extend(struct.pack("<I", checksum(out)))
    return bytes(out)


def finite(v):
    return isinstance(v, (int, float)) and math.isfinite(v)


def check_preprocessing(error, resize, crop, contrast, brightness, mean, std,
                        lighting_target=DEFAULT_LIGHTING_TARGET, dark_threshold=0.0):
    """The ranges PreprocessParams::validate accepts; error(message) for the first violation."""
    for name, (w, h) in (("--resize", resize), ("--crop", crop)):
        if not (0 <= w <= MAX_SIDE and 0 <= h <= MAX_SIDE and (w == 0) == (h == 0)):
            error(f"{name} {w} {h}: expected both 0 (skip) or both in 1..{MAX_SIDE}")
    if not (finite(contrast) and contrast >= 0):
        error(f"--contrast {contrast}: expected a finite value >= 0")
    if not (finite(brightness) and brightness >= 0):
        error(f"--brightness {brightness}: expected a finite value >= 0")
    if not all(finite(v) for v in mean):
        error(f"--mean {' '.join(map(str, mean))}: expected finite values")
    if not all(finite(v) and v > 0 for v in std):
        error(f"--std {' '.join(map(str, std))}: expected finite values > 0")
    if not (finite(lighting_target) and 0 < lighting_target <= 1):
        error(f"--lighting-target {lighting_target}: expected a value in (0, 1]")
    if not (finite(dark_threshold) and 0 <= dark_threshold <= 1):
        error(f"--dark-threshold {dark_threshold}: expected a value in [0, 1]")


def check_architecture(error, growth, blocks, init, bn_size):
    """The ranges DenseNetArchitecture::validate accepts."""
    if not 1 <= growth <= 4096:
        error(f"--growth-rate {growth}: expected 1..4096")
    if not 1 <= len(blocks) <= 16 or not all(1 <= b <= 1024 for b in blocks):
        error(f"--block-config {' '.join(map(str, blocks))}: expected 1..16 blocks of "
              "1..1024 layers each")
    if not 1 <= init <= 65536:
        error(f"--init-features {init}: expected 1..65536")
    if not 1 <= bn_size <= 64:
        error(f"--bn-size {bn_size}: expected 1..64")


def check_args(ap, args):
    """Reject what the C++ loader would reject, before any work: argparse's error() prints
    the usage and the message and exits with status 2 (no traceback)."""
    check_preprocessing(ap.error, args.resize, args.crop, args.contrast, args.brightness,
                        args.mean, args.std, args.lighting_target,
                        0.0 if args.dark_threshold is None else args.dark_threshold)
    check_architecture(ap.error, args.growth_rate, args.block_config, args.init_features,
                       args.bn_size)
    if not 0 <= args.num_classes <= (1 << 20):
        ap.error(f"--num-classes {args.num_classes}: expected 1..1048576 (0: from the weights)")
    if not 0 <= args.self_test <= 64:
        ap.error(f"--self-test {args.self_test}: expected 0..64")
    if not (finite(args.self_test_tolerance) and args.self_test_tolerance > 0):
        ap.error(f"--self-test-tolerance {args.self_test_tolerance}: expected a finite value > 0")
    if args.class_names and any(len(n.encode("utf-8")) > 1024 for n in args.class_names):
        ap.error("--class-names: a name longer than 1024 bytes")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--torchvision", choices=sorted(ARCHS))
    src.add_argument("--state-dict")
    src.add_argument("--random-init", action="store_true")
    src.add_argument("--upgrade", metavar="OLD",
                     help="rewrite a version-1 model file as version 2 (see above)")
    ap.add_argument("--extreme-bn", action="store_true",
                    help="with --random-init: running_var 0, 1e-9 and x1e6 in channels 0-2")
    ap.add_argument("--pretrained", action="store_true", help="torchvision ImageNet weights")
    ap.add_argument("--arch", choices=sorted(ARCHS))
    ap.add_argument("--growth-rate", type=int, default=32)
    ap.add_argument("--block-config", type=int, nargs="+", default=[6, 12, 24, 16])
    ap.add_argument("--init-features", type=int, default=64)
    ap.add_argument("--bn-size", type=int, default=4)
    ap.add_argument("--num-classes", type=int, default=0)
    ap.add_argument("--class-names", nargs="*", help="default: class0, class1, ...")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--resize", type=int, nargs=2, default=[318, 235], metavar=("W", "H"))
    ap.add_argument("--crop", type=int, nargs=2, default=[220, 150], metavar=("W", "H"))
    ap.add_argument("--contrast", type=float, default=3.0)
    ap.add_argument("--brightness", type=float, default=2.0, help="factor for dark images")
    ap.add_argument("--mean", type=float, nargs=3, default=[0.485, 0.456, 0.406])
    ap.add_argument("--std", type=float, nargs=3, default=[0.229, 0.224, 0.225])
    ap.add_argument("--self-test", type=int, default=0, metavar="N",
                    help="embed N random inputs (crop size) and torchvision's logits")
    ap.add_argument("--self-test-tolerance", type=float, default=1e-4)
    ap.add_argument("--lighting-normalise", action="store_true",
                    help="the model expects lighting-normalised frames (recorded in the file)")
    ap.add_argument("--lighting-target", type=float, default=DEFAULT_LIGHTING_TARGET)
    ap.add_argument("--dark-threshold", type=float, default=None,
                    help=f"dark-frame rule threshold in 0..1 (default {DEFAULT_DARK_THRESHOLD}; "
                         "with --upgrade: 0, version 1's behaviour)")
    ap.add_argument("-o", "--output", required=True)
    import ss_version  # tools/ss_version.py
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    args = ap.parse_args(argv)
    check_args(ap, args)
    if args.upgrade:
        try:
            with open(args.upgrade, "rb") as f:
                data = f.read()
            out = upgrade(data, args.lighting_normalise, args.lighting_target,
                          args.dark_threshold if args.dark_threshold is not None else 0.0,
                          args.upgrade)
            write_atomic(args.output, out)
        except (OSError, ValueError) as e:
            print(f"densenet_to_model.py: {e}", file=sys.stderr)
            sys.exit(2 if isinstance(e, ValueError) else 1)
        print(f"wrote {args.output}: version {VERSION}, lighting normalisation "
              f"{'on' if args.lighting_normalise else 'off'}")
        return

    model, growth, blocks, init = build_model(args)
    classes = model.classifier.out_features
    names = args.class_names or [f"class{i}" for i in range(classes)]
    pre = dict(resize_width=args.resize[0], resize_height=args.resize[1],
               crop_width=args.crop[0], crop_height=args.crop[1], contrast=args.contrast,
               brightness=args.brightness, mean=args.mean, std=args.std,
               lighting_normalise=args.lighting_normalise, lighting_target=args.lighting_target,
               dark_threshold=(DEFAULT_DARK_THRESHOLD if args.dark_threshold is None
                               else args.dark_threshold))
    st = None
    if args.self_test > 0:
        gen = torch.Generator().manual_seed(args.seed + 1)
        h, w = (args.crop[1], args.crop[0]) if args.crop[0] else (args.resize[1], args.resize[0])
        x = torch.randn(args.self_test, 3, h, w, generator=gen)
        with torch.no_grad():
            logits = model(x)
        st = (x, logits, args.self_test_tolerance)
    try:
        write_model(args.output, model, growth, blocks, init, args.bn_size, names, pre, st)
    except OSError as e:
        print(f"densenet_to_model.py: cannot write {args.output}: {e}", file=sys.stderr)
        sys.exit(1)
    print(f"wrote {args.output}: growth {growth}, blocks {list(blocks)}, init {init}, "
          f"bn_size {args.bn_size}, {classes} classes")


if __name__ == "__main__":
    main()
