#!/usr/bin/python3
"""Print the input encoding a shadowsense model file records (docs/model_format.md): colour for
versions 1-3, the recorded one (skin_relative, darkness_warmth) for version 4. Reads only the
header (tools/model_header.py, no torch), so scripts can choose their options by it.

  tools/model_encoding.py MODEL.ssm        -> prints the encoding's name, exit 0
Exit 2 with a message on stderr when the file is not a model file or its header is cut.

input_encoding(path) -> the name; raises ValueError naming the file on a bad header.
Stateless; safe from any thread.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import model_header  # noqa: E402
import ss_version  # noqa: E402


def input_encoding(path):
    with open(path, "rb") as f:
        data = f.read()
    return model_header.read_header(data, path)[2]["input_encoding"]


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
