"""Build and load a small C kernel with the system C compiler, once per source version and machine.

Used by every kernel (LM-cut, the Bellman-Novelty expansion, the Q-network): the
source is compiled on first use into the user's cache folder
(planning.cache: `$XDG_CACHE_HOME/anticipatory-planning`, else `~/.cache/...`), named by a
digest of the source, the flags and the CPU, and loaded with ctypes. Where no
compiler works (or `<NAME>_NATIVE=0`) `load` returns None and the caller runs
its pure-Python version, which computes the same thing.

Floating point: kernels are built with `-ffp-contract=off` and without
`-ffast-math`, so each `a * b + c` is rounded twice as in Python and numpy,
and no sum is reordered: the results are the same with or without
`-march=native` (tried first; dropped where the compiler refuses it).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import subprocess
from pathlib import Path

from planning import cache

BASE_FLAGS = ["-O3", "-ffp-contract=off", "-fno-fast-math", "-shared", "-fPIC"]
_LOADED: dict = {}


def _cpu() -> str:
    """What the compiled code depends on: the machine and its instruction set extensions."""
    flags = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(("flags", "Features")):
                flags = line
                break
    except OSError:
        pass
    return f"{platform.machine()} {flags}"


def load(source: Path, switch: str) -> ctypes.CDLL | None:
    """The compiled `source` (a .c file), or None where `switch`=0 is set in the environment or no compiler works."""
    if os.environ.get(switch, "1") == "0":
        return None
    key = (str(source), switch)
    if key not in _LOADED:
        _LOADED[key] = _build(Path(source)) or False
    return _LOADED[key] or None


def _build(src: Path) -> ctypes.CDLL | None:
    try:
        code = src.read_bytes()
    except OSError:
        return None
    cc = os.environ.get("CC", "cc")
    for extra in (["-march=native"], []):
        flags = BASE_FLAGS + extra
        digest = hashlib.sha1(code + " ".join([cc] + flags).encode() + _cpu().encode()).hexdigest()[:12]
        lib = cache.folder() / f"{src.stem.lstrip('_')}-{digest}.so"
        try:
            if not lib.is_file():
                lib.parent.mkdir(parents=True, exist_ok=True)
                tmp = lib.with_name(f"{lib.name}.{os.getpid()}.tmp")
                subprocess.run(
                    [cc, *flags, "-o", str(tmp), str(src), "-lm"], check=True, capture_output=True, timeout=120
                )
                os.replace(tmp, lib)  # atomic: processes building at once never load half a file
            return ctypes.CDLL(str(lib))
        except (OSError, subprocess.SubprocessError):
            continue
    return None
