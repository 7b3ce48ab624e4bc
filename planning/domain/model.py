"""The compiled grounded model: atoms as bits of a Python int, actions as bit masks.

A state is an int whose bit i says whether atom i holds: hashable, compact and
copied for free. Applying an action is two mask operations (delete, then add;
adds win, as in PDDL), plus its conditional effects evaluated in the old state.
In a domain with derived predicates their atoms are bits too, recomputed by the
layout's axioms (planning.domain.axioms) after every step, consumption and reset.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

from planning.domain.grounding import atom_text, parse_atom_text
from planning.domain.tasks import Task, TaskDistribution
from planning.errors import DomainError


class Op(NamedTuple):
    """A conjunctive precondition with its effects, as bit masks."""

    pos: int
    neg: int
    add: int
    dele: int
    cond: tuple = ()  # ((pos, neg, add, dele), ...) evaluated in the state before

    def applicable(self, state: int) -> bool:
        return state & self.pos == self.pos and not state & self.neg

    def apply(self, state: int) -> int:
        add, dele = self.add, self.dele
        for cp, cn, ca, cd in self.cond:
            if state & cp == cp and not state & cn:
                add |= ca
                dele |= cd
        return (state & ~dele) | add


@dataclass(eq=False)
class Model:
    """One layout of a domain, grounded: atoms, ground actions, costs, tasks."""

    name: str
    layout: str
    folder: Path
    config: dict
    atoms: list  # AtomKey per bit
    actions: list  # ground action names, e.g. "move(countertop, fountain)"
    action_schema: list
    action_args: list
    action_cost: list  # int PDDL cost per ground action
    ops: list  # Op per variant (a disjunctive precondition gives several)
    op_action: list  # ground action of each variant
    init: int
    objects: list  # object names in declaration order
    objects_of: Callable  # type name -> objects of that type
    schema_params: dict  # schema -> [(param, type)]
    resets: list  # [([choice masks], [probabilities])]
    files: dict
    tasks: TaskDistribution = None
    source: object = None  # the parsed DomainSource (tarski schemas and problem)
    static_atoms: frozenset = frozenset()
    axioms: object = None  # planning.domain.axioms.Axioms where the domain has derived predicates
    atom_index: dict = field(init=False)
    action_index: dict = field(init=False)

    def __post_init__(self):
        self.atom_index = {a: i for i, a in enumerate(self.atoms)}
        self.action_index = {a: i for i, a in enumerate(self.actions)}
        self.full_mask = (1 << len(self.atoms)) - 1
        self._build_successor_index()

    def attach_tasks(self, compiled: list) -> None:
        tasks = []
        for spec, ops in compiled:
            if not ops:
                raise DomainError(
                    self.files["tasks"], f"task {spec.name} can never be satisfied in layout {self.layout}"
                )
            tasks.append(Task(len(tasks), spec.type, spec.args, spec.params, spec.probability, tuple(ops), self.axioms))
        self.tasks = TaskDistribution(tasks, self.files["config"])

    # ---- sizes and names -------------------------------------------------
    @property
    def cost_scale(self) -> float:
        """PDDL cost units per RL reward unit (domain.toml [reward] cost_scale, default 1)."""
        return float(self.config.get("reward", {}).get("cost_scale", 1))

    @property
    def derived_mask(self) -> int:
        """The bits of the derived atoms (0 in a domain without derived predicates)."""
        return 0 if self.axioms is None else self.axioms.mask

    def derive(self, state: int) -> int:
        """The state with its derived atoms recomputed from the others (the state itself where there are none)."""
        return state if self.axioms is None else self.axioms(state)

    @property
    def n_atoms(self) -> int:
        return len(self.atoms)

    @property
    def n_actions(self) -> int:
        return len(self.actions)

    @property
    def locations(self) -> list[str]:
        """The layout's locations: the objects its rooms list in domain.toml ([] if none)."""
        rooms = self.config.get("layouts", {}).get(self.layout, {}).get("rooms", {})
        return [o for r in rooms.values() for o in r]

    def state_from_atoms(self, atoms) -> int:
        """A state from atom texts '(at cup_0 shelf)' or keys; unknown atoms are an error.
        Derived atoms are recomputed from the others (any listed are ignored)."""
        s = 0
        for a in atoms:
            try:
                key = parse_atom_text(a) if isinstance(a, str) else tuple(a)
            except ValueError as e:
                raise DomainError(self.files["problem"], str(e)) from None
            if key not in self.atom_index:
                raise DomainError(
                    self.files["problem"], f"{atom_text(key)} is not a reachable fluent atom of this layout"
                )
            s |= 1 << self.atom_index[key]
        return self.derive(s)

    def true_atoms(self, state: int) -> list:
        """The atom keys that hold in a state, in atom order."""
        out, i = [], 0
        while state:
            if state & 1:
                out.append(self.atoms[i])
            state >>= 1
            i += 1
        return out

    def describe(self, state: int) -> str:
        """A readable printout: one line per predicate with its true atoms."""
        groups: dict[str, list[str]] = {}
        for key in self.true_atoms(state):
            groups.setdefault(key[0], []).append(" ".join(key[1:]) or "yes")
        return "\n".join(f"{p:>14}: {', '.join(v)}" for p, v in groups.items())

    def action(self, name: str) -> int:
        """A ground action's index from its name, e.g. 'pick(cup_0, countertop)'."""
        key = name.strip().replace(" ", "").replace(",", ", ")
        if key not in self.action_index:
            raise DomainError(self.files["domain"], f"unknown ground action '{name}'")
        return self.action_index[key]

    # ---- the simulator ---------------------------------------------------
    def trigger_groups(self) -> dict:
        """{trigger atom (-1: none): [variants]}: the index successors() uses."""
        return {t: list(vs) for t, vs in self._trigger_variants.items()}

    def _build_successor_index(self) -> None:
        # Index each variant under its precondition atom of the predicate with the
        # most ground atoms (rarely true), so successors() tests few candidates.
        per_pred: dict[str, int] = {}
        for a in self.atoms:
            per_pred[a[0]] = per_pred.get(a[0], 0) + 1
        self._triggers: dict[int, list] = {}
        self._always: list = []
        self._variants_of: list[list] = [[] for _ in self.actions]
        self._trigger_variants: dict[int, list] = {}
        multi = {a for a in self.op_action if self.op_action.count(a) > 1}
        for v, (op, a) in enumerate(zip(self.ops, self.op_action)):
            entry = (op.pos, op.neg, op.add, op.dele, op.cond, a, self.action_cost[a], a in multi)
            self._variants_of[a].append(op)
            bits = [i for i in range(op.pos.bit_length()) if op.pos >> i & 1]
            if not bits:
                self._always.append(entry)
                self._trigger_variants.setdefault(-1, []).append(v)
                continue
            best = max(bits, key=lambda i: (per_pred[self.atoms[i][0]], -i))
            self._triggers.setdefault(best, []).append(entry)
            self._trigger_variants.setdefault(best, []).append(v)
        self._trigger_bits = sorted(self._triggers)

    def successors(self, state: int) -> list[tuple[int, int, int]]:
        """[(action, next_state, cost)] for every applicable ground action."""
        out = []
        seen = None
        triggers = self._triggers
        s = state
        candidates = [self._always]
        while s:
            low = s & -s
            lst = triggers.get(low.bit_length() - 1)
            if lst:
                candidates.append(lst)
            s ^= low
        for lst in candidates:
            for pos, neg, add, dele, cond, a, cost, multi in lst:
                if state & pos != pos or state & neg:
                    continue
                if multi:
                    seen = seen or set()
                    if a in seen:
                        continue
                    seen.add(a)
                for cp, cn, ca, cd in cond:
                    if state & cp == cp and not state & cn:
                        add |= ca
                        dele |= cd
                out.append((a, (state & ~dele) | add, cost))
        if self.axioms is not None:
            derive = self.axioms
            out = [(a, derive(t), c) for a, t, c in out]
        return out

    def applicable(self, state: int) -> list[int]:
        """The indices of the ground actions applicable in a state, ascending."""
        return sorted({a for a, _, _ in self.successors(state)})

    def is_applicable(self, state: int, action: int) -> bool:
        return any(op.applicable(state) for op in self._variants_of[action])

    def apply(self, state: int, action: int) -> int:
        """The next state; a DomainError (state untouched) if the action is not applicable."""
        for op in self._variants_of[action]:
            if op.applicable(state):
                return self.derive(op.apply(state))
        raise DomainError(self.actions[action], "not applicable in this state")

    # ---- world resets ----------------------------------------------------
    def reset_state(self, seed_or_rng) -> int:
        """A fresh world: the problem's :init with each [[reset]] entry's choice drawn."""
        rng = np.random.default_rng(seed_or_rng) if not isinstance(seed_or_rng, np.random.Generator) else seed_or_rng
        state = self.init
        for choices, probs in self.resets:
            k = int(rng.choice(len(choices), p=probs))
            every = 0
            for c in choices:
                every |= c
            state = (state & ~every) | choices[k]
        return self.derive(state)

    def reset_worlds(self, limit: int | None = None) -> list[int]:
        """Every world a reset can draw: each combination of the [[reset]] choices of probability > 0,
        in order, without repeats, at most `limit` combinations (None: all)."""
        from itertools import islice, product

        entries = []
        for choices, probs in self.resets:
            every = 0
            for c in choices:
                every |= c
            entries.append([(c, every) for c, p in zip(choices, probs) if p > 0])
        out = []
        for combo in islice(product(*entries), limit):
            state = self.init
            for choice, every in combo:
                state = (state & ~every) | choice
            out.append(self.derive(state))
        return list(dict.fromkeys(out))

    def random_walk_states(self, n: int, seed: int, walk: int = 40) -> list[int]:
        """n states (repeats allowed) along seeded random walks of `walk` steps from world resets:
        a cheap spread of reachable states to probe a value or a heuristic on."""
        rng = np.random.default_rng(seed)
        states = []
        while len(states) < n:
            s = self.reset_state(rng)
            for _ in range(walk):
                states.append(s)
                succ = self.successors(s)
                s = succ[rng.integers(len(succ))][1]
        return states[:n]
