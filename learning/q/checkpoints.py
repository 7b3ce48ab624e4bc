"""Q-network checkpoints: written atomically in plain types, read with weights_only=True, checked against
the domain and layout they are used on.
"""

from __future__ import annotations

import io
from pathlib import Path

import torch

from learning.encoding import Encoding
from learning.plain import from_plain, full_precision, load_plain, to_plain
from planning.atomic import write_bytes
from planning.errors import DomainError

from .network import FactoredQNet

DOMAIN_KEYS = ("domain", "domain_sha256", "domain_files")
"""What a checkpoint records of the domain it was trained on (`planning.domain.identity`)."""
_warned: set = set()


def save_checkpoint(path, payload: dict) -> Path:
    """Write a torch checkpoint atomically (a temporary file beside it, then os.replace), in plain
    types only (`learning.plain`): it loads with weights_only=True."""
    buf = io.BytesIO()
    torch.save(to_plain(payload), buf)
    return write_bytes(path, buf.getvalue())


def read_checkpoint(path) -> dict:
    """A checkpoint's payload, loaded with weights_only=True (nothing in the file runs); a missing,
    corrupt, foreign or hostile file is a one-line DomainError naming it."""
    path = Path(path)
    payload = load_plain(path, "checkpoint")
    if not isinstance(payload, dict) or "net" not in payload or "dims" not in payload:
        raise DomainError(path, "not a Q-network checkpoint (no 'net' or 'dims')")
    return full_precision(from_plain(payload), "net")


def checkpoint_config(path) -> dict:
    """What a results file records of a Q-network checkpoint: its path, step, evaluation and training settings."""
    payload = read_checkpoint(path)
    cfg = payload.get("config", {})
    return {
        "checkpoint": str(path),
        **{k: payload[k] for k in ("step", "eval") if k in payload},
        **{k: cfg[k] for k in ("horizon", "seed", "gamma", "goal_reward") if k in cfg},
    }


def network_payload(net: FactoredQNet, enc: Encoding, extra: dict | None = None) -> dict:
    """The minimal checkpoint of a network: weights, sizes, the layout signature and the domain it was
    trained on (its PDDL name and the digest of its files, `planning.domain.identity`)."""
    from planning.domain.identity import identity

    return {
        "net": net.state_dict(),
        "dims": net.dims,
        "signature": enc.signature(),
        **identity(enc.model),
        **(extra or {}),
    }


def check_domain(path, payload: dict, model) -> None:
    """A checkpoint about to be used on `model`'s layout: one recorded for another domain (its PDDL name)
    or another layout is a one-line DomainError; one trained on other content of this domain (its
    recorded domain_sha256 differs: an edited cost, a retuned reward) is a one-line warning on stderr,
    once per file, and stays usable. A checkpoint that records no domain (the format's first version, the committed ones among them)
    is checked by its layout signature alone."""
    import sys

    from planning.domain.identity import mismatch

    sig = payload.get("signature") or {}
    name = payload.get("domain") or sig.get("domain")
    layout = (payload.get("config") or {}).get("layout") or sig.get("layout")
    if (name or model.name, layout or model.layout) != (model.name, model.layout):
        raise DomainError(path, f"trained for {name}/{layout}, not {model.name}/{model.layout}")
    diff = mismatch(payload, model) if payload.get("domain_sha256") is not None else None
    key = (str(Path(path).resolve()) if isinstance(path, (str, Path)) else str(path), payload.get("domain_sha256"))
    if diff is not None and key not in _warned:
        _warned.add(key)
        print(f"warning: {path}: trained on {diff}; used as it is", file=sys.stderr)
