"""The labelling oracle: C_AP(s) = sum_tau P(tau) C*_tau(s) (thesis Eq. 3.11), exactly.

Every task of the layout's distribution is solved from s by ONE multi-goal
search: A* by f-levels (planning.search.cost_levels) on the batched model whose
goal is "some task not yet settled". Each task's optimal cost is settled at the
first level that closes one of its goal states (the smallest g among them), and
the search stops when every task is settled.

Why this is exact. The heuristic at any moment is an admissible estimate of
the cost to the nearest goal of a still-unsettled task, e.g. the minimum over
those tasks of h_max, or LM-cut of the disjunction of their goals. For an
unsettled task tau it is therefore <= h*_tau, whatever else has been settled:
settling only shrinks the set, which only raises the estimate, and never above
h*_tau while tau is in it. A* with pathmax and reopening (a closed state found
again at a smaller g is expanded again) keeps, until tau is settled, a node of
an optimal tau-plan open at its optimal g with f <= C*_tau. Levels are popped in
increasing f and a goal state of tau has g <= f, so the first level holding a
goal of tau holds one at g = C*_tau and none cheaper. Entries queued under an
older, larger task set carry a stale (smaller) f; they are re-scored when popped
and queued again if their f rose (CostLevels.rescore), which keeps the search
from expanding states only a settled task needed.

    python -m oracles.labelling --layout three-room [--state FILE] [--out FILE] [--force]
        [--stream NAME --estimator markov --after TASK]

P(tau) is the layout's by default. A `planning.world.estimators` estimator replaces it with what an agent
believes the next task's distribution to be (thesis limitations L1 and L4): `Labeller(model,
estimator=...)`, and `label(state, after=TASK)` weighs every task's optimal cost by
P(tau' | after) instead, e.g. the C_AP of a state left by make-coffee under a Markov stream where
washing-up usually follows. The search is the same (every task is solved from s whatever the weights), so
one label serves every distribution (`Label.under`). On the command line: `--estimator markov` with
`--stream NAME` (a declared Markov stream) and `--after TASK`, the task just completed (none: the first
task of a sequence, the stream's start distribution); `known` is the default. The empirical estimators
answer from the tasks they have seen, which a single command has not: they are the API's.

--state is checked first (`check_possible`): a state two of whose atoms never hold together in any state
the layout reaches (from a world reset, by actions and by task consumption) is refused; one the check
cannot place is labelled with a warning, "not reachable as far as I can tell".

--out writes the label with the domain's identity (`planning.domain.identity`), the layout and
the state's atoms; it never replaces a labels file of another state, layout or domain content
(nor any other file) unless --force.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planning import cli
from planning.atomic import write_json
from planning.domain.batched import BatchedModel
from planning.domain.grounding import atom_text
from planning.errors import DomainError
from planning.heuristics import HEURISTICS, build, choose, names
from planning.search.cost_levels import CostLevels
from planning.world.estimators import build as build_estimator
from planning.world.streams import stream

CLI_ESTIMATORS = ("known", "markov")
"""The estimators --estimator takes: those that need no stream seen so far (see the module)."""

CHUNK = 1 << 16  # rows per goal test: keeps the (rows, conjunctions) arrays small


class TaskGoals:
    """Every task's goal as stacked conjunctions: (K, W) pos/neg words and the task of each."""

    def __init__(self, bm, tasks):
        self.bm = bm
        self.tasks = list(tasks)
        self.probabilities = np.array([t.probability for t in self.tasks], dtype=float)
        ops = [(t, o) for t, task in enumerate(self.tasks) for o in task.bindings]
        self.owner = np.array([t for t, _ in ops], dtype=np.int64)  # ascending by construction
        self.pos = bm.pack([o.pos for _, o in ops])
        self.neg = bm.pack([o.neg for _, o in ops])
        self.starts = np.searchsorted(self.owner, np.arange(len(self.tasks)))

    def __len__(self) -> int:
        return len(self.tasks)

    def satisfied(self, rows: np.ndarray, tasks: np.ndarray | None = None) -> np.ndarray:
        """(N, T') bool: which of `tasks` (default all) each packed state satisfies."""
        tasks = np.arange(len(self.tasks)) if tasks is None else np.asarray(tasks)
        out = np.zeros((len(rows), len(tasks)), dtype=bool)
        for j, t in enumerate(tasks):
            for k in range(self.starts[t], self.starts[t + 1] if t + 1 < len(self.tasks) else len(self.owner)):
                p, n = self.pos[k], self.neg[k]
                out[:, j] |= ((rows & p) == p).all(1) & ((rows & n) == 0).all(1)
        return out


class CachedHeuristic:
    """Memoizes a multi-goal heuristic h(batch, goals) by (the goals' tasks, state), exactly (the state's words).

    A state is generated again and again, by other parents and by the searches of
    neighbouring dataset states (consecutive states of a rollout share most of
    their search space, and at each phase the same tasks are unsettled), and the
    wrapped heuristic is a pure function of the state and the unsettled set. The
    cache keeps at most `max_entries` values; past that the oldest task sets go.
    """

    def __init__(self, inner, max_entries: int = 1_500_000):
        self.inner, self.max_entries = inner, max_entries
        self.tables: dict[tuple, dict] = {}  # task indices -> {state bytes: h}; insertion order = age
        self.size = 0
        self.calls = self.computed = 0

    def __call__(self, batch: np.ndarray, goals: list) -> np.ndarray:
        n = len(batch)
        if not n:
            return np.zeros(0, dtype=np.int64)
        key = tuple(t.index for t in goals)
        table = self.tables.pop(key, None)
        if table is None:
            table = {}
        self.tables[key] = table  # most recently used last
        width = batch.shape[1] * batch.itemsize
        raw = np.ascontiguousarray(batch).tobytes()
        rows = [raw[i : i + width] for i in range(0, n * width, width)]
        out = np.fromiter((table.get(r, -1) for r in rows), dtype=np.int64, count=n)
        miss = np.flatnonzero(out < 0)
        self.calls += n
        if len(miss):
            h = self.inner(batch[miss], goals)
            out[miss] = h
            for i, v in zip(miss.tolist(), h.tolist()):
                table[rows[i]] = v
            self.computed += len(miss)
            self.size += len(miss)
            while self.size > self.max_entries and len(self.tables) > 1:
                old = next(iter(self.tables))
                self.size -= len(self.tables.pop(old))
        return out


# ---- the oracle --------------------------------------------------------------------------


@dataclass
class Label:
    """C_AP of one state with every task's optimal cost."""

    c_ap: float
    costs: np.ndarray  # (T,) int64; -1 where no plan exists (then c_ap is inf)
    seconds: float
    closed: int
    complete: bool
    probabilities: np.ndarray | None = None  # (T,) the distribution c_ap weighs by; None: the layout's P

    def under(self, probabilities) -> float:
        """C_AP of the same state under another next-task distribution (T,): sum_tau p(tau) C*_tau; inf
        where p gives weight to a task with no plan."""
        return expected_cost(np.asarray(probabilities, dtype=float), self.costs)

    def as_json(self, tasks) -> dict:
        """{"c_ap", "tasks": [{"task", "probability", "cost"}]} as --out writes it (the probabilities
        c_ap weighs by)."""
        p = [t.probability for t in tasks] if self.probabilities is None else self.probabilities
        return {
            "c_ap": self.c_ap if np.isfinite(self.c_ap) else None,
            "tasks": [
                {"task": t.name, "probability": float(q), "cost": int(c) if c >= 0 else None}
                for t, q, c in zip(tasks, p, self.costs)
            ],
            "seconds": round(self.seconds, 4),
            "closed": self.closed,
        }


def expected_cost(probabilities: np.ndarray, costs: np.ndarray) -> float:
    """sum_tau p(tau) C*_tau over the tasks; inf if p gives weight to a task with no plan (cost -1)."""
    solved = costs >= 0
    if (probabilities[~solved] > 0).any():
        return float("inf")
    return float(probabilities @ np.where(solved, costs, 0))


class Labeller:
    """C_AP(s) = sum_tau P(tau) C*_tau(s) over every task instantiation of a layout, by one multi-goal search.

    heuristic: a name of the registry's "multi-goal" rows (planning.heuristics): "pdb" (min over the
    unsettled tasks of their pattern databases, planning.heuristics.pdb; the default, for a layout whose
    rooms name its locations, else "lmcut"), "lmcut" (LM-cut of the unsettled tasks' goals joined by "or";
    planning.heuristics.lmcut), "lmcut-pc" (the same on the P^C compilation with the agent's atom pairs,
    planning.heuristics.lmcut_pc; states that break the mutexes it relies on get "lmcut"), "hmax" (min
    over the unsettled tasks of h_max) or "blind" (Dijkstra). All are admissible, so every label is the
    same exact one. `cache`: memoize the heuristic across searches (CachedHeuristic; not for a row whose
    estimate is a table lookup). `tie_break`: within an f, lower h first (CostLevels); the same labels.
    `estimator`: a `planning.world.estimators` estimator whose P(tau' | after) replaces the layout's P in
    C_AP (None: the layout's P, the thesis's label).
    """

    def __init__(
        self,
        model,
        heuristic: str = "pdb",
        time_limit: float | None = None,
        cache: bool = True,
        tie_break: bool = False,
        estimator=None,
    ):
        self.model, self.time_limit, self.tie_break = model, time_limit, tie_break
        self.estimator = estimator
        self.bm = BatchedModel(model)
        self.goals = TaskGoals(self.bm, model.tasks)
        self.heuristic = choose(heuristic, model, "multi-goal")
        h = build(self.heuristic, self.bm, "multi-goal")  # None: blind, Dijkstra
        if h is not None and cache and not HEURISTICS[self.heuristic].lookup:
            h = CachedHeuristic(h)
        self.h = h

    def label(self, state: int, after=None) -> Label:
        """C_AP of a state exactly as given (apply the finished task's consumption first). `after`: the task
        just completed, which the estimator's distribution may depend on (a Markov stream's P(tau' | after))."""
        t0 = time.perf_counter()
        goals, tasks = self.goals, self.goals.tasks
        costs = np.full(len(goals), -1, dtype=np.int64)
        unsettled = np.ones(len(goals), dtype=bool)

        def h(batch):
            return self.h(batch, [tasks[t] for t in np.flatnonzero(unsettled)])

        levels = CostLevels(
            self.bm,
            state,
            time_limit=self.time_limit,
            heuristic=None if self.h is None else h,
            tie_break=self.tie_break,
        )
        for _, rows, _, g in levels:
            # Settle the tasks whose goal this level reaches, at the smallest g among its goal states.
            open_tasks = np.flatnonzero(unsettled)
            for lo in range(0, len(rows), CHUNK):
                sat = goals.satisfied(rows[lo : lo + CHUNK], open_tasks)
                for j in np.flatnonzero(sat.any(0)):
                    t = open_tasks[j]
                    c = int(g[lo : lo + CHUNK][sat[:, j]].min())
                    if unsettled[t] or c < costs[t]:
                        costs[t], unsettled[t] = c, False
            if not unsettled.any():
                break
            if unsettled.sum() < len(open_tasks):
                levels.rescore()  # the minimum is over fewer tasks now: states opened before may wait
        solved = costs >= 0
        p = None if self.estimator is None else np.asarray(self.estimator.probabilities(after), dtype=float)
        if p is None:
            c_ap = float(goals.probabilities @ np.where(solved, costs, 0))
            if not solved.all():
                c_ap = float("inf")
        else:
            c_ap = expected_cost(p, costs)
        complete = not unsettled.any() or levels.exhausted
        return Label(c_ap, costs, time.perf_counter() - t0, levels.closed, complete, p)


def c_ap(model, state: int, heuristic: str = "pdb") -> float:
    """C_AP of one state (a convenience; build a Labeller to label many)."""
    return Labeller(model, heuristic).label(state).c_ap


def read_state(model, path) -> int:
    """A state from a file: a JSON list of true atoms, or a PDDL problem file's :init."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise DomainError(path, f"cannot read: {e.strerror}") from None
    if text.lstrip().startswith("["):
        try:
            atoms = json.loads(text)
        except json.JSONDecodeError as e:
            raise DomainError(path, f"malformed JSON: {e.msg} at line {e.lineno}") from None
        if not all(isinstance(a, str) for a in atoms):
            raise DomainError(path, 'must be a JSON list of atom strings like "(at cup_0 shelf)"')
    else:
        atoms = _pddl_init_atoms(path, text)
    try:
        return model.state_from_atoms([a for a in atoms if _fluent(model, a, path)])
    except DomainError as e:
        raise DomainError(path, e.reason) from None


def _fluent(model, text: str, path) -> bool:
    """True for a fluent atom; False for a static fact of the layout (kept out of states)."""
    from planning.domain.grounding import parse_atom_text

    try:
        key = parse_atom_text(text)
    except ValueError as e:
        raise DomainError(path, str(e)) from None
    return key not in model.static_atoms


def _pddl_init_atoms(path, text: str) -> list[str]:
    """The atoms of a PDDL problem's :init (numeric fluents such as costs are skipped)."""
    import re

    lower = text.lower()
    start = lower.find("(:init")
    if start < 0:
        raise DomainError(path, "neither a JSON list of atoms nor a PDDL problem with (:init")
    depth, i = 0, start
    while i < len(text):
        depth += {"(": 1, ")": -1}.get(text[i], 0)
        if depth == 0:
            break
        i += 1
    else:
        raise DomainError(path, "unbalanced parentheses in :init")
    body = re.sub(r";[^\n]*", "", text[start + len("(:init") : i])
    atoms, depth, begin = [], 0, 0
    for j, ch in enumerate(body):  # the top-level groups: atoms and (= ...) numeric facts
        if ch == "(":
            if depth == 0:
                begin = j
            depth += 1
        elif ch == ")":
            depth -= 1
            if depth < 0:
                raise DomainError(path, "unbalanced parentheses in :init")
            if depth == 0:
                inner = body[begin + 1 : j].strip()
                if inner.startswith("="):
                    continue
                if "(" in inner:
                    raise DomainError(path, f"cannot read the :init fact ({' '.join(inner.split())})")
                atoms.append(f"({' '.join(inner.split())})")
    return atoms


# ---- is a state one the layout can reach? --------------------------------------------------
class ReachablePairs:
    """Pairs of atoms that never hold together in any state a layout can reach: from any world a reset can
    draw, by actions and by the consumption of completed tasks (the h^2-style fixpoint on pairs).

    The starting pairs are exact: an atom that some [[reset]] entry names takes that entry's drawn choice (the
    last such entry's), one that none names keeps its :init value, so two atoms hold together in some reset
    world iff both can (atoms of one entry: in one of its choices). The transitions over-approximate: every
    action, and every binding of every task instance (not only the first satisfied one, nor only the tasks
    that can be drawn), each conditional effect firing or not. A pair left mutex is therefore a proof that no
    reachable state holds both. Derived atoms (recomputed from the others after every change) are left out:
    they are taken as able to hold with anything, and preconditions on them as satisfiable. `max_rounds` caps
    the fixpoint; a capped analysis is not a proof (`complete` False)."""

    MAX_CASES = 8  # conditional effects enumerated as subsets up to this many; beyond, one coarse case

    def __init__(self, model, max_rounds: int | None = None):
        n = self.n = model.n_atoms
        derived = getattr(getattr(model, "axioms", None), "mask", 0) or 0
        self.derived = _bool(derived, n)
        m = ~_reset_together(model, n)
        m[self.derived, :] = False
        m[:, self.derived] = False
        ops = list(model.ops) + [o for t in model.tasks for o in t.bindings]
        cases = []
        for op in ops:
            for pos, neg, add, dele in _firings(op, self.MAX_CASES):
                pos, neg = pos & ~derived, neg & ~derived
                A = np.array(_bits(add & ~derived), dtype=np.int64)
                if len(A):
                    cases.append(
                        (np.array(_bits(pos), dtype=np.int64), _bool(neg, n), _bool(dele, n), A, _bool(add, n))
                    )
        rounds, changed = 0, True
        while changed and (max_rounds is None or rounds < max_rounds):
            changed, rounds = False, rounds + 1
            for P, neg, dele, A, add in cases:
                if len(P) and (m[np.ix_(P, P)].any() or neg[P].any()):
                    continue  # never applicable in a state that respects m
                # after the op, an added atom may hold with any q not deleted, not required false and not
                # mutex with a precondition (then q was false before), or added too
                apart = dele | neg | (m[P].any(0) if len(P) else np.zeros(n, dtype=bool))
                hit = m[A] & (~apart | add)
                if hit.any():
                    for row, p in zip(hit, A):
                        if row.any():
                            m[p, row] = False
                            m[row, p] = False
                    changed = True
        self.complete = not changed
        np.fill_diagonal(m, False)
        self.matrix = m

    def violated(self, state: int) -> list[tuple[int, int]]:
        """The mutex pairs (i < j) that `state` holds together."""
        true = np.flatnonzero(_bool(state, self.n))
        sub = self.matrix[np.ix_(true, true)]
        return [(int(true[a]), int(true[b])) for a, b in zip(*np.nonzero(np.triu(sub, 1)))]


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]


def _bool(mask: int, n: int) -> np.ndarray:
    out = np.zeros(n, dtype=bool)
    out[_bits(mask)] = True
    return out


def _firings(op, max_cases: int) -> list[tuple]:
    """(pos, neg, add, dele) of each way an op can fire: each subset of its conditional effects (their
    conditions joined to the precondition), or, past `max_cases` of them, one case with every conditional
    add and no conditional delete or condition (coarser, still covering every firing). Adds win."""
    conds = list(getattr(op, "cond", ()))
    if len(conds) > max_cases:
        add = op.add
        for _, _, ca, _ in conds:
            add |= ca
        return [(op.pos, op.neg, add, op.dele & ~add)]
    from itertools import combinations

    out = []
    for k in range(len(conds) + 1):
        for sub in combinations(conds, k):
            pos, neg, add, dele = op.pos, op.neg, op.add, op.dele
            for cp, cn, ca, cd in sub:
                pos, neg, add, dele = pos | cp, neg | cn, add | ca, dele | cd
            if not pos & neg:
                out.append((pos, neg, add, dele & ~add))
    return out


def _reset_together(model, n: int) -> np.ndarray:
    """(n, n) bool: which pairs of atoms hold together in some world a reset can draw (choices of P > 0)."""
    owner = np.full(n, -1)  # the last [[reset]] entry that names each atom
    choices = []
    for e, (masks, probs) in enumerate(model.resets):
        every = 0
        for c in masks:
            every |= c
        owner[_bits(every)] = e
        choices.append(np.array([_bool(c, n) for c, p in zip(masks, probs) if p > 0], dtype=bool).reshape(-1, n))
    fixed = _bool(model.init, n) & (owner < 0)
    can = fixed.copy()
    for e, C in enumerate(choices):
        can |= C.any(0) & (owner == e)
    together = np.outer(can, can)
    for e, C in enumerate(choices):  # two atoms of one entry: only in the same choice
        mine = owner == e
        same = (C.T.astype(np.int64) @ C.astype(np.int64)) > 0
        block = np.ix_(mine, mine)
        together[block] = same[block]
    return together


def reachable_states(model, limit: int = 20_000, target: int | None = None) -> tuple[set, bool]:
    """(states, complete): the states reachable from every reset world by actions and by the consumption of
    satisfied tasks (the first satisfied binding, as the world applies it), breadth first, at most `limit`;
    stops early once `target` is found. complete: the whole reachable set was enumerated."""
    from collections import deque

    roots = model.reset_worlds(limit)
    seen = set(roots)
    frontier = deque(seen)
    while frontier:
        if target in seen or len(seen) >= limit:
            return seen, False
        s = frontier.popleft()
        nxt = [t for _, t, _ in model.successors(s)] + [task.consume(s) for task in model.tasks if task.satisfied(s)]
        for t in nxt:
            if t not in seen:
                seen.add(t)
                frontier.append(t)
    return seen, True


def check_possible(model, state: int, where, limit: int = 20_000, max_rounds: int | None = None) -> str | None:
    """A one-line error if two atoms of `state` never hold together in any state the layout can reach (the
    robot in two places, an object held and on a table): `ReachablePairs`, which accounts for every world
    a reset can draw, every action and every task's consumption. Where the analysis cannot prove it, a
    warning line instead (returned, the caller prints it): "not reachable as far as I can tell", when the
    pair fixpoint was cut short, or when the state respects every pair but is none of the states
    enumerated from the reset worlds though they were all enumerated. None: nothing to say.
    `limit`: states enumerated at most; `max_rounds`: ReachablePairs's cap."""
    pairs = ReachablePairs(model, max_rounds)
    bad = pairs.violated(state)
    if bad and pairs.complete:
        i, j = bad[0]
        raise DomainError(
            where,
            f"an impossible state: {atom_text(model.atoms[i])} and "
            f"{atom_text(model.atoms[j])} never hold together in any state this layout "
            "reaches (from a world reset, by actions and task consumption)",
        )
    if bad:
        i, j = bad[0]
        return (
            f"{where}: not reachable as far as I can tell: {atom_text(model.atoms[i])} and "
            f"{atom_text(model.atoms[j])} seem never to hold together (the analysis was cut short); "
            "labelled as given"
        )
    states, complete = reachable_states(model, limit, target=state)
    if complete and state not in states:
        return (
            f"{where}: not reachable as far as I can tell: none of the {len(states):,} states reachable "
            "from the world resets by actions and task consumption; labelled as given"
        )
    return None


def labels_file(model, state: int, label: Label, heuristic: str, distribution: dict | None = None) -> dict:
    """What --out writes: the domain's identity, the layout, the state's atoms, C_AP and every task's cost;
    `distribution` (`distribution_record`) where C_AP weighs by an estimator's P."""
    from planning.domain.identity import identity

    return {
        **identity(model),
        "layout": model.layout,
        "heuristic": heuristic,
        "state": [atom_text(k) for k in model.true_atoms(state)],
        **({} if distribution is None else {"distribution": distribution}),
        **label.as_json(model.tasks),
    }


def distribution_record(estimator: str, stream: str, after) -> dict | None:
    """What a labels file records of the distribution its C_AP weighs by (None: the layout's P, which the
    known estimator is whatever the stream)."""
    if estimator == "known":
        return None
    return {"estimator": estimator, "stream": stream, "after": None if after is None else after.name}


def check_replaceable(path, model, state: int, distribution: dict | None = None) -> None:
    """A one-line error if `path` holds anything but a labels file of this state, layout, domain content and
    distribution (the same label again may be rewritten; another is replaced only with --force)."""
    from planning.domain.identity import mismatch

    path = Path(path)
    if not path.is_file():
        return
    try:
        saved = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        saved = None
    if not isinstance(saved, dict) or "c_ap" not in saved:
        raise DomainError(path, "exists and is not a labels file; pass --force to replace it, or --out another file")
    atoms = sorted(atom_text(k) for k in model.true_atoms(state))
    if (
        saved.get("layout") != model.layout
        or mismatch(saved, model) is not None
        or sorted(saved.get("state") or []) != atoms
        or saved.get("distribution") != distribution
    ):
        what = (
            f"layout {saved.get('layout')}"
            if saved.get("layout") != model.layout
            else mismatch(saved, model)
            or ("a state it does not record" if saved.get("state") is None else None)
            or ("another state" if sorted(saved.get("state") or []) != atoms else "another task distribution")
        )
        raise DomainError(path, f"a labels file of {what}; pass --force to replace it, or --out another file")


def summary(model, label: Label, distribution: dict | None = None) -> str:
    """C_AP and every task's cost, one line per task, for the command line."""
    under = ""
    if distribution is not None:
        after = distribution["after"] or "a sequence's start"
        under = f" under {distribution['estimator']} (stream {distribution['stream']}, after {after})"
    lines = [
        f"{model.name} {model.layout}: C_AP = {label.c_ap:.2f}{under} over {len(label.costs)} tasks "
        f"({label.seconds:.2f}s, {label.closed} states closed)"
    ]
    p = [t.probability for t in model.tasks] if label.probabilities is None else label.probabilities
    for t, q, c in sorted(zip(model.tasks, p, label.costs), key=lambda x: (-x[2], x[0].name)):
        lines.append(f"  {t.name:34s} P={q:.5f}  cost {c if c >= 0 else 'none':>5}")
    return "\n".join(lines)


def main() -> None:
    from planning.domain.compiler import compile_domain

    p = cli.parser(__doc__.splitlines()[0])
    p.add_argument(
        "--state",
        default=None,
        help="a JSON list of true atoms or a PDDL problem file (default: the layout's start state)",
    )
    p.add_argument("--heuristic", default="pdb", choices=names("multi-goal"), help="(default: %(default)s)")
    p.add_argument("--time-limit", type=float, default=None, help="seconds for the search (default: none)")
    p.add_argument(
        "--stream", default="iid", help="the task stream whose distribution C_AP weighs by (default: %(default)s)"
    )
    p.add_argument(
        "--estimator",
        default="known",
        choices=CLI_ESTIMATORS,
        help="the next task's distribution (planning.world.estimators; default: %(default)s, the layout's P)",
    )
    p.add_argument("--after", default=None, help="the task just completed, e.g. 'make-coffee(servingtable)'")
    p.add_argument("--force", action="store_true", help="replace an --out file of another state or domain content")
    args = p.parse_args()
    if args.time_limit is not None and not args.time_limit > 0:
        raise DomainError("--time-limit", f"must be positive, not {args.time_limit}")
    model = compile_domain(args.domain, args.layout)
    estimator = build_estimator(args.estimator, model, stream(model, args.stream))
    after = None if args.after is None else model.tasks.get(args.after)
    if after is not None and args.estimator == "known":
        raise DomainError(
            "--after",
            "the known estimator's P does not depend on the task just completed (pass "
            "--estimator markov and --stream NAME)",
        )
    distribution = distribution_record(args.estimator, args.stream, after)
    state = model.init if args.state is None else read_state(model, args.state)
    where = args.state or f"the start state of {model.layout}"
    if args.state is not None:
        warning = check_possible(model, state, where)
        if warning:
            print(f"warning: {warning}", file=sys.stderr)
    if args.out and not args.force:
        check_replaceable(args.out, model, state, distribution)
    labeller = Labeller(model, args.heuristic, args.time_limit, estimator=None if distribution is None else estimator)
    label = labeller.label(state, after)
    if not label.complete:
        raise DomainError(where, f"time limit of {args.time_limit}s reached before every task was solved")
    unsolvable = [t.name for t, c in zip(model.tasks, label.costs) if c < 0]
    if unsolvable:
        more = f" (and {len(unsolvable) - 1} more of the {len(model.tasks)} tasks)" if len(unsolvable) > 1 else ""
        raise DomainError(
            where, f"task {unsolvable[0]} cannot be completed from this state{more}, so C_AP is undefined"
        )
    print(summary(model, label, distribution))
    if args.out:
        from planning.atomic import OutputLock

        with OutputLock(args.out, "labels file"):
            write_json(args.out, labels_file(model, state, label, labeller.heuristic, distribution))
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)
