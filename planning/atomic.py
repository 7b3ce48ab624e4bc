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
        os.fchmod(fd, 0o666 & ~current_umask())  # mkstemp makes 0600; a file gets the usual mode
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


def read_json(path, what: str = "results file"):
    """A file's JSON; one cut short or not JSON at all is a one-line error naming it (a report that read it
    as missing would blank its figures, which would pass for a run not yet made)."""
    from planning.errors import DomainError

    path = Path(path)
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise DomainError(
            path,
            f"corrupt {what} ({e.msg} at line {e.lineno}: cut short or edited by hand); "
            "restore it from git, or delete it and rerun the command that writes it",
        ) from None
    except UnicodeDecodeError:
        raise DomainError(
            path, f"corrupt {what} (not text); restore it from git, or delete it and rerun the command that writes it"
        ) from None
    except OSError as e:
        raise DomainError(path, f"cannot read: {e.strerror}") from None


def sha256(path) -> str | None:
    """The hex sha256 of a file's bytes (None if there is no such file): the provenance of a checkpoint."""
    path = Path(path)
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None


class OutputLock:
    """Held while a process writes an output (a results file, a run folder, a dataset): a second
    writer of the same output stops at once with a one-line error instead of interleaving with it.

        with OutputLock(out):
            ...   # play, train, write

    The lock is an advisory `flock` on a hidden `.NAME.lock` beside the output (inside it, for a
    folder); the operating system drops it when the process dies, so a killed run never leaves
    the output locked. Re-entrant within a process.
    """

    _held: dict = {}

    def __init__(self, path, what: str = "output"):
        path = Path(path)
        self.path = path
        self.what = what
        self.lock = (path / ".lock") if path.is_dir() else path.parent / f".{path.name}.lock"
        self._fd = None

    def __enter__(self) -> "OutputLock":
        import fcntl

        from planning.errors import DomainError

        key = str(self.lock.resolve())
        if key in OutputLock._held:
            OutputLock._held[key][1] += 1
            return self
        import errno

        try:
            self.lock.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.lock, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as e:
            raise DomainError(self.path, f"cannot lock this {self.what} for writing ({e.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            os.close(fd)
            if e.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise DomainError(
                    self.path,
                    f"another process is writing this {self.what}; wait for it to finish, or write to another --out",
                ) from None
            raise DomainError(
                self.path, f"cannot lock this {self.what} for writing ({e.strerror}; a file system without locks?)"
            ) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        OutputLock._held[key] = [fd, 1]
        return self

    def __exit__(self, *exc) -> None:
        key = str(self.lock.resolve())
        held = OutputLock._held.get(key)
        if held is None:
            return
        held[1] -= 1
        if held[1] == 0:
            del OutputLock._held[key]
            try:
                self.lock.unlink()
            except OSError:
                pass
            os.close(held[0])
