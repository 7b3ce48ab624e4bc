"""Task streams: how the next task is drawn, declared in domain.toml.

The [tasks] table is the i.i.d. stream (`iid`): every task drawn from P(τ), the thesis's
assumption. A domain may declare more streams under [streams.<name>], over the same task
types and with each type's arguments drawn as [tasks] draws them (P(τ) = P(type) P(args | type)):

    [streams.cook-then-clean]
    kind = "markov"                  # P(type' | type): the next type depends on the current one
    [streams.cook-then-clean.transitions]
    make-coffee = { wash = 0.6, serve-water = 0.2, make-coffee = 0.2 }
    ...                              # one row per type [tasks] draws; each row sums to 1

    [streams.lunch-rush]
    kind = "drift"                   # the type mix changes with the position in the sequence
    blend = "step"                   # step: each phase holds from its `from`; linear: blends between them
    phases = [
      { from = 0, types = { serve-water = 0.25, make-coffee = 0.3, ... } },
      { from = 25, types = { serve-water = 0.6, make-coffee = 0.2, ... } },
    ]

A Markov stream's first task after a world reset is drawn from [streams.<name>] start (a type
table; default: the chain's stationary distribution, `Stream.stationary`); a drifting stream's
position counts the tasks since the last reset (0 to tasks_per_reset - 1). A stream draws only
types that [tasks] gives a positive probability, so every stream has the support of P(τ)
(what the learner's boundary target and the search's V_AP average over).

The i.i.d. stream samples exactly as `TaskDistribution.sample`, so its tasks (and the canonical
sequences, `planning.world.sequences`) are those of the thesis protocol, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from planning.errors import DomainError

IID = "iid"
KINDS = ("markov", "drift")
BLENDS = ("step", "linear")


@dataclass
class Stream:
    """One task stream of a layout: its type distributions and how they change."""

    name: str
    kind: str  # iid, markov or drift
    model: object
    types: list  # the task types drawn (positive [tasks] probability), in [tasks] order
    type_of: np.ndarray  # (instances,) index into `types`, -1 for an instance of a type not drawn
    args_given_type: np.ndarray  # (instances,) P(args | type)
    iid_types: np.ndarray  # (types,) the [tasks] type probabilities
    transitions: np.ndarray | None = None  # markov: (types, types), row = current type
    start: np.ndarray | None = None  # markov: the first task's type distribution after a reset
    phases: list = field(default_factory=list)  # drift: [(from, (types,) probabilities)], sorted
    blend: str = "step"

    def type_probabilities(self, previous=None, position: int = 0) -> np.ndarray:
        """(types,) P(type of the next task | the previous task, its position since the reset)."""
        if self.kind == "markov":
            if previous is None:
                return self.start
            k = self.type_of[previous.index]
            if k < 0:
                raise DomainError(self.where, f"stream {self.name}: task {previous.name} is not of a type it draws")
            return self.transitions[k]
        if self.kind == "drift":
            return self._phase(position)
        return self.iid_types

    def probabilities(self, previous=None, position: int = 0) -> np.ndarray:
        """(instances,) P(next task | previous task, position): the type's probability times P(args | type)."""
        p = self.type_probabilities(previous, position)
        return np.where(self.type_of >= 0, p[np.maximum(self.type_of, 0)], 0.0) * self.args_given_type

    def sample(self, rng: np.random.Generator, previous=None, position: int = 0):
        """One task drawn given the previous one and the position (the i.i.d. stream: `TaskDistribution.sample`)."""
        if self.kind == IID:
            return self.model.tasks.sample(rng)
        cum = np.cumsum(self.probabilities(previous, position))
        i = int(np.searchsorted(cum, rng.random() * cum[-1], side="right"))
        return self.model.tasks[min(i, len(cum) - 1)]

    def stationary(self) -> np.ndarray:
        """(types,) the type distribution the stream settles to: a Markov chain's stationary distribution
        (π = π T, the eigenvector of eigenvalue 1), a drifting stream's mix averaged over the positions of
        one reset period, the i.i.d. type probabilities."""
        if self.kind == "markov":
            return stationary(self.transitions, self.where)
        if self.kind == "drift":
            n = self.model.config.get("stream", {}).get("tasks_per_reset", 50)
            return np.mean([self._phase(k) for k in range(n)], axis=0)
        return self.iid_types

    @property
    def where(self):
        return self.model.files["config"]

    def _phase(self, position: int) -> np.ndarray:
        starts = [f for f, _ in self.phases]
        k = int(np.searchsorted(starts, position, side="right")) - 1
        k = max(k, 0)
        if self.blend == "linear" and k + 1 < len(self.phases):
            (f0, p0), (f1, p1) = self.phases[k], self.phases[k + 1]
            w = (position - f0) / (f1 - f0)
            return (1 - w) * p0 + w * p1
        return self.phases[k][1]


def stationary(transitions: np.ndarray, where="transitions") -> np.ndarray:
    """The stationary distribution π = π T of a row-stochastic matrix (a one-line DomainError if it has none
    that is unique: a chain that is not irreducible)."""
    T = np.asarray(transitions, dtype=float)
    n = len(T)
    # π (T - I) = 0 with Σ π = 1: least squares on the stacked system, exact for an irreducible chain
    A = np.vstack([T.T - np.eye(n), np.ones((1, n))])
    b = np.concatenate([np.zeros(n), [1.0]])
    pi, *_ = np.linalg.lstsq(A, b, rcond=None)
    if np.abs(A @ pi - b).max() > 1e-8 or (pi < -1e-12).any() or np.linalg.matrix_rank(T.T - np.eye(n)) != n - 1:
        raise DomainError(
            where, "the transition table has no unique stationary distribution (is every type reachable?)"
        )
    pi = np.clip(pi, 0.0, None)
    return pi / pi.sum()


def _type_table(value, types: list, where, what: str) -> np.ndarray:
    """A {type: probability} table as a (types,) vector that sums to 1 (a one-line DomainError otherwise)."""
    if not isinstance(value, dict) or not value:
        raise DomainError(where, f"{what} is {value!r}, not a table of task type = probability")
    out = np.zeros(len(types))
    for name, p in value.items():
        if name not in types:
            raise DomainError(where, f"{what}: '{name}' is not a task type [tasks] draws ({', '.join(types)})")
        if isinstance(p, bool) or not isinstance(p, (int, float)) or p < 0:
            raise DomainError(where, f"{what}: {name} = {p!r} is not a probability")
        out[types.index(name)] = float(p)
    if abs(out.sum() - 1.0) > 1e-9:
        raise DomainError(where, f"{what} sums to {out.sum():g}, not 1")
    return out


def streams(model) -> dict:
    """{name: Stream} of the layout: `iid` and every [streams.<name>] of domain.toml, checked."""
    where = model.files["config"]
    tasks = list(model.tasks)
    order = list(dict.fromkeys(t.type for t in tasks))
    p_type = {ty: sum(t.probability for t in tasks if t.type == ty) for ty in order}
    types = [ty for ty in order if p_type[ty] > 0]
    type_of = np.array([types.index(t.type) if t.type in types else -1 for t in tasks], dtype=np.int64)
    args = np.array([t.probability / p_type[t.type] if p_type[t.type] > 0 else 0.0 for t in tasks])
    iid_types = np.array([p_type[ty] for ty in types]) / sum(p_type[ty] for ty in types)
    base = dict(model=model, types=types, type_of=type_of, args_given_type=args, iid_types=iid_types)
    out = {IID: Stream(IID, IID, **base)}
    table = model.config.get("streams", {})
    if not isinstance(table, dict):
        raise DomainError(where, f"streams is {table!r}, not a table of [streams.<name>] tables")
    for name, entry in table.items():
        what = f"[streams.{name}]"
        if name == IID:
            raise DomainError(where, f"{what}: '{IID}' is the [tasks] stream's name; choose another")
        if not isinstance(entry, dict) or entry.get("kind") not in KINDS:
            kind = entry.get("kind") if isinstance(entry, dict) else entry
            raise DomainError(where, f"{what} kind is {kind!r}, not one of {', '.join(KINDS)}")
        allowed = {"markov": {"kind", "transitions", "start"}, "drift": {"kind", "phases", "blend"}}[entry["kind"]]
        extra = sorted(set(entry) - allowed)
        if extra:
            raise DomainError(where, f"{what}: unknown key(s) {', '.join(extra)} for a {entry['kind']} stream")
        if entry["kind"] == "markov":
            rows = entry.get("transitions")
            if not isinstance(rows, dict) or set(rows) != set(types):
                have = sorted(rows) if isinstance(rows, dict) else rows
                raise DomainError(
                    where, f"{what} transitions needs one row per type [tasks] draws ({', '.join(types)}), has {have}"
                )
            T = np.stack([_type_table(rows[ty], types, where, f"{what} transitions.{ty}") for ty in types])
            start = entry.get("start")
            s = stationary(T, where) if start is None else _type_table(start, types, where, f"{what} start")
            out[name] = Stream(name, "markov", transitions=T, start=s, **base)
        else:
            phases = entry.get("phases")
            if not isinstance(phases, list) or not phases:
                raise DomainError(where, f"{what} phases is {phases!r}, not a list of {{ from = N, types = {{...}} }}")
            parsed = []
            for k, ph in enumerate(phases):
                if not isinstance(ph, dict) or set(ph) != {"from", "types"}:
                    raise DomainError(where, f"{what} phase {k + 1} is {ph!r}, not {{ from = N, types = {{...}} }}")
                f = ph["from"]
                if isinstance(f, bool) or not isinstance(f, int) or f < 0 or (parsed and f <= parsed[-1][0]):
                    raise DomainError(
                        where, f"{what} phase {k + 1}: from = {f!r} is not a position after the last phase's"
                    )
                parsed.append((f, _type_table(ph["types"], types, where, f"{what} phase {k + 1} types")))
            if parsed[0][0] != 0:
                raise DomainError(where, f"{what}: the first phase must start at from = 0")
            blend = entry.get("blend", "step")
            if blend not in BLENDS:
                raise DomainError(where, f"{what} blend is {blend!r}, not one of {', '.join(BLENDS)}")
            out[name] = Stream(name, "drift", phases=parsed, blend=blend, **base)
    return out


def stream(model, name: str | None) -> Stream:
    """The layout's stream of that name (None: the i.i.d. one); a one-line DomainError naming the known ones."""
    known = streams(model)
    name = name or IID
    if name not in known:
        raise DomainError("--stream", f"'{name}' is not a stream of {model.name} ({', '.join(known)})")
    return known[name]
