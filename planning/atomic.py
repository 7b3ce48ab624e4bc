"""Atomic file writes: a reader never sees half a result file or checkpoint; and a file's digest."""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path


def write_text(path, text: str) -> Path:
    """Write text to a temporary file beside `path`, then rename it into place."""
    return write_bytes(path, text.encode())


def write_bytes(path, data: bytes) -> Path:
    """Write bytes to a temporary file beside `path`, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o666 & ~current_umask())     # mkstemp makes 0600; a file gets the usual mode
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def current_umask() -> int:
    """The process umask (read by setting it and setting it back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_json(path, obj) -> Path:
    """Write JSON atomically (indented, keys in insertion order)."""
    return write_text(path, json.dumps(obj, indent=1) + "\n")


def sha256(path) -> str | None:
    """The hex sha256 of a file's bytes (None if there is no such file): the provenance of a checkpoint."""
    path = Path(path)
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
