"""The constants and the header of a shadowsense model file (docs/model_format.md), without
torch: tools/densenet_to_model.py writes files with these constants; tools/train.py and
tools/model_encoding.py read headers with read_header.

read_header(data, path, versions=(1, 2, 3, 4)) -> (version, arch, pre, pos)
  data: the file's bytes (the whole file, or at least its header); path names the file in errors.
  arch: growth, bn_size, init, classes, eps, blocks. pre: resize_width, resize_height,
  crop_width, crop_height, contrast, brightness, mean, std, channel_order (0 RGB, 1 BGR),
  lighting_normalise, lighting_target, dark_threshold (version 1's defaults for a version-1
  file) and input_encoding (colour for versions 1-3). pos: the offset of the class names.
  raises ValueError naming path: bad magic, a version not in `versions`, a header cut short, a
  block count outside 1..MAX_BLOCKS, an input encoding code a version-4 file cannot hold.
checksum(data) -> the CRC-32 the file ends with, of every byte before it.
Stateless; safe from any thread.
"""
import struct
import zlib

MAGIC = b"SSDNMOD\n"
VERSION = 2
VERSION_INT8 = 3
# Version 4 (include/shadowsense/backends/densenet/model_file.hpp): version 2 plus the input
# encoding after the dark-frame threshold and an int8 flag before the checksum; written only for
# an encoding other than colour, so colour models stay version 2.
VERSION_ENCODED = 4
# InputEncoding codes 0, 1, 2, 3, 4
INPUT_ENCODINGS = ("colour", "skin_relative", "darkness_warmth", "masks", "darkness_contact")
DEFAULT_LIGHTING_TARGET = 0.35  # LightingNormaliser::Config::target
MAX_BLOCKS = 16


def checksum(data):
    """CRC-32 (zlib) of every byte before the checksum."""
    return zlib.crc32(bytes(data)) & 0xFFFFFFFF


def read_header(data, path, versions=(1, VERSION, VERSION_INT8, VERSION_ENCODED)):
    if len(data) < 12 or data[:8] != MAGIC:
        raise ValueError(f"{path}: not a shadowsense model file (bad magic or too short)")
    pos = 8

    def take(fmt):
        nonlocal pos
        if pos + 4 > len(data):
            raise ValueError(f"{path}: the header is cut short at byte {pos}")
        v = struct.unpack_from(fmt, data, pos)[0]
        pos += 4
        return v

    def u32():
        return take("<I")

    def f32():
        return take("<f")

    version = u32()
    if version not in versions:
        raise ValueError(f"{path}: format version {version}, expected "
                         + ", ".join(map(str, versions[:-1])) + f" or {versions[-1]}")
    growth, bn_size, init, classes = u32(), u32(), u32(), u32()
    eps = f32()
    n_blocks = u32()
    if not 1 <= n_blocks <= MAX_BLOCKS:
        raise ValueError(f"{path}: {n_blocks} dense blocks, expected 1..{MAX_BLOCKS}")
    blocks = tuple(u32() for _ in range(n_blocks))
    rw, rh, cw, ch = u32(), u32(), u32(), u32()
    contrast, brightness = f32(), f32()
    mean = [f32() for _ in range(3)]
    std = [f32() for _ in range(3)]
    order = u32()
    if version >= 2:
        normalise, target, dark_threshold = u32() == 1, f32(), f32()
    else:  # version 1's behaviour
        normalise, target, dark_threshold = False, DEFAULT_LIGHTING_TARGET, 0.0
    encoding = "colour"
    if version == VERSION_ENCODED:
        code = u32()
        if not 1 <= code < len(INPUT_ENCODINGS):  # colour is never version 4
            raise ValueError(f"{path}: input encoding code {code}, expected 1 (skin_relative), "
                             f"2 (darkness_warmth), 3 (masks) or 4 (darkness_contact)")
        encoding = INPUT_ENCODINGS[code]
    arch = dict(growth=growth, blocks=blocks, init=init, bn_size=bn_size, classes=classes, eps=eps)
    pre = dict(resize_width=rw, resize_height=rh, crop_width=cw, crop_height=ch,
               contrast=contrast, brightness=brightness, mean=mean, std=std,
               channel_order=order, lighting_normalise=normalise, lighting_target=target,
               dark_threshold=dark_threshold, input_encoding=encoding)
    return version, arch, pre, pos
