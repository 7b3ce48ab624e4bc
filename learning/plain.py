"""Files that load without running code from them: torch.load with weights_only=True, never a bare pickle.

A checkpoint, dataset or cache holds only tensors, numbers, strings, booleans,
None, lists, tuples and dicts. `to_plain` puts what the trainer keeps in numpy
(the replay memory, random generator states) into those types before saving;
`from_plain` restores it after loading. `load_plain` refuses a file that would
build any other Python object (a hostile pickle whose `__reduce__` runs a
command, a checkpoint of another program) with a one-line DomainError naming
the file; nothing of it runs.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import torch

from planning.errors import DomainError

PLAIN = "tensors, numbers, strings, lists and dicts"
_ARRAY = "__ndarray__"


def to_plain(obj):
    """obj with numpy arrays and scalars put into plain types (an array: a uint8 tensor of its bytes,
    its dtype and shape); anything else not plain is a TypeError, so no unloadable file is written."""
    if isinstance(obj, torch.Tensor):  # a view into a larger buffer is saved alone, not with the buffer
        obj = obj.cpu()  # a checkpoint of a run on a GPU loads where there is none
        return obj.clone() if obj.untyped_storage().nbytes() > obj.nbytes else obj
    if obj is None or isinstance(obj, (bool, int, float, str, bytes)):
        return obj
    if isinstance(obj, np.ndarray):
        if obj.dtype.hasobject:
            raise TypeError("a numpy array of Python objects is not plain data")
        raw = np.ascontiguousarray(obj)
        data = (
            torch.from_numpy(raw.reshape(-1).view(np.uint8).copy()) if raw.size else torch.zeros(0, dtype=torch.uint8)
        )
        return {_ARRAY: data, "dtype": raw.dtype.str, "shape": list(raw.shape)}
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, dict):
        out = type(obj)() if type(obj) is not dict and _is_allowed_dict(obj) else {}
        for k, v in obj.items():
            out[to_plain(k)] = to_plain(v)
        _keep_metadata(obj, out)
        return out
    if isinstance(obj, tuple):
        return tuple(to_plain(v) for v in obj)
    if isinstance(obj, list):
        return [to_plain(v) for v in obj]
    raise TypeError(f"{type(obj).__name__} is not plain data ({PLAIN})")


def _is_allowed_dict(obj) -> bool:
    from collections import OrderedDict

    return isinstance(obj, OrderedDict)


def _keep_metadata(old, new) -> None:
    """A module state_dict's version metadata (an attribute of its OrderedDict) goes along."""
    meta = getattr(old, "_metadata", None)
    if meta is not None and type(new) is not dict:
        new._metadata = meta


def from_plain(obj):
    """The inverse of `to_plain`: numpy arrays back from their byte tensors."""
    if isinstance(obj, dict):
        if _ARRAY in obj and set(obj) == {_ARRAY, "dtype", "shape"}:
            data = obj[_ARRAY].numpy().tobytes()
            return np.frombuffer(data, dtype=np.dtype(obj["dtype"])).reshape(obj["shape"]).copy()
        out = type(obj)()
        for k, v in obj.items():
            out[k] = from_plain(v)
        _keep_metadata(obj, out)
        return out
    if isinstance(obj, list):
        return [from_plain(v) for v in obj]
    if isinstance(obj, tuple):
        return tuple(from_plain(v) for v in obj)
    return obj


def refusal(e: Exception, what: str, head: bytes = b"") -> str:
    """One line saying why torch.load(weights_only=True) refused a file (`head`: its first bytes)."""
    text = str(e)
    found = re.search(r"Unsupported global: GLOBAL ([\w.]+)", text)
    if found:
        return (
            f"refused as a {what}: it would build Python objects ({found.group(1)}) on loading, "
            f"not only {PLAIN}; nothing of it was run"
        )
    unpickler = re.search(r"WeightsUnpickler error:\s*([^\n]*)", text)
    if unpickler and head[:1] == b"\x80":  # a pickle's protocol mark: a bare pickle, not a torch file
        return (
            f"refused as a {what}: a bare pickle the safe loader cannot read "
            f"({unpickler.group(1).strip()}); nothing of it was run"
        )
    first = (unpickler.group(1) if unpickler else text).strip()
    first = first.splitlines()[0].split(". ")[0][:100] if first else ""
    kind = "cut short or not a torch file: " if isinstance(e, (OSError, RuntimeError, EOFError)) else ""
    return f"not a readable {what} ({kind}{type(e).__name__}{': ' + first if first else ''})"


def load_plain(path, what: str = "checkpoint"):
    """torch.load(path, weights_only=True) on the CPU; a missing, corrupt or hostile file is a
    one-line DomainError naming it (nothing of a hostile file runs)."""
    path = Path(path)
    if not path.is_file():
        raise DomainError(path, f"no such {what}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # torch's note on a pickle protocol it does not expect
            return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # torch raises many types for a truncated, foreign or hostile file
        with open(path, "rb") as f:
            head = f.read(2)
        raise DomainError(path, refusal(e, what, head)) from None


def to_half(state: dict) -> dict:
    """A state_dict with its floating-point tensors in float16 (a compact checkpoint's weights)."""
    return type(state)((k, v.to(torch.float16) if v.is_floating_point() else v) for k, v in state.items())


def from_half(state: dict) -> dict:
    """A compact state_dict back in float32, the precision the networks compute in."""
    return type(state)((k, v.float() if v.is_floating_point() else v) for k, v in state.items())


def full_precision(payload: dict, key: str) -> dict:
    """The checkpoint payload with its weights `payload[key]` in float32: a compact checkpoint
    (learning.export, precision "float16") is cast back; any other is returned as it is."""
    if payload.get("precision") == "float16":
        payload[key] = from_half(payload[key])
    return payload
