"""Admissible heuristics for the exact searches, computed for a whole batch of states at once."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from planning.states import INF_64

INF = np.iinfo(np.int32).max // 4  # relaxed costs are int32 (half the memory traffic); INF + a cost fits


class HMax:
    """h_max (Bonet & Geffner 2001) on the positive normal form of the task.

    The costliest goal literal of the delete relaxation, where a negative literal
    (not p) is a relaxed atom of its own, reached by the actions that delete p
    (so the relaxation knows a dirty cup must be washed before it is filled).
    Admissible and consistent, so A* with it closes each state at its optimal g.
    A conditional effect is an achiever whose precondition includes its
    condition. Computed by Bellman-Ford over literals for a whole batch in numpy.
    Literal i < n is atom i; literal n + i is (not atom i).
    """

    def __init__(self, model, bm):
        self.bm = bm
        n = model.n_atoms
        achievers = []  # (precondition literals, action cost, reached literal)

        def add_achievers(pre, cost, add, dele):
            for atom in _bits(add):
                achievers.append((pre, cost, atom))
            for atom in _bits(dele & ~add):  # add wins over delete
                achievers.append((pre, cost, n + atom))

        for op, a in zip(model.ops, model.op_action):
            pre = _bits(op.pos) + [n + i for i in _bits(op.neg)]
            cost = model.action_cost[a]
            add_achievers(pre, cost, op.add, op.dele)
            for cp, cn, ca, cd in op.cond:
                add_achievers(pre + _bits(cp) + [n + i for i in _bits(cn)], cost, ca, cd)
        n *= 2
        self.n_atoms = n
        self._achievers = achievers
        self._tables: dict = {}

    def _relevant_tables(self, goal: list[list[int]]):
        """Achiever tables restricted to the literals the goal can depend on (cached per goal).

        A literal is relevant if it is in the goal or in the precondition of an
        achiever of a relevant literal; the others cannot change the goal's h_max.
        """
        key = tuple(tuple(c) for c in goal)
        if key in self._tables:
            return self._tables[key]
        relevant = {lit for conj in goal for lit in conj}
        frontier = list(relevant)
        by_effect: dict[int, list] = {}
        for i, (_, _, lit) in enumerate(self._achievers):
            by_effect.setdefault(lit, []).append(i)
        while frontier:
            lit = frontier.pop()
            for i in by_effect.get(lit, []):
                for p in self._achievers[i][0]:
                    if p not in relevant:
                        relevant.add(p)
                        frontier.append(p)
        lits = sorted(l for l in relevant if l in by_effect)  # reachable by some achiever
        chosen = [i for l in lits for i in by_effect[l]]
        n = self.n_atoms
        # Padding: literal n is always reached (cost 0).
        width = max((len(self._achievers[i][0]) for i in chosen), default=1) or 1
        pre = np.full((len(chosen), width), n, dtype=np.int64)
        cost = np.zeros(len(chosen), dtype=np.int32)
        for row, i in enumerate(chosen):
            p, c, _ = self._achievers[i]
            pre[row, : len(p)] = p
            cost[row] = c
        starts = np.cumsum([0] + [len(by_effect[l]) for l in lits[:-1]]).astype(np.int64)
        self._tables[key] = (pre, cost, starts, np.array(lits, dtype=np.int64))
        return self._tables[key]

    def literal_costs(self, batch: np.ndarray, goal: list[list[int]]) -> np.ndarray:
        """(N, 2 atoms + 1) relaxed cost of each literal the goal depends on (others: 0 or INF)."""
        pre, acost, starts, lits = self._relevant_tables(goal)
        bits = self.bm.to_bits(batch).astype(bool)
        cost = np.full((len(batch), self.n_atoms + 1), INF, dtype=np.int32)
        half = self.n_atoms // 2
        cost[:, :half][bits] = 0
        cost[:, half:-1][~bits] = 0
        cost[:, -1] = 0
        if not len(lits):
            return cost
        while True:
            via = cost[:, pre].max(-1) + acost  # (N, achievers)
            best = np.minimum.reduceat(via, starts, axis=1)  # (N, relevant literals)
            new = np.minimum(cost[:, lits], best)
            if (new == cost[:, lits]).all():
                return cost
            cost[:, lits] = new

    def __call__(self, batch: np.ndarray, goal: list[list[int]]) -> np.ndarray:
        """(N,) h_max of each state for a DNF goal of literal lists (INF: dead end)."""
        if not len(batch):
            return np.zeros(0, dtype=np.int64)
        cost = self.literal_costs(batch, goal)
        per_conj = [cost[:, conj].max(-1) if conj else np.zeros(len(batch), dtype=np.int32) for conj in goal]
        h = np.minimum.reduce(per_conj).astype(np.int64)
        h[h >= INF] = INF_64
        return h


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]


def goal_literals(model, task) -> list[list[int]]:
    """Each conjunction of a task's goal as literal indices (n + i stands for not atom i)."""
    n = model.n_atoms
    return [_bits(o.pos) + [n + i for i in _bits(o.neg)] for o in task.bindings]


class GoalLiterals:
    """goal_literals of a list of goals, their conjunctions in one DNF, memoized by the goals' bindings."""

    MAX_ENTRIES = 4096

    def __init__(self, model):
        self.model, self._memo = model, {}

    def __call__(self, goals: list) -> list[list[int]]:
        key = tuple(tuple((o.pos, o.neg) for o in g.bindings) for g in goals)
        dnf = self._memo.get(key)
        if dnf is None:
            if len(self._memo) >= self.MAX_ENTRIES:
                self._memo.clear()
            dnf = self._memo[key] = [c for g in goals for c in goal_literals(self.model, g)]
        return dnf


class MinHMax:
    """The multi-goal search's h_max: min over the goals (the model's tasks) of their h_max, every task's from
    one relaxed-cost table per batch (the union of all tasks' goals)."""

    def __init__(self, model, bm):
        self.hmax = HMax(model, bm)
        lits = [goal_literals(model, t) for t in model.tasks]
        self.union = [c for task in lits for c in task]
        owner = np.array([t for t, task in enumerate(lits) for _ in task], dtype=np.int64)
        self.starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
        always = self.hmax.n_atoms  # literal_costs' last column: always 0
        width = max((len(c) for c in self.union), default=1) or 1
        self.conj = np.full((len(self.union), width), always, dtype=np.int64)
        for k, c in enumerate(self.union):
            self.conj[k, : len(c)] = c

    def per_task(self, batch: np.ndarray) -> np.ndarray:
        """(N, T) h_max of every task (INF_64: dead end)."""
        cost = self.hmax.literal_costs(batch, self.union)  # (N, 2 atoms + 1)
        per_conj = cost[:, self.conj].max(-1).astype(np.int64)  # (N, K)
        h = np.minimum.reduceat(per_conj, self.starts, axis=1)
        h[h >= INF] = INF_64
        return h

    def __call__(self, batch: np.ndarray, goals: list) -> np.ndarray:
        if not len(batch):
            return np.zeros(0, dtype=np.int64)
        return self.per_task(batch)[:, [t.index for t in goals]].min(1)


def build(bm, search: str):
    """The registry's builder (planning.heuristics): h_max of the nearest goal's DNF on the model's relaxed_view
    (task search), of the current stage (window), or the min over the tasks of one table (multi-goal)."""
    if search == "multi-goal":
        return MinHMax(bm.model, bm)
    h, literals = HMax(relaxed_view(bm.model), bm), GoalLiterals(bm.model)
    if search == "window":
        return lambda batch, goals: h(batch, literals(goals[:1]))
    return lambda batch, goals: h(batch, literals(goals))


def relaxed_view(model):
    """The model as the delete-relaxation heuristics (HMax, LMCut) are to read it: the model itself, or, where it
    has derived predicates, its operators plus one zero-cost operator per ground axiom (body -> head) and one
    that makes every negated derived atom free. Relaxed reachability then follows the axioms; giving the
    negated atoms away only lowers the estimates, so both heuristics stay admissible."""
    axioms = getattr(model, "axioms", None)
    if axioms is None:
        return model
    from planning.domain.model import Op

    ops, op_action, cost = list(model.ops), list(model.op_action), list(model.action_cost)
    free = len(cost)
    cost.append(0)
    for stratum in axioms.strata:
        for pos, neg, head in stratum:
            ops.append(Op(pos, neg, head, 0))
            op_action.append(free)
    ops.append(Op(0, 0, 0, axioms.mask))
    op_action.append(free)
    return SimpleNamespace(
        n_atoms=model.n_atoms,
        atoms=model.atoms,
        ops=ops,
        op_action=op_action,
        action_cost=cost,
        name=model.name,
        layout=model.layout,
    )
