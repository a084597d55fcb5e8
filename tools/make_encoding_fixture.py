#!/usr/bin/python3
"""Golden vectors for FrameEncoder's skin_relative input encoding from tools/train.py's own
functions (skin_relative, normalise_lighting, geometry, photometric): what the training saw is
what the C++ encoder must give (tests/test_frame_encoder.cpp).

  /usr/bin/python3 tools/make_encoding_fixture.py
      -> tests/data/encoding_calibration.calib (a version-2 calibration file holding the
         empty-skin model, written by tools/calibration_file.py)
         tests/data/encoding_golden.bin

The model is 40 x 30 (W x H) with random values in 0.05..1.3 (skin and not skin, channels
under the floor), frames are 40 x 30 (the model's size) and 64 x 48 (the model bilinearly
resized). File (little-endian): u32 case count; per case: u32 height, width, dark, lighting
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
    resize, crop = (37, 27), (32, 22)  # odd offsets: round half to even
    pre = dict(resize_width=resize[0], resize_height=resize[1], crop_width=crop[0],
               crop_height=crop[1], contrast=3.0, brightness=2.0, mean=train.MEAN,
               std=train.STD, input_encoding="skin_relative")
    out = bytearray(struct.pack("<I", len(cases)))
    for frame, dark, normalise in cases:
        h, w = frame.shape[1], frame.shape[2]
        x = frame.float().div(255)
        e = train.encode(x, pre, model)
        y = e
        if normalise:
            y = train.normalise_lighting(y)
        y = train.geometry(y, pre)
        y = train.photometric(y.unsqueeze(0), torch.tensor([dark]), pre, normalise)[0]
        out += struct.pack("<8I2f", h, w, int(dark), int(normalise), resize[0], resize[1],
                           crop[0], crop[1], 3.0, 2.0)
        out += frame.flip(0).permute(1, 2, 0).contiguous().numpy().tobytes()  # BGR HWC
        out += e.flip(0).permute(1, 2, 0).contiguous().numpy().astype("<f4").tobytes()
        out += struct.pack("<2I", y.shape[1], y.shape[2])
        out += y.contiguous().numpy().astype("<f4").tobytes()
    write_atomic(args.output, bytes(out))
    print(f"wrote {args.calibration} and {args.output}: {len(cases)} cases")


if __name__ == "__main__":
    main()
