"""The task distribution: task types from tasks.pddl, their arguments and probabilities from domain.toml.

A task schema's precondition is the goal, its effect the consumption. Parameters
named under [tasks.<type>].arguments are the task's arguments; the others are
existential. A task is satisfied when some binding of them holds, and on
completion the consumption of the first such binding (object order) is applied.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np

from planning.errors import DomainError


@dataclass(frozen=True)
class TaskSpec:
    type: str
    args: tuple  # argument objects, in parameter order
    params: tuple  # the argument parameter names, e.g. ("?l",)
    probability: float

    @property
    def name(self) -> str:
        return f"{self.type}({', '.join(self.args)})"


@dataclass(frozen=True, eq=False)
class Task:
    """One task instance: its goal (DNF of bit masks) and its consumption."""

    index: int
    type: str
    args: tuple
    params: tuple
    probability: float
    bindings: tuple  # Op per existential binding, in object order: goal conj + consumption
    axioms: object = None  # the model's derived-predicate axioms, recomputed after the consumption

    @property
    def name(self) -> str:
        return f"{self.type}({', '.join(self.args)})"

    def satisfied(self, state: int) -> bool:
        """True if the goal holds in the state."""
        return any(state & o.pos == o.pos and not state & o.neg for o in self.bindings)

    def consume(self, state: int) -> int:
        """The state after completion: the first satisfied binding's consumption applied."""
        for o in self.bindings:
            if state & o.pos == o.pos and not state & o.neg:
                return o.apply(state) if self.axioms is None else self.axioms(o.apply(state))
        raise ValueError(f"task {self.name} is not satisfied, nothing to consume")

    def __repr__(self) -> str:
        return f"Task({self.name}, p={self.probability:.4g})"


class TaskDistribution:
    """The task instances of a layout with their probabilities; seeded i.i.d. sampling."""

    def __init__(self, tasks: list[Task], where):
        self.tasks = tasks
        self.probabilities = np.array([t.probability for t in tasks])
        self._by_name = {t.name: t for t in tasks}
        self._cumulative = np.cumsum(self.probabilities)
        self.where = where

    def __len__(self) -> int:
        return len(self.tasks)

    def __iter__(self):
        return iter(self.tasks)

    def __getitem__(self, i: int) -> Task:
        return self.tasks[i]

    def get(self, name: str) -> Task:
        """A task by its printed name, e.g. 'serve-water(servingtable)'."""
        key = name.replace(" ", "").replace(",", ", ")
        if key not in self._by_name:
            raise DomainError(self.where, f"unknown task '{name}'")
        return self._by_name[key]

    def sample(self, rng: np.random.Generator) -> Task:
        """One task drawn from P."""
        i = int(np.searchsorted(self._cumulative, rng.random() * self._cumulative[-1], side="right"))
        return self.tasks[min(i, len(self.tasks) - 1)]


def compile_tasks(src, grounder) -> list:
    """[(TaskSpec, [GroundVariant])] for every instance of every task type."""
    where = src.folder / "domain.toml"
    table = src.config.get("tasks", {})
    if not isinstance(table, dict):
        raise DomainError(where, f"tasks is {table!r}, not a table of [tasks.<type>] tables")
    for name in src.task_schemas:
        if name not in table:
            raise DomainError(src.tasks_file, f"task type '{name}' has no [tasks.{name}] in domain.toml")
    for ttype, entry in table.items():
        check_entry(ttype, entry, where)
    total = sum(float(t["probability"]) for t in table.values())
    if abs(total - 1.0) > 1e-9:
        raise DomainError(where, f"task type probabilities sum to {total:g}, not 1")
    out = []
    for ttype, entry in table.items():
        if ttype not in src.task_schemas:
            raise DomainError(where, f"task '{ttype}' has no schema in {src.tasks_file.name}")
        schema = src.task_schemas[ttype]
        sorts = {p.symbol: p.sort.name for p in schema.parameters}
        arguments = entry.get("arguments", {})
        for pname in arguments:
            if pname not in sorts:
                raise DomainError(where, f"task {ttype}: '{pname}' is not a parameter of its schema")
        params = tuple(p.symbol for p in schema.parameters if p.symbol in arguments)
        domains = [_argument_domain(ttype, p, arguments[p], sorts[p], grounder, where) for p in params]
        p_type = float(entry["probability"])
        for combo in product(*domains):
            args = tuple(o for o, _ in combo)
            prob = p_type * float(np.prod([q for _, q in combo]))
            spec = TaskSpec(ttype, args, params, prob)
            variants = grounder.ground_schema(schema, dict(zip(params, args)))
            out.append((spec, variants))
    return out


TASK_KEYS = ("probability", "arguments")
"""The keys of a [tasks.<type>] table."""


def check_entry(ttype: str, entry, where) -> None:
    """A one-line error unless [tasks.<type>] is a table of known keys, each of its type: a probability
    (a number in [0, 1]) and arguments (a table: parameter -> a list of objects, a table of object
    probabilities, or "all"); checked before any of it is used, so a typo is never a traceback."""
    if not isinstance(entry, dict):
        raise DomainError(where, f"[tasks.{ttype}] is {entry!r}, not a table")
    unknown = [k for k in entry if k not in TASK_KEYS]
    if unknown:
        raise DomainError(
            where, f"task {ttype}: unknown key '{unknown[0]}' (a [tasks.<type>] table has {' and '.join(TASK_KEYS)})"
        )
    if "probability" not in entry:
        raise DomainError(where, f"task {ttype}: no probability")
    probability(entry["probability"], where, f"task {ttype}: probability")
    arguments = entry.get("arguments", {})
    if not isinstance(arguments, dict):
        raise DomainError(
            where, f'task {ttype}: arguments is {arguments!r}, not a table like {{ "?l" = ["servingtable"] }}'
        )
    for pname, value in arguments.items():
        if isinstance(value, list):
            bad = [o for o in value if not isinstance(o, str)]
            if bad:
                raise DomainError(where, f"task {ttype}: {pname} lists {bad[0]!r}, not an object name")
        if isinstance(value, (list, dict)) and not value:
            raise DomainError(where, f"task {ttype}: {pname} names no object")


def _argument_domain(ttype, pname, value, sort, grounder, where) -> list[tuple[str, float]]:
    allowed = grounder.objects_of(sort)
    if value == "all":
        objs = list(allowed)
        if not objs:
            raise DomainError(where, f"task {ttype}: no objects of type {sort} for {pname}")
        return [(o, 1.0 / len(objs)) for o in objs]
    if isinstance(value, list):
        pairs = [(o, 1.0 / len(value)) for o in value]
    elif isinstance(value, dict):
        pairs = [(o, probability(q, where, f"task {ttype}: probability of {o} for {pname}")) for o, q in value.items()]
        if abs(sum(q for _, q in pairs) - 1.0) > 1e-9:
            raise DomainError(where, f"task {ttype}: probabilities of {pname} do not sum to 1")
    else:
        raise DomainError(where, f'task {ttype}: {pname} must be a list, a table or "all"')
    for o, _ in pairs:
        if o not in grounder.objects:
            raise DomainError(where, f"task {ttype}: unknown object '{o}' for {pname}")
        if o not in allowed:
            raise DomainError(where, f"task {ttype}: object '{o}' is not of type {sort} for {pname}")
    return pairs


def probability(value, where, what: str) -> float:
    """A probability from domain.toml: a number in [0, 1]; anything else is a one-line error."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DomainError(where, f"{what} is {value!r}, not a number")
    if not 0.0 <= value <= 1.0:
        raise DomainError(where, f"{what} is {value:g}, not between 0 and 1")
    return float(value)
