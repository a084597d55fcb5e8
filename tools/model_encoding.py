#!/usr/bin/python3
"""Print the input encoding a shadowsense model file records (docs/model_format.md): colour for
versions 1-3, the recorded one (skin_relative, darkness_warmth) for version 4. Reads only the
header (no torch), so scripts can choose their options by it: a darkness_warmth model takes no
--lighting-normalise (docs/input_encodings.md).

  tools/model_encoding.py MODEL.ssm        -> prints the encoding's name, exit 0
Exit 2 with a message on stderr when the file is not a model file or its header is cut.

input_encoding(path) -> the name; raises ValueError naming the file on a bad header.
Stateless; safe from any thread.
"""
import argparse
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ss_version  # noqa: E402

MAGIC = b"SSDNMOD\n"
ENCODINGS = ("colour", "skin_relative", "darkness_warmth")  # InputEncoding codes 0, 1, 2
MAX_BLOCKS = 16


def input_encoding(path):
    with open(path, "rb") as f:
        d = f.read(36 + 4 * MAX_BLOCKS + 80)
    if d[:8] != MAGIC or len(d) < 36:
        raise ValueError(f"{path}: not a shadowsense model file (bad magic or too short)")
    version = struct.unpack_from("<I", d, 8)[0]
    if version != 4:
        return "colour"  # versions 1-3 record no encoding
    blocks = struct.unpack_from("<I", d, 32)[0]
    if not 1 <= blocks <= MAX_BLOCKS:
        raise ValueError(f"{path}: {blocks} dense blocks, expected 1..{MAX_BLOCKS}")
    # After the block sizes: resize and crop (4 u32), contrast and brightness, mean and std
    # (8 f32), the channel order, the lighting flag, target and dark threshold (4 fields).
    at = 36 + 4 * blocks + 16 + 8 + 24 + 4 + 12
    if len(d) < at + 4:
        raise ValueError(f"{path}: the header is cut before the input encoding")
    code = struct.unpack_from("<I", d, at)[0]
    if not 1 <= code < len(ENCODINGS):
        raise ValueError(f"{path}: input encoding code {code}, expected 1..{len(ENCODINGS) - 1}")
    return ENCODINGS[code]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model", help="a shadowsense model file")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    args = ap.parse_args(argv)
    try:
        print(input_encoding(args.model))
    except (OSError, ValueError) as e:
        print(f"model_encoding.py: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
