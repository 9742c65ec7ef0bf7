"""File helpers shared by the whole package: the one reader of input files
(`read_input`: regular files only, never blocking, one size limit per kind
of file), the atomic write every result, state, manifest and plot goes
through, the removal of temporary files a killed run left, and the SHA-256
of a file.

The size limits are the Rust crate's (`src/files/mod.rs`, `MAX_*_BYTES`,
docs/LIMITS.md): a file the tool writes is one this package reads, and
tests/python/test_hostile.py checks that the two lists agree.

Layer 0 with the package's `__init__`: it imports no module of the package
(only the standard library), so every other module may import it. The
layer order is pinned by tests/python/test_package_layers.py.
"""

from __future__ import annotations

import hashlib
import itertools
import os
import stat
from pathlib import Path

# Largest file of each kind [bytes]: the Rust crate's MAX_<KIND>_BYTES.
LIMITS = {
    "scene": 1 << 20,
    "plan": 1 << 20,
    "worn_state": 64 << 20,
    "campaign": 1 << 20,
    "record": 16 << 20,
    "library": 512 << 20,
    "duty_cycle": 32 << 20,
}

# How every temporary file of the project begins (the Rust crate's
# files::TEMP_PREFIX): `.planetwear-tmp.<pid>.<n>.<target name>`.
TEMP_PREFIX = ".planetwear-tmp."

_counter = itertools.count()


class InputError(ValueError):
    """An input file refused: not a regular file, or over its kind's limit."""


def _what(mode):
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _mib(n):
    return f"{n >> 20} MiB" if n % (1 << 20) == 0 else f"{n} bytes"


def read_input(path, kind):
    """The bytes of the input file `path` of `kind` (a key of `LIMITS`).
    Refuses, naming the path, the kind and the limit, a path that is not a
    regular file (looked at before opening, opened without blocking, looked
    at again once open) and a file over the kind's limit (never reading more
    than the limit). Symbolic links are followed."""
    limit = LIMITS[kind]
    name = kind.replace("_", " ") + " file"
    path = Path(path)
    st = os.stat(path)
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"'{path}': is {_what(st.st_mode)}, not a regular file: a {name} must be a regular file")
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(f.fileno())
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"'{path}': is {_what(st.st_mode)}, not a regular file: a {name} must be a regular file")
        if st.st_size > limit:
            raise InputError(f"'{path}': is {st.st_size} bytes, larger than the {_mib(limit)} a {name} may have")
        data = f.read(limit + 1)
    if len(data) > limit:
        raise InputError(f"'{path}': is more than {_mib(limit)}, larger than the {_mib(limit)} a {name} may have")
    return data


def remove_stale_temps(directory):
    """Removes from `directory` the temporary files (`TEMP_PREFIX`) of
    processes that no longer run, and nothing else; returns how many."""
    directory = Path(directory)
    removed = 0
    if not directory.is_dir():
        return 0
    proc = Path("/proc/self").exists()
    for p in directory.iterdir():
        if not p.name.startswith(TEMP_PREFIX):
            continue
        pid = p.name[len(TEMP_PREFIX):].split(".", 1)[0]
        if not pid.isdigit():
            continue
        alive = int(pid) == os.getpid() or not proc or Path(f"/proc/{pid}").exists()
        if not alive and p.is_file() and not p.is_symlink():
            p.unlink(missing_ok=True)
            removed += 1
    return removed


def output_target(path):
    """The file an output path names, with the Rust crate's policy
    (docs/LIMITS.md): a symbolic link is followed (its target is written, the
    link stays; a link to nothing is refused) and an existing path that is
    not a regular file (a directory, a device, a named pipe, a socket) is
    refused with `InputError`."""
    path = Path(path)
    if path.is_symlink():
        try:
            path = path.resolve(strict=True)
        except (FileNotFoundError, RuntimeError):
            raise InputError(f"'{path}': is a symbolic link to {os.readlink(path)}, which does not exist: "
                             "give the file's own path") from None
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return path
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"'{path}': is {_what(st.st_mode)}: an output file may only replace a regular file")
    return path


def write_atomic(path, data):
    """Writes bytes to `path` through a temporary file in the same directory
    (`TEMP_PREFIX`; fsync, rename, directory fsync): a reader sees the old
    file or the new one, never a part. What `path` may be: `output_target`."""
    path = output_target(path)
    tmp = path.with_name(f"{TEMP_PREFIX}{os.getpid()}.{next(_counter)}.{path.name}")
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
