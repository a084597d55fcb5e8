"""write_atomic(path, data): the one way the project's Python tools write a file.

The data goes to a temporary file in the same folder (fsync, then rename over `path`): the old
file is replaced completely or left untouched, and the temporary file never outlives a failure
(it is removed and the error raised again). `data` is bytes, or a str written as UTF-8 with no
newline translation. The file is made readable by all (0644), as a plain open() would with the
usual umask (mkstemp makes it 0600).
"""
import os
import tempfile


def write_atomic(path, data):
    if isinstance(data, str):
        data = data.encode("utf-8")
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix="." + os.path.basename(path) + ".tmp-")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
