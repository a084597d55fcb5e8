#!/usr/bin/python3
"""Golden vectors for shadowsense's Preprocessor from torchvision's tensor path:
ToTensor -> Resize(bilinear, antialias=False) -> CenterCrop -> adjust_contrast ->
adjust_brightness (dark images only) -> Normalize.

  /usr/bin/python3 tools/make_preprocess_fixture.py            # tests/data/preprocess_golden.bin
  /usr/bin/python3 tools/make_preprocess_fixture.py --paper -o F  # paper geometry (400x300 in)

File (little-endian): u32 case count; per case: u32 height, width, dark, resize_w, resize_h,
crop_w, crop_h; f32 contrast, brightness; u8 BGR pixels (height*width*3, OpenCV order);
u32 out_h, out_w; f32 output (3*out_h*out_w, RGB planes).
"""
import argparse
import os
import struct

import torch
import torchvision.transforms.functional as TF
from torchvision.transforms import InterpolationMode

import ss_version
from atomic_write import write_atomic

MEAN = [0.485, 0.456, 0.406]
STD = [0.229, 0.224, 0.225]


def images(h, w, gen):
    yy, xx = torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")
    smooth = torch.stack([(xx * 255 // max(w - 1, 1)), (yy * 255 // max(h - 1, 1)),
                          ((xx + yy) * 7) % 256]).to(torch.uint8)
    noise = torch.randint(0, 256, (3, h, w), generator=gen, dtype=torch.uint8)
    dark = torch.randint(0, 60, (3, h, w), generator=gen, dtype=torch.uint8)
    black = torch.zeros(3, h, w, dtype=torch.uint8)
    white = torch.full((3, h, w), 255, dtype=torch.uint8)
    sat = torch.zeros(3, h, w, dtype=torch.uint8)
    sat[0, :, : w // 3] = 255
    sat[1, :, w // 3: 2 * w // 3] = 255
    sat[2, :, 2 * w // 3:] = 255
    sat[:, : h // 4, :] = 255
    # (name, RGB CHW uint8, dark flag)
    return [("smooth", smooth, False), ("noise", noise, False), ("dark", dark, True),
            ("dark_unflagged", dark, False), ("black", black, True), ("white", white, False),
            ("saturated", sat, True)]


def reference(img, resize, crop, contrast, brightness, dark):
    x = img.float().div(255)
    x = TF.resize(x, [resize[1], resize[0]], interpolation=InterpolationMode.BILINEAR,
                  antialias=False)
    x = TF.center_crop(x, [crop[1], crop[0]])
    x = TF.adjust_contrast(x, contrast)
    if dark:
        x = TF.adjust_brightness(x, brightness)
    return TF.normalize(x, MEAN, STD)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--paper", action="store_true", help="400x300 inputs, 318x235, 220x150")
    ap.add_argument("-o", "--output", default=os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data",
        "preprocess_golden.bin"))
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    args = ap.parse_args()
    if args.paper:
        h, w, resize, crop = 300, 400, (318, 235), (220, 150)
    else:
        h, w, resize, crop = 48, 64, (53, 39), (40, 30)  # odd offsets: round half to even
    gen = torch.Generator().manual_seed(11)
    cases = images(h, w, gen)
    out = bytearray(struct.pack("<I", len(cases)))
    for name, img, dark in cases:
        y = reference(img, resize, crop, 3.0, 2.0, dark)
        out += struct.pack("<7I2f", h, w, int(dark), resize[0], resize[1], crop[0], crop[1],
                           3.0, 2.0)
        out += img.flip(0).permute(1, 2, 0).contiguous().numpy().tobytes()  # BGR HWC
        out += struct.pack("<2I", y.shape[1], y.shape[2])
        out += y.contiguous().numpy().astype("<f4").tobytes()
    write_atomic(args.output, bytes(out))  # temp + fsync + rename: never a truncated fixture
    print(f"wrote {args.output}: {len(cases)} cases")


if __name__ == "__main__":
    main()
