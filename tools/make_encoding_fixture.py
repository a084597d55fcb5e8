#!/usr/bin/python3
"""Golden vectors for FrameEncoder's calibrated input encodings (skin_relative, darkness_warmth)
from tools/train.py's own functions (encode, normalise_lighting, geometry, photometric): what the
training saw is what the C++ encoder must give (tests/test_frame_encoder.cpp).

  /usr/bin/python3 tools/make_encoding_fixture.py
      -> tests/data/encoding_calibration.calib (a version-2 calibration file holding the
         empty-skin model, written by tools/calibration_file.py)
         tests/data/encoding_golden.bin (skin_relative)
         tests/data/encoding_golden_darkness_warmth.bin (darkness_warmth)

The model is 40 x 30 (W x H) with random values in 0.05..1.3 (skin and not skin, channels
under the floor), frames are 40 x 30 (the model's size) and 64 x 48 (the model bilinearly
resized). darkness_warmth adds frames made of the model itself under a light level with a dark
and a warm patch (a meaningful reference), a black frame (the reference's floor) and a frame
off the skin; its cases are never dark (the flag is written and must be ignored) nor
normalised. File (little-endian): u32 case count; per case: u32 height, width, dark, lighting
normalise, resize_w, resize_h, crop_w, crop_h; f32 contrast, brightness; u8 BGR pixels
(height*width*3, OpenCV order); f32 the encoded image (stage 0: height*width*3, B G R
interleaved); u32 out_h, out_w; f32 output (3*out_h*out_w, RGB planes).
"""
import argparse
import os
import struct
import sys

import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import calibration_file  # noqa: E402
import ss_version  # noqa: E402
import train  # noqa: E402
from atomic_write import write_atomic  # noqa: E402


def main():
    data = os.path.join(HERE, "..", "tests", "data")
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--output", default=os.path.join(data, "encoding_golden.bin"))
    ap.add_argument("--output-darkness-warmth",
                    default=os.path.join(data, "encoding_golden_darkness_warmth.bin"))
    ap.add_argument("--calibration", default=os.path.join(data, "encoding_calibration.calib"))
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    args = ap.parse_args()
    gen = torch.Generator().manual_seed(21)
    model = (torch.rand(30, 40, 3, generator=gen) * 1.25 + 0.05).numpy().astype(np.float32)
    model[:6, :, :] *= 0.3  # a band that is not skin (the robot's interior)
    calibration_file.write_calibration(args.calibration, model)
    model = calibration_file.read_empty_skin(args.calibration)  # what C++ will read
    cases = []
    for (h, w) in ((30, 40), (48, 64)):
        for dark, normalise in ((False, False), (True, False), (False, True)):
            frame = torch.randint(0, 256, (3, h, w), generator=gen, dtype=torch.uint8)  # RGB
            if dark:
                frame = frame // 6
            cases.append((frame, dark, normalise))
    write_atomic(args.output, golden(cases, model, "skin_relative", 3.0))
    # darkness_warmth: the random frames (the reference then sits at random values) and frames
    # made of the model itself: the lit skin at a light level, a dark patch (a shadow) and a
    # warm patch (a contact), so that the reference is the skin's and darkness and warmth span
    # their ranges; a black frame (every quotient 0: the reference's floor).
    dw = [(f, d, False) for f, d, n in cases if not n]
    for (h, w), level in (((30, 40), 0.8), ((48, 64), 0.3)):
        import cv2
        m = cv2.resize(model, (w, h), interpolation=cv2.INTER_LINEAR) if (h, w) != (30, 40) \
            else model
        lit = torch.from_numpy(m).permute(2, 0, 1).flip(0) * level  # RGB
        lit[:, h // 2:h // 2 + 8, 4:14] *= 0.3  # a shadow
        lit[1:, 10:16, w - 12:w - 4] *= 0.35  # a contact: red kept, green and blue darker
        noise = torch.rand(3, h, w, generator=gen) * 0.04
        frame = ((lit + noise).clamp(0, 1) * 255).round().to(torch.uint8)
        dw.append((frame, False, False))
    dw.append((torch.zeros(3, 30, 40, dtype=torch.uint8), True, False))
    write_atomic(args.output_darkness_warmth, golden(dw, model, "darkness_warmth", 1.0))
    print(f"wrote {args.calibration}, {args.output} ({len(cases)} cases) and "
          f"{args.output_darkness_warmth} ({len(dw)} cases)")


def golden(cases, model, encoding, contrast):
    resize, crop = (37, 27), (32, 22)  # odd offsets: round half to even
    pre = dict(resize_width=resize[0], resize_height=resize[1], crop_width=crop[0],
               crop_height=crop[1], contrast=contrast, brightness=2.0, mean=train.MEAN,
               std=train.STD, input_encoding=encoding)
    out = bytearray(struct.pack("<I", len(cases)))
    for frame, dark, normalise in cases:
        h, w = frame.shape[1], frame.shape[2]
        x = frame.float().div(255)
        e = train.encode(x, pre, model)
        y = e
        if normalise:
            y = train.normalise_lighting(y)
        y = train.geometry(y, pre)
        # darkness_warmth frames are never dark (train.py's cache() clears the flag).
        dark_used = dark and encoding != "darkness_warmth"
        y = train.photometric(y.unsqueeze(0), torch.tensor([dark_used]), pre, normalise)[0]
        out += struct.pack("<8I2f", h, w, int(dark), int(normalise), resize[0], resize[1],
                           crop[0], crop[1], contrast, 2.0)
        out += frame.flip(0).permute(1, 2, 0).contiguous().numpy().tobytes()  # BGR HWC
        out += e.flip(0).permute(1, 2, 0).contiguous().numpy().astype("<f4").tobytes()
        out += struct.pack("<2I", y.shape[1], y.shape[2])
        out += y.contiguous().numpy().astype("<f4").tobytes()
    return bytes(out)


if __name__ == "__main__":
    main()
