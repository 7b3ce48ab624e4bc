"""Admissible heuristics for the exact searches, computed for a whole batch of states at once."""
from __future__ import annotations

import numpy as np

INF = np.iinfo(np.int32).max // 4        # relaxed costs are int32: half the memory traffic
INF_64 = np.iinfo(np.int64).max // 4     # "unreachable" for g and f values


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
        achievers = []                      # (precondition literals, action cost, reached literal)

        def add_achievers(pre, cost, add, dele):
            for atom in _bits(add):
                achievers.append((pre, cost, atom))
            for atom in _bits(dele & ~add):           # add wins over delete
                achievers.append((pre, cost, n + atom))

        for op, a in zip(model.ops, model.op_action):
            pre = _bits(op.pos) + [n + i for i in _bits(op.neg)]
            cost = model.action_cost[a]
            add_achievers(pre, cost, op.add, op.dele)
            for cp, cn, ca, cd in op.cond:
                add_achievers(pre + _bits(cp) + [n + i for i in _bits(cn)], cost, ca, cd)
        n *= 2
        # Padding: literal index n is always reached (cost 0); achiever index len is never applicable.
        width = max((len(p) for p, _, _ in achievers), default=1) or 1
        self.pre = np.full((len(achievers) + 1, width), n, dtype=np.int64)
        self.cost = np.zeros(len(achievers) + 1, dtype=np.int32)
        for i, (pre, c, _) in enumerate(achievers):
            self.pre[i, : len(pre)] = pre
            self.cost[i] = c
        self.cost[-1] = INF
        # Achievers sorted by the atom they add (an atom with none gets the never-
        # applicable one), so one minimum.reduceat gives every atom's best achiever.
        per_atom = [[i for i, (_, _, atom) in enumerate(achievers) if atom == k] or [len(achievers)]
                    for k in range(n)]
        self.order = np.array([i for lst in per_atom for i in lst], dtype=np.int64)
        self.starts = np.cumsum([0] + [len(lst) for lst in per_atom[:-1]]).astype(np.int64)
        self.n_atoms = n

    def atom_costs(self, batch: np.ndarray) -> np.ndarray:
        """(N, 2 atoms + 1) relaxed cost of reaching each literal from each state."""
        bits = self.bm.to_bits(batch).astype(bool)
        cost = np.full((len(batch), self.n_atoms + 1), INF, dtype=np.int32)
        half = self.n_atoms // 2
        cost[:, :half][bits] = 0
        cost[:, half:-1][~bits] = 0
        cost[:, -1] = 0
        while True:
            via = cost[:, self.pre].max(-1) + self.cost          # (N, achievers + 1)
            best = np.minimum.reduceat(via[:, self.order], self.starts, axis=1)   # (N, atoms)
            new = np.minimum(cost[:, :-1], best)
            if (new == cost[:, :-1]).all():
                return cost
            cost[:, :-1] = new

    def __call__(self, batch: np.ndarray, goal: list[list[int]]) -> np.ndarray:
        """(N,) h_max of each state for a DNF goal of literal lists (INF: dead end)."""
        if not len(batch):
            return np.zeros(0, dtype=np.int64)
        cost = self.atom_costs(batch)
        per_conj = [cost[:, conj].max(-1) if conj else np.zeros(len(batch), dtype=np.int32)
                    for conj in goal]
        h = np.minimum.reduce(per_conj).astype(np.int64)
        h[h >= INF] = INF_64
        return h


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]


def goal_literals(model, task) -> list[list[int]]:
    """Each conjunction of a task's goal as literal indices (n + i stands for not atom i)."""
    n = model.n_atoms
    return [_bits(o.pos) + [n + i for i in _bits(o.neg)] for o in task.bindings]
