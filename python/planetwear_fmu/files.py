"""File helpers shared by the whole package: the atomic write every result,
state, manifest and plot goes through, and the SHA-256 of a file.

Layer 0 with the package's `__init__`: it imports no module of the package
(only the standard library), so every other module may import it. The
layer order is pinned by tests/python/test_package_layers.py.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path


def write_atomic(path, data):
    """Writes bytes to `path` through a temporary file in the same directory
    (fsync, rename, directory fsync): a reader sees the old file or the new
    one, never a part."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def sha256_file(path):
    """The SHA-256 of a file's bytes (hex), read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()
