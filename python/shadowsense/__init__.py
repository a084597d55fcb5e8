"""shadowsense: touch sensing from shadow images - the C++ library's runtime from Python.

Frames are HxWx3 uint8 numpy arrays in BGR order (as OpenCV reads them), C-contiguous; they are
read in place, never copied. See python/README.md (installed: share/shadowsense/doc/python.md).
"""
from ._shadowsense import *  # noqa: F401,F403
from ._shadowsense import __doc__, __version__  # noqa: F401
