#!/usr/bin/python3
"""Train a shadowsense gesture classifier with the paper's recipe (section 5.1.3) and write the
library's model file (docs/model_format.md).

Recipe: Adam (lr 1e-3, betas 0.9/0.999, eps 1e-8, weight decay 0), negative log-likelihood on
log-softmax, batch 16, 20 epochs; the epoch with the best validation accuracy is kept (ties:
lower validation loss). --lr-schedule cosine (not the paper's) decays the learning rate from --lr
towards 0 over the epochs (half a cosine, per epoch: epoch e of E trains at
lr * (1 + cos(pi * (e - 1) / E)) / 2), so the last epochs make small steps. --swa-from E (not
the paper's) keeps the mean of the weights after epochs E..last instead of the best epoch
(stochastic weight averaging, Izmailov et al. 2018), with the BatchNorm statistics recomputed
over the training inputs; the validation split then only reports. --teacher FILE (repeatable;
not the paper's) adds knowledge distillation (Hinton et al. 2015): the loss is
(1 - a) * NLL(labels) + a * T^2 * KL(teachers || student at temperature T), the teachers' target
the mean of their softmax(logits / T) on the very input the student sees (same augmentation),
a = --distill-weight, T = --distill-temperature; every teacher must be a model file with the
student's classes and input (encoding, geometry, photometrics). Teachers use no random numbers,
so the data order and augmentation are those of the same --seed without them. Preprocessing is the
C++ Preprocessor's tensor path exactly (ToTensor, bilinear resize without antialias, centre crop,
adjust_contrast, adjust_brightness for dark images, Normalize), optionally preceded by the
lighting normalisation of include/shadowsense/classify/lighting_normalise.hpp
(--lighting-normalise), and by the input
encoding of include/shadowsense/classify/frame_encoder.hpp (--input-encoding):
  colour          the frame as it is (the default; every model before format version 4)
  skin_relative   the frame over the calibration's empty-skin model, 0 off the skin, clipped
                  at 1 (skin_relative() below). The empty-skin model comes from --calibration
                  FILE (one robot for every frame), or else per session from the dataset's
                  empty_skin/<session>.calib (ss_gesture_data --empty-skin; docs/dataset_format.md).
                  The model file records the encoding (format version 4): the C++ programs then
                  need --calibration FILE, and refuse to run without one.
  darkness_warmth the relative pixel rule's darkness and warmth maps beside the skin mask
                  (darkness_warmth() below), from the same empty-skin models; independent of the
                  light level, so it takes no --lighting-normalise and no frame is dark.
  masks           the library's segmenter's shadow and contact masks beside the skin mask, from
                  the same calibrations; light-independent like darkness_warmth. Encoded by the
                  C++ library itself through its Python module (shadowsense.encode_input, the
                  code the classifier runs at inference): build it and put <build>/python on
                  PYTHONPATH (models/make_c11.sh does).
  darkness_contact darkness_warmth's darkness map, the masks encoding's contact mask in place of
                  warmth, and the skin mask (a combination); made by the library like masks.

Modes
  --mode scratch    a compact DenseNet (--growth-rate/--block-config/--init-features/--bn-size)
                    trained from random initialisation
  --mode transfer   the feature extractor of --backbone (a shadowsense model file or a
                    torchvision state_dict/checkpoint) frozen (BatchNorm in eval mode), a new
                    linear classifier trained on its pooled features (computed once)

Data: a folder in the library's dataset format (root/<class>/*.png + root/metadata.csv with
file_name, class, user, lighting, session, timestamp_ms, ...), or a plain class-per-folder tree
without metadata.csv: root/<class>/**/*.{png,jpg,jpeg,bmp} (recursive, sorted by path; user and
lighting absent, the frames of a class in path order stand for its collection order, and the
dark-frame rule decides which frames get the brightness factor). Split selection by metadata:
  --users / --exclude-users, --lightings / --exclude-lightings   which rows may be used at all
  --holdout 0.3      drop the last 30% (by timestamp) of every session x class block: the
                     test part of the paper's Table 1 split, never seen here
  --val-fraction 0.3 validation = the last 30% (by timestamp) of every session x class block
                     of what remains (the paper's 70/30 train/validation split)
  --val-users / --val-lightings   validation = those rows instead (leave-out experiments)
Dark images (brightness factor): lighting 'night', or a lighting_level below 0.25; in a plain
tree, a mean luminance below --dark-threshold (the rule the model file records for inference).
The model file records the preprocessing, --lighting-normalise and --dark-threshold included,
so the C++ Classifier encodes frames the same way without flags. The output (and
--save-state-dict) are written atomically: no partial or temporary file is left behind.

  /usr/bin/python3 tools/train.py DATA -o model.ssm --mode scratch --resize 160 88 --crop 0 0
  /usr/bin/python3 tools/train.py DATA -o model.ssm --mode transfer --backbone base.ssm
"""
import argparse
import io
import math
import os
import random
import struct
import sys
import time

import torch
import torch.nn.functional as F
import torchvision
import torchvision.transforms.functional as TF
from torchvision.transforms import InterpolationMode

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import calibration_file  # noqa: E402
import dataset_reader  # noqa: E402
from atomic_write import write_atomic  # noqa: E402
import densenet_to_model as d2m  # noqa: E402
import model_header  # noqa: E402
import ss_version  # noqa: E402

MEAN = [0.485, 0.456, 0.406]
STD = [0.229, 0.224, 0.225]
DARK_LEVEL = 0.25
# Lighting normalisation (include/shadowsense/classify/lighting_normalise.hpp): every channel scaled so its mean
# over the image becomes TARGET (gray world + exposure), then clamped to [0, 1].
NORMALISE_TARGET = 0.35
# The skin_relative encoding (include/shadowsense/classify/frame_encoder.hpp): a pixel is skin
# when B + G + R of the empty-skin model is at least SKIN_MODEL_SUM; each channel is divided
# by the model's, floored at MODEL_FLOOR.
SKIN_MODEL_SUM = 1.5
MODEL_FLOOR = 0.125
# The darkness_warmth encoding's frame reference (FrameEncoder): the 90th percentile of each
# channel's quotient over the skin samples, in bins of 1/REFERENCE_BINS_PER_UNIT, floored.
REFERENCE_BINS = 1024
REFERENCE_BINS_PER_UNIT = 512.0
REFERENCE_FLOOR = 1.0 / 64.0
# The encodings with the light level divided out (light_independent, preprocess_params.hpp).
LIGHT_INDEPENDENT = ("darkness_warmth", "masks", "darkness_contact")
# The encodings that run the library's segmenter (through its Python module).
SEGMENTED = ("masks", "darkness_contact")


# ---------------------------------------------------------------------------------- model file
def read_model_file(path):
    """Parse a shadowsense model file: (architecture dict, preprocessing dict, class names,
    state_dict). The checksum is verified."""
    data = open(path, "rb").read()
    if len(data) < 12 or data[:8] != model_header.MAGIC:
        raise SystemExit(f"{path}: not a shadowsense model file (bad magic)")
    if model_header.checksum(data[:-4]) != struct.unpack("<I", data[-4:])[0]:
        raise SystemExit(f"{path}: checksum mismatch (corrupt or truncated)")
    try:  # not version 3: int8 (docs/model_format.md)
        _, arch, pre, pos = model_header.read_header(
            data, path, versions=(1, model_header.VERSION, model_header.VERSION_ENCODED))
    except ValueError as e:
        raise SystemExit(str(e))
    if pre.pop("channel_order") != 0:
        raise SystemExit(f"{path}: network channel order BGR is not supported by train.py")

    def u32():
        nonlocal pos
        v = struct.unpack_from("<I", data, pos)[0]
        pos += 4
        return v

    names = []
    for _ in range(u32()):
        n = u32()
        names.append(data[pos:pos + n].decode("utf-8"))
        pos += n
    sd = {}
    for _ in range(u32()):
        n = u32()
        name = data[pos:pos + n].decode()
        pos += n
        shape = tuple(u32() for _ in range(u32()))
        count = 1
        for d in shape:
            count *= d
        t = torch.frombuffer(bytearray(data[pos:pos + 4 * count]), dtype=torch.float32)
        pos += 4 * count
        sd[name] = t.reshape(shape).clone()
    return arch, pre, names, sd


def load_backbone(path):
    """A torchvision DenseNet from a model file or a state_dict/checkpoint; returns
    (model, growth, blocks, init, bn_size, preprocessing dict or None)."""
    with open(path, "rb") as f:
        head = f.read(8)
    if head == d2m.MAGIC:
        arch, pre, _, sd = read_model_file(path)
        model = torchvision.models.DenseNet(arch["growth"], arch["blocks"], arch["init"],
                                            arch["bn_size"], 0, arch["classes"])
        for k in list(model.state_dict()):
            if k.endswith("num_batches_tracked"):
                sd[k] = torch.tensor(0)
        model.load_state_dict(sd)
        return model, arch["growth"], arch["blocks"], arch["init"], arch["bn_size"], pre
    sd = d2m.normalise_state_dict(torch.load(path, map_location="cpu"))
    # Infer the architecture from the tensor shapes.
    init = sd["features.conv0.weight"].shape[0]
    growth = sd["features.denseblock1.denselayer1.conv2.weight"].shape[0]
    bn_size = sd["features.denseblock1.denselayer1.conv1.weight"].shape[0] // growth
    blocks = []
    b = 1
    while f"features.denseblock{b}.denselayer1.conv1.weight" in sd:
        n = 1
        while f"features.denseblock{b}.denselayer{n + 1}.conv1.weight" in sd:
            n += 1
        blocks.append(n)
        b += 1
    classes = sd["classifier.weight"].shape[0]
    model = torchvision.models.DenseNet(growth, tuple(blocks), init, bn_size, 0, classes)
    model.load_state_dict(sd, strict=False)
    return model, growth, tuple(blocks), init, bn_size, None


# -------------------------------------------------------------------------------- data + split
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp")


def read_class_folders(root):
    """A plain class-per-folder tree: root/<class>/**/<image>, recursive, sorted by path."""
    if not os.path.isdir(root):
        raise SystemExit(f"{root}: not a folder")
    rows = []
    for cls in sorted(os.listdir(root)):
        top = os.path.join(root, cls)
        if not os.path.isdir(top) or cls.startswith("."):
            continue
        files = []
        for folder, dirs, names in os.walk(top):
            dirs[:] = sorted(d for d in dirs if not d.startswith("."))
            files += [os.path.join(folder, n) for n in names
                      if n.lower().endswith(IMAGE_EXTENSIONS) and not n.startswith(".")]
        for i, path in enumerate(sorted(files)):
            rows.append({"file_name": os.path.relpath(path, root), "class": cls, "user": "",
                         "lighting": "", "lighting_level": float("nan"), "session": cls,
                         "timestamp_ms": float(i), "path": path})
    if not rows:
        raise SystemExit(f"{root}: no metadata.csv and no images in class sub-folders "
                         f"(expected root/<class>/*.png)")
    return rows


def mean_luminance(x):
    """x: RGB 3 x H x W in [0, 1] -> mean of 0.2989 R + 0.587 G + 0.114 B (FrameEncoder)."""
    return float((0.2989 * x[0] + 0.587 * x[1] + 0.114 * x[2]).mean())


def is_dark(row, x=None, threshold=0.0):
    """The metadata's lighting when there is one, else the dark-frame rule on the image."""
    if not row["lighting"] and x is not None:
        return threshold > 0 and mean_luminance(x) < threshold
    if row["lighting"] == "night":
        return True
    lv = row.get("lighting_level")
    return lv == lv and lv < DARK_LEVEL and row["lighting"] == "custom"


def time_split(rows, fraction):
    """Per session x class block, the last `fraction` of the frames by timestamp go to the
    second list."""
    blocks = {}
    for r in rows:
        blocks.setdefault((r["session"], r["class"]), []).append(r)
    first, last = [], []
    for key in sorted(blocks):
        b = sorted(blocks[key], key=lambda r: r["timestamp_ms"])
        cut = len(b) - int(round(fraction * len(b)))
        first += b[:cut]
        last += b[cut:]
    return first, last


def csv_list(s):
    return [x for x in s.split(",") if x] if s else None


def select(rows, args):
    def keep(r, users, lightings, ex_users, ex_lightings):
        return ((users is None or r["user"] in users) and
                (lightings is None or r["lighting"] in lightings) and
                (ex_users is None or r["user"] not in ex_users) and
                (ex_lightings is None or r["lighting"] not in ex_lightings))

    pool = [r for r in rows if keep(r, csv_list(args.users), csv_list(args.lightings),
                                    csv_list(args.exclude_users),
                                    csv_list(args.exclude_lightings))]
    if args.holdout > 0:
        pool, _ = time_split(pool, args.holdout)
    if args.val_users or args.val_lightings:
        vu, vl = csv_list(args.val_users), csv_list(args.val_lightings)
        val = [r for r in pool if (vu and r["user"] in vu) or (vl and r["lighting"] in vl)]
        train = [r for r in pool if r not in val]
    else:
        train, val = time_split(pool, args.val_fraction)
    if not train:
        raise SystemExit("the selection leaves no training rows")
    if not val:
        raise SystemExit("the selection leaves no validation rows")
    return train, val


# ----------------------------------------------------------------------------- preprocessing
def load_image(path):
    """RGB float tensor 3 x H x W in [0, 1] (ToTensor)."""
    from PIL import Image
    try:
        with Image.open(path) as im:
            im = im.convert("RGB")
            x = torch.frombuffer(bytearray(im.tobytes()), dtype=torch.uint8)
            x = x.reshape(im.height, im.width, 3).permute(2, 0, 1)
    except Exception as e:  # PIL raises many types for corrupt files
        raise SystemExit(f"{path}: cannot read image ({e})")
    return x.float().div(255)


def skin_quotient(x, empty_skin):
    """(q, skin): x RGB 3 x H x W in [0, 1] over empty_skin, a calibration's model (numpy
    float32 h x w x 3, B G R), bilinearly resized to H x W with cv2.resize (INTER_LINEAR, the
    library's cv::resize) when its size differs. skin = (B + G) + R of the model >=
    SKIN_MODEL_SUM; q = x / max(model, MODEL_FLOOR) per channel in float32 (RGB planes)."""
    h, w = x.shape[1], x.shape[2]
    m = empty_skin
    if m.shape[0] != h or m.shape[1] != w:
        import cv2
        m = cv2.resize(m, (w, h), interpolation=cv2.INTER_LINEAR)
    m = torch.from_numpy(m.astype("float32", copy=False)).permute(2, 0, 1)  # B, G, R planes
    skin = (m[0] + m[1]) + m[2] >= SKIN_MODEL_SUM
    return x / m.flip(0).clamp_min(MODEL_FLOOR), skin


def skin_relative(x, empty_skin):
    """The skin_relative encoding of FrameEncoder: min(q, 1) on the skin, 0 off it."""
    q, skin = skin_quotient(x, empty_skin)
    return torch.where(skin, torch.clamp(q, max=1.0), torch.zeros((), dtype=q.dtype))


def darkness_warmth(x, empty_skin):
    """The darkness_warmth encoding of FrameEncoder (its header has the definition): the
    quotient q over the frame's reference r (per channel the 90th percentile of q over the skin
    samples of rows and columns 1, 4, 7, ..., binned), then darkness = 1 - mean, warmth = 0.5 +
    0.5 (R - B), both clamped to [0, 1], and the skin mask: RGB planes darkness, warmth, skin;
    0 off the skin."""
    q, skin = skin_quotient(x, empty_skin)
    samples = q[:, 1::3, 1::3][:, skin[1::3, 1::3]]  # 3 x n
    n = samples.shape[1]
    ref = torch.ones(3)
    if n > 0:
        target = max(1, (9 * n + 9) // 10)
        bins = (samples * REFERENCE_BINS_PER_UNIT).clamp(max=REFERENCE_BINS - 1).long()
        for c in range(3):
            below = torch.bincount(bins[c], minlength=REFERENCE_BINS).cumsum(0)
            b = min(int((below >= target).nonzero()[0]), REFERENCE_BINS - 1)
            ref[c] = max(REFERENCE_FLOOR, (b + 0.5) / REFERENCE_BINS_PER_UNIT)
    p = q / ref.view(3, 1, 1)
    darkness = (1.0 - ((p[2] + p[1]) + p[0]) / 3.0).clamp(0, 1)
    warmth = (0.5 + 0.5 * (p[0] - p[2])).clamp(0, 1)
    out = torch.stack([darkness, warmth, torch.ones_like(darkness)])
    return torch.where(skin, out, torch.zeros((), dtype=out.dtype))


class EmptySkins:
    """The empty-skin model of a row: one --calibration file for all, or the dataset's
    empty_skin/<session>.calib (read once per session). With whole=True, the calibration
    itself as the library's Python module loads it (the masks encoding)."""

    def __init__(self, root, calibration, whole=False):
        self.root, self.cache, self.whole = root, {}, whole
        self.single = self.read(calibration) if calibration else None

    def read(self, path):
        try:
            m = calibration_file.read_empty_skin(path)
            scale = calibration_file.read_px_per_cm(path)
        except calibration_file.CalibrationFileError as e:
            raise SystemExit(f"train.py: {e}")
        if scale > 0:  # the C++ encoder would rescale these frames; training here does not
            raise SystemExit(f"train.py: {path} records the camera's scale (px_per_cm {scale}); "
                             f"training does not rescale frames to the network's scale, so it "
                             f"would not match inference: use a calibration without px_per_cm")
        if m is None:
            raise SystemExit(f"train.py: {path}: the calibration holds no empty-skin model, "
                             f"which a calibrated --input-encoding needs (ss_calibrate --empty)")
        return library().load_calibration(path) if self.whole else m

    def __call__(self, row):
        if self.single is not None:
            return self.single
        session = row["session"]
        if session not in self.cache:
            path = os.path.join(self.root, "empty_skin", f"{session}.calib")
            if not os.path.isfile(path):
                raise SystemExit(f"train.py: a calibrated --input-encoding needs the empty-skin "
                                 f"model of session '{session}': no {path} (write the dataset "
                                 f"with ss_gesture_data --empty-skin, or pass --calibration FILE)")
            self.cache[session] = self.read(path)
        return self.cache[session]


def normalise_lighting(x):
    m = x.mean(dim=(1, 2), keepdim=True).clamp_min(1e-3)
    return (x * (NORMALISE_TARGET / m)).clamp(0, 1)


def geometry(x, pre):
    if pre["resize_width"] and (x.shape[2] != pre["resize_width"] or
                                x.shape[1] != pre["resize_height"]):
        x = TF.resize(x, [pre["resize_height"], pre["resize_width"]],
                      interpolation=InterpolationMode.BILINEAR, antialias=False)
    if pre["crop_width"]:
        x = TF.center_crop(x, [pre["crop_height"], pre["crop_width"]])
    return x


def photometric(x, dark, pre, normalised):
    """contrast -> brightness (dark images; not after lighting normalisation) -> Normalize,
    on a batch N x 3 x h x w (adjust_contrast's mean is per image)."""
    x = TF.adjust_contrast(x, pre["contrast"])
    if not normalised and dark.any():
        x = torch.where(dark.view(-1, 1, 1, 1), TF.adjust_brightness(x, pre["brightness"]), x)
    return TF.normalize(x, pre["mean"], pre["std"])


def augment(x, gen):
    """Lighting augmentation on the cached geometry-stage tensors: per-image and per-channel
    gain, a gamma, sensor noise."""
    n = x.shape[0]
    gain = torch.exp(torch.empty(n, 1, 1, 1).uniform_(-0.25, 0.25, generator=gen))
    ch = torch.exp(torch.empty(n, 3, 1, 1).uniform_(-0.1, 0.1, generator=gen))
    gamma = torch.exp(torch.empty(n, 1, 1, 1).uniform_(-0.2, 0.2, generator=gen))
    x = (x * gain * ch).clamp(1e-6, 1).pow(gamma)
    sigma = torch.empty(n, 1, 1, 1).uniform_(0, 0.03, generator=gen)
    return (x + sigma * torch.randn(x.shape, generator=gen)).clamp(0, 1)


def augment_geometry(x, gen):
    """Geometric augmentation (--augment-geometry): random horizontal and vertical flips
    (people stand on either side of the robot) and a random scale 0.85-1.15 and shift of up to
    8% of the frame (other lenses, mounting heights and hand sizes), per image."""
    n = x.shape[0]
    sx = torch.where(torch.rand(n, generator=gen) < 0.5, -1.0, 1.0)
    sy = torch.where(torch.rand(n, generator=gen) < 0.5, -1.0, 1.0)
    scale = torch.empty(n).uniform_(0.85, 1.15, generator=gen)
    theta = torch.zeros(n, 2, 3)
    theta[:, 0, 0] = sx / scale
    theta[:, 1, 1] = sy / scale
    theta[:, :, 2] = torch.empty(n, 2).uniform_(-0.16, 0.16, generator=gen)
    grid = F.affine_grid(theta, list(x.shape), align_corners=False)
    return F.grid_sample(x, grid, mode="bilinear", padding_mode="border", align_corners=False)


def library():
    """The library's Python module (the masks encoding runs its segmenter)."""
    try:
        import shadowsense
    except ImportError as e:
        raise SystemExit(f"train.py: --input-encoding masks / darkness_contact run the library's "
                         f"segmenter through its Python module, which cannot be imported ({e}): "
                         f"build the project and set PYTHONPATH=<build>/python")
    return shadowsense


_ENCODERS = {}


def input_encoder(encoding, calibration):
    """One library InputEncoder per session calibration and encoding, reused over its frames
    (the same values as a new encoder per frame, 2.5-10x faster by encoding: the empty-skin
    model, and the masks' segmenter, are prepared once). The calibration is kept in the entry so
    its id is never reused."""
    key = (id(calibration), encoding)
    if key not in _ENCODERS:
        _ENCODERS[key] = (calibration, library().InputEncoder(encoding, calibration))
    return _ENCODERS[key][1]


def segmented(x, encoding, calibration):
    """The masks or darkness_contact encoding of FrameEncoder, computed by the library itself:
    x RGB 3 x H x W in [0, 1] from an 8-bit image (exact in uint8), calibration the library's
    Calibration."""
    bgr = x.flip(0).mul(255).round().to(torch.uint8).permute(1, 2, 0).contiguous().numpy()
    out = input_encoder(encoding, calibration).encode(bgr)  # H x W x 3, B G R slots
    return torch.from_numpy(out).permute(2, 0, 1).flip(0).contiguous()


def encode(x, pre, empty_skin=None):
    """The frame -> the Preprocessor's input image (stage 0 of FrameEncoder)."""
    if pre.get("input_encoding", "colour") in SEGMENTED:
        return segmented(x, pre["input_encoding"], empty_skin)
    if pre.get("input_encoding", "colour") == "skin_relative":
        return skin_relative(x, empty_skin)
    if pre.get("input_encoding", "colour") == "darkness_warmth":
        return darkness_warmth(x, empty_skin)
    return x


def cache(rows, pre, normalised, classes, label, empty_skins=None):
    xs, ys, dark = [], [], []
    t0 = time.time()
    for i, r in enumerate(rows):
        x = load_image(r["path"])
        # The frame, not the encoding; darkness_warmth and masks have divided the light out:
        # never dark.
        dark.append(is_dark(r, x, pre.get("dark_threshold", 0.0)) and
                    pre.get("input_encoding", "colour") not in LIGHT_INDEPENDENT)
        if pre.get("input_encoding", "colour") != "colour":
            x = encode(x, pre, empty_skins(r))
        if normalised:
            x = normalise_lighting(x)
        xs.append(geometry(x, pre))
        if r["class"] not in classes:
            raise SystemExit(f"{r['path']}: class '{r['class']}' is not among the model's "
                             f"classes {classes}")
        ys.append(classes.index(r["class"]))
        if (i + 1) % 500 == 0:
            print(f"  {label}: loaded {i + 1}/{len(rows)} images ({time.time() - t0:.0f} s)",
                  flush=True)
    return torch.stack(xs), torch.tensor(ys), torch.tensor(dark)


# ---------------------------------------------------------------------------------- training
def evaluate(model, x, y, dark, pre, normalised, batch=64):
    model.eval()
    loss, correct = 0.0, 0
    with torch.no_grad():
        for i in range(0, len(y), batch):
            out = F.log_softmax(model(photometric(x[i:i + batch], dark[i:i + batch], pre,
                                                  normalised)), dim=1)
            loss += F.nll_loss(out, y[i:i + batch], reduction="sum").item()
            correct += (out.argmax(1) == y[i:i + batch]).sum().item()
    return loss / len(y), correct / len(y)


def epoch_lr(lr, schedule, epoch, epochs):
    """The learning rate of epoch `epoch` (1-based) of `epochs` under `schedule`."""
    if schedule == "constant":
        return lr
    return lr * (1.0 + math.cos(math.pi * (epoch - 1) / epochs)) / 2.0


def average_into(avg, model, n):
    """Running mean of the parameters: avg (a dict name -> tensor, or None) holds the mean of n
    earlier snapshots; returns the mean with model's current parameters added."""
    cur = {k: p.detach().clone() for k, p in model.named_parameters()}
    if avg is None:
        return cur
    return {k: avg[k] + (cur[k] - avg[k]) / (n + 1) for k in avg}


def recompute_batch_norm(model, batches):
    """BatchNorm running statistics made again for weights they were not collected with (an
    average of snapshots): reset, then the plain mean over `batches` (an iterable of inputs; the
    same size each gives the mean over all their samples), the network in training mode."""
    norms = [m for m in model.modules() if isinstance(m, torch.nn.modules.batchnorm._BatchNorm)]
    saved = [m.momentum for m in norms]
    for m in norms:
        m.reset_running_stats()
        m.momentum = None  # cumulative average
    model.train()
    with torch.no_grad():
        for x in batches:
            model(x)
    for m, mom in zip(norms, saved):
        m.momentum = mom


def distillation_loss(logits, y, teacher_probs, weight, temperature):
    """(1 - weight) * NLL of the labels + weight * T^2 * KL(teacher_probs || softmax(logits / T))
    (Hinton et al. 2015; T^2 keeps the soft term's gradient scale independent of T). logits
    N x C, y N labels, teacher_probs N x C (the teachers' mean softmax at T); batch means."""
    hard = F.nll_loss(F.log_softmax(logits, dim=1), y)
    soft = F.kl_div(F.log_softmax(logits / temperature, dim=1), teacher_probs,
                    reduction="batchmean")
    return (1.0 - weight) * hard + weight * temperature * temperature * soft


def teacher_probabilities(teachers, x, temperature):
    """The mean over the teachers (eval mode) of softmax(logits / T) on input x."""
    with torch.no_grad():
        return torch.stack([F.softmax(t(x) / temperature, dim=1) for t in teachers]).mean(0)


# The model file's preprocessing fields that make a teacher's input differ from the student's.
TEACHER_INPUT_FIELDS = ("resize_width", "resize_height", "crop_width", "crop_height", "contrast",
                        "brightness", "mean", "std", "lighting_normalise", "dark_threshold",
                        "input_encoding")


def same_value(a, b):
    """Equal strings / booleans, or numbers (or lists of them) within 1e-6 (the model file
    stores float32)."""
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same_value(u, v) for u, v in zip(a, b))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return abs(float(a) - float(b)) <= 1e-6
    return a == b


def load_teachers(paths, classes, pre, fail):
    """The --teacher model files as DenseNets in eval mode; fail(message) when one cannot be
    read or differs from the student in classes or input."""
    teachers = []
    for path in paths:
        try:
            _, tpre, tclasses, _ = read_model_file(path)
        except (OSError, SystemExit) as e:
            fail(f"--teacher {path}: cannot be read ({e})")
        if list(tclasses) != list(classes):
            fail(f"--teacher {path}: classes {list(tclasses)}, the student's are {list(classes)}")
        for k in TEACHER_INPUT_FIELDS:
            a, b = tpre.get(k, "colour" if k == "input_encoding" else None), pre.get(k)
            if not same_value(a, b):
                fail(f"--teacher {path}: input differs from the student's in {k} ({a} vs {b})")
        model = load_backbone(path)[0]
        model.eval()
        for p in model.parameters():
            p.requires_grad_(False)
        teachers.append(model)
    return teachers


def train_loop(model, params, forward, n_train, val_fn, args, gen, bn_batches=None):
    """Trains; keeps the best validation epoch, or with args.swa_from = E > 0 the mean of the
    parameters after epochs E..last (stochastic weight averaging) with the BatchNorm statistics
    recomputed over bn_batches() (an iterable of training inputs)."""
    opt = torch.optim.Adam(params, lr=args.lr, betas=(0.9, 0.999), eps=1e-8, weight_decay=0)
    best = None
    swa_from = getattr(args, "swa_from", 0)
    avg, n_avg = None, 0
    for epoch in range(1, args.epochs + 1):
        t0 = time.time()
        for group in opt.param_groups:
            group["lr"] = epoch_lr(args.lr, args.lr_schedule, epoch, args.epochs)
        perm = torch.randperm(n_train, generator=gen)
        total, correct, seen = 0.0, 0, 0
        for i in range(0, n_train, args.batch_size):
            idx = perm[i:i + args.batch_size]
            logits, y, *soft = forward(idx)  # soft: the teachers' targets when distilling
            out = F.log_softmax(logits, dim=1)
            loss = (distillation_loss(logits, y, soft[0], args.distill_weight,
                                      args.distill_temperature) if soft else F.nll_loss(out, y))
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
            correct += (out.argmax(1) == y).sum().item()
            seen += len(idx)
        if swa_from and epoch >= swa_from:
            avg, n_avg = average_into(avg, model, n_avg), n_avg + 1
        vloss, vacc = val_fn()
        better = best is None or vacc > best[1] or (vacc == best[1] and vloss < best[2])
        if better:
            best = (epoch, vacc, vloss, {k: v.clone() for k, v in model.state_dict().items()})
        print(f"epoch {epoch:2d}/{args.epochs}  train loss {total / seen:.4f}  train acc "
              f"{correct / seen:.4f}  val loss {vloss:.4f}  val acc {vacc:.4f}  "
              f"({time.time() - t0:.1f} s){'  best' if better else ''}", flush=True)
    if swa_from:
        with torch.no_grad():
            for k, p in model.named_parameters():
                p.copy_(avg[k])
        if bn_batches is not None:
            recompute_batch_norm(model, bn_batches())
        vloss, vacc = val_fn()
        print(f"kept the mean of epochs {swa_from}-{args.epochs}: val acc {vacc:.4f}, "
              f"val loss {vloss:.4f}", flush=True)
        return (args.epochs, vacc, vloss, None)
    model.load_state_dict(best[3])
    print(f"best epoch {best[0]}: val acc {best[1]:.4f}, val loss {best[2]:.4f}", flush=True)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("data", help="dataset folder (root/<class>/*.png + metadata.csv), or a "
                                 "plain class-per-folder tree")
    ap.add_argument("-o", "--output", required=True, help="model file to write")
    ap.add_argument("--mode", choices=["scratch", "transfer"], default="scratch")
    ap.add_argument("--backbone", help="transfer: model file or state_dict of a DenseNet")
    ap.add_argument("--growth-rate", type=int, default=12)
    ap.add_argument("--block-config", type=int, nargs="+", default=[4, 4, 4])
    ap.add_argument("--init-features", type=int, default=24)
    ap.add_argument("--bn-size", type=int, default=4)
    ap.add_argument("--resize", type=int, nargs=2, default=[160, 88], metavar=("W", "H"))
    ap.add_argument("--crop", type=int, nargs=2, default=[0, 0], metavar=("W", "H"))
    ap.add_argument("--contrast", type=float, default=3.0)
    ap.add_argument("--brightness", type=float, default=2.0)
    ap.add_argument("--lighting-normalise", action="store_true",
                    help="normalise every image's channel means before preprocessing (and "
                         "skip the dark-image brightness factor); the classifier must do the "
                         "same at inference (ss_eval_classify --lighting-normalise)")
    ap.add_argument("--dark-threshold", type=float, default=d2m.DEFAULT_DARK_THRESHOLD,
                    help="dark-frame rule recorded in the model (mean luminance below it: "
                         "dark); 0 = never")
    ap.add_argument("--input-encoding", choices=d2m.INPUT_ENCODINGS, default="colour",
                    help="what the network sees (see above); recorded in the model file")
    ap.add_argument("--calibration", metavar="FILE",
                    help="a calibrated encoding: the calibration file (ss_calibrate) whose "
                         "empty-skin model every frame is divided by (default: the dataset's "
                         "empty_skin/<session>.calib)")
    ap.add_argument("--augment", action="store_true", help="lighting augmentation (scratch)")
    ap.add_argument("--augment-geometry", action="store_true",
                    help="flips, scale and shift augmentation (scratch)")
    ap.add_argument("--users"), ap.add_argument("--exclude-users")
    ap.add_argument("--lightings"), ap.add_argument("--exclude-lightings")
    ap.add_argument("--holdout", type=float, default=0.0)
    ap.add_argument("--val-fraction", type=float, default=0.3)
    ap.add_argument("--val-users"), ap.add_argument("--val-lightings")
    ap.add_argument("--classes", help="comma-separated class order (default: sorted names)")
    ap.add_argument("--epochs", type=int, default=20)
    ap.add_argument("--batch-size", type=int, default=16)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--lr-schedule", choices=["constant", "cosine"], default="constant",
                    help="constant (the paper's recipe) or cosine: decay --lr to 0 over the "
                         "epochs")
    ap.add_argument("--swa-from", type=int, default=0, metavar="EPOCH",
                    help="keep the mean of the weights after epochs EPOCH..last (stochastic "
                         "weight averaging, BatchNorm statistics recomputed) instead of the best "
                         "validation epoch; 0 (default): off")
    ap.add_argument("--teacher", action="append", default=[], metavar="FILE",
                    help="distil from this model file (repeatable: the teachers' mean)")
    ap.add_argument("--distill-weight", type=float, default=0.5,
                    help="weight of the teachers' term with --teacher (0..1)")
    ap.add_argument("--distill-temperature", type=float, default=2.0,
                    help="softmax temperature of the teachers' term with --teacher (> 0)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--save-state-dict", help="also save the torch state_dict here")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    args = ap.parse_args(argv)
    d2m.check_preprocessing(ap.error, args.resize, args.crop, args.contrast, args.brightness,
                            MEAN, STD, d2m.DEFAULT_LIGHTING_TARGET, args.dark_threshold)
    d2m.check_architecture(ap.error, args.growth_rate, args.block_config, args.init_features,
                           args.bn_size)
    for name, v, lo in (("--epochs", args.epochs, 1), ("--batch-size", args.batch_size, 1),
                        ("--threads", args.threads, 1)):
        if v < lo:
            ap.error(f"{name} {v}: expected at least {lo}")
    if not 0 <= args.swa_from <= args.epochs:
        ap.error(f"--swa-from {args.swa_from}: expected 0 (off) or an epoch in 1..{args.epochs}")
    if not (d2m.finite(args.distill_weight) and 0 <= args.distill_weight <= 1):
        ap.error(f"--distill-weight {args.distill_weight}: expected a value in [0, 1]")
    if not (d2m.finite(args.distill_temperature) and args.distill_temperature > 0):
        ap.error(f"--distill-temperature {args.distill_temperature}: expected a finite value > 0")
    if args.teacher and args.mode != "scratch":
        ap.error("--teacher is for --mode scratch")
    if not (d2m.finite(args.lr) and args.lr > 0):
        ap.error(f"--lr {args.lr}: expected a finite value > 0")
    for name, v in (("--holdout", args.holdout), ("--val-fraction", args.val_fraction)):
        if not (d2m.finite(v) and 0 <= v < 1):
            ap.error(f"{name} {v}: expected a value in [0, 1)")
    if args.calibration and args.input_encoding == "colour":
        ap.error("--calibration is for a calibrated --input-encoding (colour needs none)")
    if args.lighting_normalise and args.input_encoding in LIGHT_INDEPENDENT:
        ap.error(f"--input-encoding {args.input_encoding} is already independent of the light "
                 f"level and takes no --lighting-normalise")
    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    random.seed(args.seed)
    gen = torch.Generator().manual_seed(args.seed)

    # A dataset folder is read (and checked) by the shared reader; a plain class-per-folder
    # tree has no metadata.csv.
    if os.path.isfile(os.path.join(args.data, "metadata.csv")):
        rows = dataset_reader.rows_for_training(args.data)
    else:
        rows = read_class_folders(args.data)
    classes = csv_list(args.classes) or sorted({r["class"] for r in rows})
    train_rows, val_rows = select(rows, args)
    print(f"{len(train_rows)} training and {len(val_rows)} validation images, classes "
          f"{classes}", flush=True)

    pre = dict(resize_width=args.resize[0], resize_height=args.resize[1],
               crop_width=args.crop[0], crop_height=args.crop[1], contrast=args.contrast,
               brightness=args.brightness, mean=MEAN, std=STD,
               lighting_normalise=args.lighting_normalise,
               lighting_target=d2m.DEFAULT_LIGHTING_TARGET, dark_threshold=args.dark_threshold,
               input_encoding=args.input_encoding)
    if args.mode == "transfer":
        if not args.backbone:
            raise SystemExit("--mode transfer needs --backbone")
        model, growth, blocks, init, bn_size, bpre = load_backbone(args.backbone)
        if bpre is not None:  # keep the backbone's input geometry and photometrics
            pre = dict(bpre, lighting_normalise=args.lighting_normalise,
                       dark_threshold=args.dark_threshold, input_encoding=args.input_encoding)
        model.classifier = torch.nn.Linear(model.classifier.in_features, len(classes))
    else:
        growth, blocks, init, bn_size = (args.growth_rate, tuple(args.block_config),
                                         args.init_features, args.bn_size)
        model = torchvision.models.DenseNet(growth, blocks, init, bn_size, 0, len(classes))
    for r in train_rows + val_rows:
        if r["class"] not in classes:
            raise SystemExit(f"{r['path']}: class '{r['class']}' not in {classes}")
    missing = [c for c in classes if c not in {r["class"] for r in train_rows}]
    if missing:
        raise SystemExit(f"no training images of class(es) {missing}")

    empty_skins = (EmptySkins(args.data, args.calibration, whole=args.input_encoding in SEGMENTED)
                   if args.input_encoding != "colour" else None)
    xt, yt, dt = cache(train_rows, pre, args.lighting_normalise, classes, "train", empty_skins)
    xv, yv, dv = cache(val_rows, pre, args.lighting_normalise, classes, "val", empty_skins)
    print(f"input {tuple(xt.shape[1:])}, mode {args.mode}, growth {growth}, blocks "
          f"{list(blocks)}, init {init}, bn_size {bn_size}", flush=True)

    if args.mode == "transfer":
        # Frozen features, computed once: norm5 -> relu -> global average pool.
        model.eval()
        for p in model.features.parameters():
            p.requires_grad_(False)

        def feats(x, d):
            out = []
            with torch.no_grad():
                for i in range(0, len(x), 64):
                    f = model.features(photometric(x[i:i + 64], d[i:i + 64], pre,
                                                   args.lighting_normalise))
                    out.append(F.adaptive_avg_pool2d(F.relu(f), 1).flatten(1))
            return torch.cat(out)

        ft, fv = feats(xt, dt), feats(xv, dv)
        head = model.classifier

        def forward(idx):
            return head(ft[idx]), yt[idx]

        def val_fn():
            with torch.no_grad():
                out = F.log_softmax(head(fv), dim=1)
                return F.nll_loss(out, yv).item(), (out.argmax(1) == yv).float().mean().item()

        train_loop(head, head.parameters(), forward, len(yt), val_fn, args, gen)
    else:
        def training_inputs(idx):  # the network's input for training samples idx (augmented)
            x = xt[idx]
            if args.augment:
                x = augment(x, gen)
            if args.augment_geometry:
                x = augment_geometry(x, gen)
            return photometric(x, dt[idx], pre, args.lighting_normalise)

        teachers = load_teachers(args.teacher, classes, pre, ap.error)

        def forward(idx):
            model.train()
            x = training_inputs(idx)
            if teachers:
                return (model(x), yt[idx],
                        teacher_probabilities(teachers, x, args.distill_temperature))
            return model(x), yt[idx]

        def val_fn():
            return evaluate(model, xv, yv, dv, pre, args.lighting_normalise)

        def bn_batches():  # the training inputs as training sees them
            order = torch.randperm(len(yt), generator=gen)
            for i in range(0, len(yt), args.batch_size):
                yield training_inputs(order[i:i + args.batch_size])

        train_loop(model, model.parameters(), forward, len(yt), val_fn, args, gen, bn_batches)

    model.eval()
    st_gen = torch.Generator().manual_seed(args.seed + 1)
    x = torch.randn(1, 3, xt.shape[2], xt.shape[3], generator=st_gen)
    with torch.no_grad():
        logits = model(x)
    try:  # atomic: never a half-written model (or a temporary file) left behind
        d2m.write_model(args.output, model, growth, blocks, init, bn_size, classes, pre,
                        (x, logits, 1e-4))
        if args.save_state_dict:
            buf = io.BytesIO()
            torch.save(model.state_dict(), buf)
            write_atomic(args.save_state_dict, buf.getvalue())
    except OSError as e:
        raise SystemExit(f"train.py: cannot write the output: {e}")
    print(f"wrote {args.output} ({os.path.getsize(args.output)} bytes)", flush=True)


if __name__ == "__main__":
    main()
