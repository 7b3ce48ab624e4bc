"""LM-cut (Helmert & Domshlak 2009), computed for a whole batch of states at once in numpy.

The same positive normal form as HMax: literal i < n is atom i, literal n + i is
(not atom i), a conditional effect is an achiever whose precondition includes
its condition, and a DNF goal is an artificial goal literal with one zero-cost
achiever per conjunction. Each round of LM-cut, for every state of the batch:
h_max under the state's current achiever costs, the precondition-choice
function (the costliest precondition of each achiever), the goal zone (literals
that reach the goal literal through zero-cost achievers, backwards), the
literals reachable from the state without entering the zone, and the cut (the
achievers that enter the zone from there). The cut's cheapest cost is added to
h and subtracted from the cut's achievers. Rounds stop when the goal's h_max is
zero. Admissible (not consistent: A* must reopen, see levels.CostLevels).
"""
from __future__ import annotations

import numpy as np

from .errors import DomainError
from .heuristics import INF, INF_64, HMax

CHUNK = 1024        # states per numpy pass: keeps the (states, achievers) arrays in cache


class LMCut:
    """Batched LM-cut of a DNF goal: `lmcut(batch, goal) -> (N,) int64`, INF_64 for dead ends."""

    def __init__(self, model, bm, hmax: HMax | None = None):
        """`hmax`: the HMax of the same model that callers such as optimal_plan keep beside it."""
        self.bm = bm
        self.hmax = hmax or HMax(model, bm)
        n = model.n_atoms
        self.n_literals = 2 * n
        # (precondition literals, operator, reached literal). Costs belong to operators,
        # not achievers: an action reaching two literals is paid once, and a cut
        # lowers its cost for all its effects (else LM-cut would count it twice).
        self._achievers = []
        self._op_cost = []
        for op, a in zip(model.ops, model.op_action):
            o = len(self._op_cost)
            self._op_cost.append(model.action_cost[a])
            pre = _bits(op.pos) + [n + i for i in _bits(op.neg)]
            self._add(pre, o, op.add, op.dele, n)
            for cp, cn, ca, cd in op.cond:
                self._add(pre + _bits(cp) + [n + i for i in _bits(cn)], o, ca, cd, n)
        self._by_effect: dict[int, list] = {}
        for i, (_, _, lit) in enumerate(self._achievers):
            self._by_effect.setdefault(lit, []).append(i)
        self._tables: dict = {}

    def _add(self, pre, op, add, dele, n) -> None:
        for atom in _bits(add):
            self._achievers.append((pre, op, atom))
        for atom in _bits(dele & ~add):           # add wins over delete
            self._achievers.append((pre, op, n + atom))

    # ---- tables ------------------------------------------------------------
    def tables(self, goal: list[list[int]]):
        """Compact achiever tables for the literals a goal can depend on (cached per goal).

        Columns: the relevant literals, then TRUE (always reached, pads short
        preconditions), then the goal literal. Achievers are sorted by effect.
        """
        key = tuple(tuple(c) for c in goal)
        if key in self._tables:
            return self._tables[key]
        for conj in goal:
            for lit in conj:
                if not 0 <= lit < self.n_literals:
                    raise DomainError("goal", f"literal {lit} is outside 0..{self.n_literals - 1}")
        relevant = {lit for conj in goal for lit in conj}
        frontier = list(relevant)
        while frontier:
            for i in self._by_effect.get(frontier.pop(), []):
                for p in self._achievers[i][0]:
                    if p not in relevant:
                        relevant.add(p)
                        frontier.append(p)
        lits = sorted(relevant)
        col = {lit: j for j, lit in enumerate(lits)}
        true_col, goal_col = len(lits), len(lits) + 1
        rows = [(self._achievers[i][0], self._achievers[i][1], lit) for lit in lits
                for i in self._by_effect.get(lit, [])]
        ops = sorted({o for _, o, _ in rows})
        op_col = {o: j for j, o in enumerate(ops)}
        rows = [(p, op_col[o], lit) for p, o, lit in rows]
        rows += [(conj, len(ops) + j, None) for j, conj in enumerate(goal)]   # zero-cost goal operators
        op_cost = np.array([self._op_cost[o] for o in ops] + [0] * len(goal), dtype=np.int32)
        width = max((len(p) for p, _, _ in rows), default=1) or 1
        pre = np.full((len(rows), width), true_col, dtype=np.int64)
        eff = np.empty(len(rows), dtype=np.int64)
        owner = np.empty(len(rows), dtype=np.int64)
        for r, (p, o, lit) in enumerate(rows):
            pre[r, : len(p)] = [col[q] for q in p]
            eff[r] = goal_col if lit is None else col[lit]
            owner[r] = o
        # Effects are ascending (goal last): reduceat over contiguous runs of one effect.
        targets, starts = np.unique(eff, return_index=True)
        self._tables[key] = (np.array(lits, dtype=np.int64), pre, eff, owner, op_cost, targets, starts)
        return self._tables[key]

    # ---- the heuristic -----------------------------------------------------
    def __call__(self, batch: np.ndarray, goal: list[list[int]]) -> np.ndarray:
        """(N,) LM-cut value of each state for a DNF goal of literal lists (INF_64: dead end)."""
        out = np.zeros(len(batch), dtype=np.int64)
        if not len(batch):
            return out
        tables = self.tables(goal)
        for lo in range(0, len(batch), CHUNK):
            out[lo: lo + CHUNK] = self._chunk(batch[lo: lo + CHUNK], tables)
        return out

    def _initial(self, batch, lits) -> np.ndarray:
        """(columns, N) bool: which literals hold in each state (TRUE yes, goal no)."""
        bits = self.bm.to_bits(batch).astype(bool).T
        half = self.n_literals // 2
        holds = np.zeros((len(lits) + 2, len(batch)), dtype=bool)
        pos = lits < half
        holds[: len(lits)][pos] = bits[lits[pos]]
        holds[: len(lits)][~pos] = ~bits[lits[~pos] - half]
        holds[len(lits)] = True
        return holds

    def _chunk(self, batch, tables) -> np.ndarray:
        # Arrays are (literals, achievers or operators; states): every gather copies whole rows.
        lits, pre, eff, owner, base, targets, starts = tables
        goal_col = len(lits) + 1
        holds = self._initial(batch, lits)
        n = len(batch)
        h = np.zeros(n, dtype=np.int64)
        op_cost = np.repeat(base[:, None], n, axis=1)
        hm = np.where(holds, 0, INF).astype(np.int32)
        wide = _width_groups(pre, len(lits))
        live = np.arange(n)
        while len(live):
            cost = op_cost[owner]
            hm = _hmax_fixpoint(hm, cost, pre, wide, targets, starts)
            g = hm[goal_col]
            dead = g >= INF
            h[live[dead]] = INF_64
            keep = ~dead & (g > 0)
            if not keep.all():
                live, hm, holds = live[keep], hm[:, keep], holds[:, keep]
                op_cost, cost = op_cost[:, keep], cost[:, keep]
                if not len(live):
                    break
            cut = _cut(hm, cost, holds, pre, wide, eff, goal_col)
            k = len(live)
            in_cut = np.zeros(op_cost.shape, dtype=bool)
            in_cut.reshape(-1)[(owner[:, None] * k + np.arange(k))[cut]] = True
            m = np.where(in_cut, op_cost, INF).min(0)
            h[live] += m
            op_cost -= np.where(in_cut, m[None, :], 0).astype(np.int32)
        return h


def _width_groups(pre, pad: int) -> list:
    """[(achievers with a j-th precondition, those preconditions' columns)] for j >= 1."""
    out = []
    for j in range(1, pre.shape[1]):
        sel = np.flatnonzero(pre[:, j] != pad)
        if len(sel):
            out.append((sel, pre[sel, j]))
    return out


def _hmax_fixpoint(hm, cost, pre, wide, targets, starts) -> np.ndarray:
    """h_max of every literal under per-state achiever costs, from an upper bound `hm`.

    Costs only ever drop between LM-cut rounds, so the previous round's values
    bound the new ones from above and the iteration resumes from them.
    """
    while True:
        via = _max_pre(hm, pre, wide)
        via += cost
        best = np.minimum(np.minimum.reduceat(via, starts, axis=0), INF)
        old = hm[targets]
        new = np.minimum(old, best)
        if (new == old).all():
            return hm
        hm[targets] = new


def _max_pre(hm, pre, wide) -> np.ndarray:
    """(achievers, N): the h_max of each achiever's costliest precondition."""
    via = hm[pre[:, 0]]
    for sel, col in wide:
        via[sel] = np.maximum(via[sel], hm[col])
    return via


def _cut(hm, cost, holds, pre, wide, eff, goal_col) -> np.ndarray:
    """(achievers, N) bool: the landmark of this round, per state."""
    n = hm.shape[1]
    pcf = np.repeat(pre[:, :1], n, axis=1)                 # (achievers, N) column of the costliest
    best = hm[pre[:, 0]]
    for sel, col in wide:
        v = hm[col]
        better = v > best[sel]
        best[sel] = np.where(better, v, best[sel])
        pcf[sel] = np.where(better, col[:, None], pcf[sel])
    flat_pcf = pcf * n + np.arange(n)
    flat_eff = eff[:, None] * n + np.arange(n)
    zero = cost == 0
    zone = np.zeros(hm.shape, dtype=bool)
    zone[goal_col] = True
    z = zone.reshape(-1)
    while True:                              # backwards through zero-cost achievers
        grow = z[flat_eff] & zero & ~z[flat_pcf]
        if not grow.any():
            break
        z[flat_pcf[grow]] = True
    reach = holds.copy()
    r = reach.reshape(-1)
    outside = ~z[flat_eff]
    while True:                              # forwards from the state, never into the zone
        grow = r[flat_pcf] & outside & ~r[flat_eff]
        if not grow.any():
            break
        r[flat_eff[grow]] = True
    return r[flat_pcf] & ~outside


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]
