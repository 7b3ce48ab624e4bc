"""Factored actions for learning (thesis §4.1.1, Table A.1): an action type plus argument heads.

Derived from the action schemas. domain.toml's [heads] names, per schema, the
parameters that are heads (default: all); the others follow from the state.
Each head parameter belongs to the family of its root type (the type just below
`object`: thing, location, ...). A family gets as many slots as the most head
parameters of that type in one schema; slots are ordered slot by slot, families
with more slots first. For the restaurant this gives Table A.1's
(type, object1, location, object2). Every head has a *none* value, used where a
type does not take that argument.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planning.errors import DomainError

NONE = "none"


@dataclass
class FactoredActions:
    heads: list  # head names, "type" first
    vocab: list  # per head, its values; the last one is NONE (except for "type")
    labels: np.ndarray  # (ground actions, heads) value index per head

    def label(self, action: int) -> tuple:
        """The readable factored label of a ground action, e.g. ('pick', 'cup_0', 'none', 'none')."""
        return tuple(self.vocab[h][i] for h, i in enumerate(self.labels[action]))

    def applicable_labels(self, model, state: int) -> dict:
        """{label index tuple: ground action} for the actions applicable in a state."""
        out = {}
        for a in model.applicable(state):
            key = tuple(self.labels[a].tolist())
            if key in out:
                raise DomainError(
                    model.actions[a],
                    f"shares its factored label with {model.actions[out[key]]}: "
                    "add the distinguishing parameter to [heads] in domain.toml",
                )
            out[key] = a
        return out


def _root(model, sort_name: str) -> str:
    lang = model.source.problem.language
    sort = lang.get_sort(sort_name)
    parents = lang.immediate_parent
    while parents.get(sort) is not None and parents[sort].name != "object":
        sort = parents[sort]
    return sort.name


def factored_actions(model) -> FactoredActions:
    """The factored action space of a compiled model."""
    where = model.files["config"]
    table = model.config.get("heads", {})
    schemas = list(model.schema_params)
    for name in table:
        if name not in model.schema_params:
            raise DomainError(where, f"[heads] names unknown action '{name}'")
    head_params = {}
    for name in schemas:
        params = dict(model.schema_params[name])
        chosen = table.get(name, list(params))
        for p in chosen:
            if p not in params:
                raise DomainError(where, f"[heads] {name}: '{p}' is not a parameter")
        head_params[name] = [(p, _root(model, params[p])) for p in chosen]

    slots: dict[str, int] = {}
    for params in head_params.values():
        count: dict[str, int] = {}
        for _, fam in params:
            count[fam] = count.get(fam, 0) + 1
        for fam, k in count.items():
            slots[fam] = max(slots.get(fam, 0), k)
    families = sorted(slots, key=lambda f: -slots[f])  # stable: first seen wins ties
    order = [(fam, k) for k in range(max(slots.values(), default=0)) for fam in families if k < slots[fam]]
    heads = ["type"] + [fam if slots[fam] == 1 else f"{fam}{k + 1}" for fam, k in order]
    vocab = [schemas] + [model.objects_of(fam) + [NONE] for fam, _ in order]
    column = {slot: 1 + i for i, slot in enumerate(order)}

    labels = np.zeros((model.n_actions, len(heads)), dtype=np.int64)
    for h in range(1, len(heads)):
        labels[:, h] = len(vocab[h]) - 1
    for a in range(model.n_actions):
        schema = model.action_schema[a]
        labels[a, 0] = schemas.index(schema)
        names = [p for p, _ in model.schema_params[schema]]
        seen: dict[str, int] = {}
        for p, fam in head_params[schema]:
            k = seen.get(fam, 0)
            seen[fam] = k + 1
            h = column[(fam, k)]
            labels[a, h] = vocab[h].index(model.action_args[a][names.index(p)])
    return FactoredActions(heads, vocab, labels)
