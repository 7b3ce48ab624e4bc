"""The value registry: every kind of value a command can take, as a lazy (module, class, description) row.

A value is named on the command line as KIND:PATH (`--value gnn:checkpoints/gnn-faithful-three-room-seed0.pt`),
or as KIND alone for the kinds that read no file (`--value zero`, `--value exact`); what follows the colon is
the kind's argument (a checkpoint path, or `exact`'s horizon). A bare PATH is a checkpoint of the caller's
default kind (`load_value`'s `default`), or, where the caller has none, of the kind its file says (a GNN's
or a Q-network's).

A value class implements the value protocol of `planning.value` (what the search calls) and the hooks the
commands use:

    load(arg, model) -> value       classmethod: the value for the compiled model (arg: the text after
                                    "KIND:", None where there is none); a bad argument is a DomainError
    record(arg) -> dict             optional: what a results file's config records of it (default:
                                    {"value": "KIND[:ARG]"}); read without loading the value

A new value is one module and one row here. Beside the registry: `learning.values.exact` (the exact value
by value iteration) and `learning.values.rank` (how well a value ranks states by preparedness).
"""

from __future__ import annotations

import importlib

from planning.errors import DomainError

VALUES = {
    "q-network": (
        "learning.q.value",
        "ValueFunction",
        "a learning.dqn checkpoint: q_max = max_a Q(s, τ, a), V_AP = Σ_τ P(τ) max_a Q(s, τ, a)",
    ),
    "gnn": (
        "learning.gnn.value",
        "GNNValue",
        "a learning.gnn_train checkpoint: V_AP = q_max = -Ĉ_AP / cost_scale, the one-task cost estimate",
    ),
    "exact": (
        "learning.values.exact",
        "ExactValue",
        "Q* by value iteration over every reachable state (small domains); exact:myopic for that horizon",
    ),
    "zero": ("planning.value", "ZeroValue", "0 everywhere: every terminal ties, so the search plays the cheapest"),
}

HELP = f"a value, KIND:PATH or KIND ({', '.join(VALUES)}; learning.values)"


def value_class(kind: str):
    """The class registered under `kind` (imported on first use)."""
    if kind not in VALUES:
        raise DomainError("--value", f"unknown value kind '{kind}' (known: {', '.join(VALUES)})")
    module, cls, _ = VALUES[kind]
    return getattr(importlib.import_module(module), cls)


def parse(spec: str, default: str | None = None) -> tuple[str, str | None]:
    """(kind, argument) of a value's name: KIND:ARG, KIND, or a bare checkpoint PATH (see the module)."""
    spec = str(spec)
    kind, colon, arg = spec.partition(":")
    if colon and kind in VALUES:
        return kind, arg or None
    if spec in VALUES:
        return spec, None
    if not spec:
        raise DomainError("--value", "names no value")
    if default is None:
        from learning.gnn.model import is_gnn_checkpoint

        default = "gnn" if is_gnn_checkpoint(spec) else "q-network"
    if default not in VALUES:
        raise DomainError("--value", f"unknown value kind '{default}' (known: {', '.join(VALUES)})")
    return default, spec


def load_value(spec: str, model, default: str | None = None):
    """The value `spec` names (KIND:PATH, KIND or PATH), built for the compiled model."""
    kind, arg = parse(spec, default)
    return value_class(kind).load(arg, model)


def record(spec: str, default: str | None = None) -> dict:
    """What a results file's config records of the value `spec` names (its kind's `record`), unloaded."""
    kind, arg = parse(spec, default)
    hook = getattr(value_class(kind), "record", None)
    return hook(arg) if hook is not None else {"value": kind if arg is None else f"{kind}:{arg}"}


def describe() -> str:
    """One line per registered kind: its name and description."""
    return "\n".join(f"{kind:10s} {row[2]}" for kind, row in VALUES.items())
