"""LM-cut of a window's stage-layered delete relaxation: the window search's "layered" heuristic.

Per stage, LM-cut of the current task alone sees one water task where a
window holds two; the layered relaxation of the stages left sees that the
first cup's water is consumed, so the second needs water again, while a filled
jar carries over (`layered_relaxation`).
"""

from __future__ import annotations

import numpy as np

from planning.heuristics.lmcut import LMCut, Relaxed, compile_relaxed


class LayeredLMCut:
    """h(batch, goals): LM-cut of the stage-layered relaxation of the window's stages left (goals[0] current)."""

    def __init__(self, model, bm):
        self.lmcut = LMCut(model, bm)
        self.n = model.n_atoms
        self._relaxed: dict = {}

    def relaxation(self, tasks: list) -> Relaxed:
        """The stage-layered relaxation of a window's tasks, the first current (cached)."""
        key = tuple(t.index for t in tasks)
        if key not in self._relaxed:
            self._relaxed[key] = layered_relaxation(self.lmcut, self.n, tasks)
        return self._relaxed[key]

    def __call__(self, batch: np.ndarray, goals: list) -> np.ndarray:
        return self.lmcut.of_relaxed(batch, self.relaxation(goals))


def build(bm, search: str) -> LayeredLMCut:
    """The registry's builder (planning.heuristics); the window search is the one it serves."""
    return LayeredLMCut(bm.model, bm)


def layered_relaxation(lmcut: LMCut, n: int, tasks: list) -> Relaxed:
    """The stage-layered delete relaxation of a window's tasks (stages 0..K-1, 0 current), compiled for LM-cut.

    Literal p@k (key (k, p)) holds at some time during stage k; every action has
    a copy per stage. Stage k's completion needs its goal @k (and stage k-1
    done) and adds done@k; its consumption's effects hold @k+1. A literal
    carries over from @k to @k+1 unless the consumption may delete it: then it
    carries over only next to the goal of a binding that keeps it (that binding
    fired, so its goal held) and, if one binding before it deletes the literal,
    the negation of one literal of that binding's goal (it did not fire).
    Every real plan of the window maps to a relaxed plan: admissible.
    """
    K = len(tasks)
    neg = lambda lit: lit + n if lit < n else lit - n
    lits = lambda mask, offset=0: [i + offset for i in range(mask.bit_length()) if mask >> i & 1]
    conj = lambda op: lits(op.pos) + lits(op.neg, n)
    base = lmcut.achievers()
    rows, costs = [], {}
    for k in range(K):
        done_before = [("done", k - 1)] if k > 0 else []
        for pre, o, e in base:
            rows.append(([(k, p) for p in pre], (k, o), (k, e)))
        for o, c in enumerate(lmcut.operator_costs()):
            costs[(k, o)] = c
        bindings = tasks[k].bindings
        for b, op in enumerate(bindings):
            name = ("complete", k, b)
            costs[name] = 0
            pre = [(k, q) for q in conj(op)] + done_before
            rows.append((pre, name, ("done", k)))
            if k + 1 == K:
                continue
            for e in lits(op.add) + lits(op.dele & ~op.add, n):
                rows.append((pre, name, (k + 1, e)))
            for cp, cn, ca, cd in op.cond:
                cpre = pre + [(k, q) for q in lits(cp) + lits(cn, n)]
                for e in lits(ca) + lits(cd & ~ca, n):
                    rows.append((cpre, name, (k + 1, e)))
        if k + 1 == K:
            continue
        # Which bindings' consumption may remove a literal: unconditionally or under a condition.
        kills = [dict() for _ in bindings]
        for b, op in enumerate(bindings):
            for e in lits(op.dele & ~op.add) + lits(op.add, n):
                kills[b][e] = None
            for cp, cn, ca, cd in op.cond:
                for e in lits(cd & ~ca) + lits(ca, n):
                    kills[b].setdefault(e, lits(cp) + lits(cn, n) or None)
        for p in range(2 * n):
            name = ("carry", k, p)
            costs[name] = 0
            keep = [(k, p), ("done", k)]
            if not any(p in kb for kb in kills):
                rows.append((keep, name, (k + 1, p)))
                continue
            for f, op in enumerate(bindings):
                cond = kills[f].get(p, [])
                if cond is None:
                    continue  # f fired: p is gone
                pre = keep + [(k, q) for q in conj(op)]
                earlier = [b for b in range(f) if kills[b].get(p, 0) is None]
                options = [[]]
                if len(earlier) == 1:  # that binding did not fire: one of its literals failed
                    options = [[(k, neg(q))] for q in conj(bindings[earlier[0]])] or [[]]
                if cond:  # f fired but its conditional delete did not
                    options = [o + [(k, neg(x))] for o in options for x in cond]
                for extra in options:
                    rows.append((pre + extra, name, (k + 1, p)))
    return compile_relaxed(rows, costs, ("done", K - 1), {(0, p): p for p in range(2 * n)})
