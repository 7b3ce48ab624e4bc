"""The user's cache folder: compiled kernels and arrays that are costly to compute and cheap to load.

`$XDG_CACHE_HOME/anticipatory-planning`, else `~/.cache/anticipatory-planning`.
Every entry is named by a digest of everything it is computed from, so an entry
is never stale: a changed domain, source or parameter names another file, and
deleting the folder only costs the time to compute its entries again.

`arrays` keeps named numpy arrays (`.npz`, loaded with `allow_pickle=False`:
loading never runs code from the file). An entry that cannot be read is
computed again and rewritten; where the folder cannot be written, the arrays
are computed and returned all the same. Writes are atomic (a temporary file
renamed into place), so processes filling the cache at once never read half a
file.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np


def folder() -> Path:
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "anticipatory-planning"


def digest(*parts) -> str:
    """A hex digest of numpy arrays (their dtype, shape and bytes) and other values (their repr)."""
    h = hashlib.sha256()
    for p in parts:
        if isinstance(p, np.ndarray):
            p = np.ascontiguousarray(p)
            h.update(f"{p.dtype.str}{p.shape}".encode())
            h.update(p.tobytes())
        else:
            h.update(repr(p).encode())
        h.update(b"\0")
    return h.hexdigest()[:24]


def arrays(
    kind: str, key: str, compute: Callable[[], dict], switch: str, keep: tuple | None = None, max_bytes: int = 1 << 28
) -> dict[str, np.ndarray]:
    """`compute()`'s named arrays, kept in `<folder>/<kind>/<key>.npz` and loaded from there next time: all
    of them, or the names in `keep` (a computed result returns every array, a loaded one those kept).
    `switch`=0 in the environment turns the cache off; entries over `max_bytes` are not kept."""
    if os.environ.get(switch, "1") == "0":
        return compute()
    path = folder() / kind / f"{key}.npz"
    try:
        with np.load(path, allow_pickle=False) as f:
            return {name: f[name] for name in f.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile):
        pass  # missing, or unreadable (cut short, not ours): computed and written
    out = compute()
    kept = {name: a for name, a in out.items() if keep is None or name in keep}
    if sum(a.nbytes for a in kept.values()) <= max_bytes:
        tmp = path.with_name(f"{path.stem}.{os.getpid()}.tmp.npz")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            np.savez(tmp, **kept)
            os.replace(tmp, path)
        except OSError:  # not writable here: the arrays all the same
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)
    return out
