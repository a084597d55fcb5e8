#!/bin/sh
# The Python model-file tools: bad values rejected (exit 2, no traceback), atomic writes,
# version-1 upgrade, train.py on a plain class-per-folder tree (tools/test_model_tools.py).
set -eu
root=$(cd "$(dirname "$0")/../.." && pwd)
/usr/bin/python3 "$root/tools/test_model_tools.py" -v
