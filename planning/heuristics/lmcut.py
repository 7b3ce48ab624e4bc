"""LM-cut (Helmert & Domshlak 2009), computed for a whole batch of states at once in numpy.

The same positive normal form as HMax: literal i < n is atom i, literal n + i is
(not atom i), a conditional effect is an achiever whose precondition includes
its condition, and a DNF goal is an artificial goal literal with one zero-cost
achiever per conjunction. Each round of LM-cut, for every state of the batch:
h_max under the state's current achiever costs, the precondition-choice
function (the costliest precondition of each achiever), the goal zone (literals
that reach the goal literal through zero-cost achievers, backwards), the
literals reachable from the state without entering the zone, and the cut (the
achievers that enter the zone from there). The cut's cheapest operator cost is
added to h and subtracted from the cut's operators (costs belong to operators:
an action reaching two literals is paid once). Rounds stop when the goal's
h_max is zero. Admissible, not consistent: A* must reopen, see levels.CostLevels.

`compile_relaxed` turns any delete-relaxed task into arrays, so the same code
serves the joint search's stage-layered relaxation. planning/heuristics/_lmcut.c computes
the same values one state at a time, 5-10x faster; it is built on first use
with the system C compiler, and the numpy version runs where there is none.
"""

from __future__ import annotations

import ctypes
from pathlib import Path
from typing import NamedTuple

import numpy as np

from planning.errors import DomainError
from planning.heuristics.hmax import INF, GoalLiterals, HMax, relaxed_view
from planning.native import load
from planning.states import INF_64

CHUNK = 512  # states per numpy pass: keeps the (achievers, states) arrays in cache


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
        for atom in _bits(dele & ~add):  # add wins over delete
            self._achievers.append((pre, op, n + atom))

    def achievers(self) -> list:
        """[(precondition literals, operator, reached literal)] of the model's normal form."""
        return list(self._achievers)

    def operator_costs(self) -> list:
        """The cost of each operator (a variant of a ground action) of achievers()."""
        return list(self._op_cost)

    # ---- tables ------------------------------------------------------------
    def tables(self, goal: list[list[int]]) -> "Relaxed":
        """The relaxed task of a DNF goal, restricted to what it can depend on (cached per goal)."""
        key = tuple(tuple(c) for c in goal)
        if key in self._tables:
            return self._tables[key]
        for conj in goal:
            for lit in conj:
                if not 0 <= lit < self.n_literals:
                    raise DomainError("goal", f"literal {lit} is outside 0..{self.n_literals - 1}")
        rows = list(self._achievers) + [(conj, ("goal", j), "goal") for j, conj in enumerate(goal)]
        costs = dict(enumerate(self._op_cost))
        costs.update({("goal", j): 0 for j in range(len(goal))})
        self._tables[key] = compile_relaxed(rows, costs, "goal", {lit: lit for lit in range(self.n_literals)})
        return self._tables[key]

    # ---- the heuristic -----------------------------------------------------
    def __call__(self, batch: np.ndarray, goal: list[list[int]]) -> np.ndarray:
        """(N,) LM-cut value of each state for a DNF goal of literal lists (INF_64: dead end)."""
        return self.of_relaxed(batch, self.tables(goal))

    def of_relaxed(self, batch: np.ndarray, task: "Relaxed") -> np.ndarray:
        """(N,) LM-cut of a compiled relaxed task whose state literals mirror each state's."""
        out = np.zeros(len(batch), dtype=np.int64)
        lib = native()
        for lo in range(0, len(batch), CHUNK):
            holds = task.holds(self.bm.to_bits(batch[lo : lo + CHUNK]).astype(bool).T)
            if lib is None:
                out[lo : lo + CHUNK] = lmcut_values(holds, task)
                continue
            out[lo : lo + CHUNK] = _native_batch(lib, task, holds)[0]
        return out

    def landmarks(self, batch: np.ndarray, task: "Relaxed") -> tuple[np.ndarray, list]:
        """LM-cut of each state and its cuts: (N,) values, [[operator indices of task] per cut] per state.

        Every relaxed plan from the state uses an operator of every cut (the
        landmarks operator counting constrains). Needs the compiled LM-cut.
        """
        lib = native()
        if lib is None:
            raise DomainError("LM-cut", "landmarks need the compiled LM-cut (a C compiler, LMCUT_NATIVE=1)")
        holds = task.holds(self.bm.to_bits(batch).astype(bool).T)
        h, flat = _native_batch(lib, task, holds, landmarks=True)
        cuts = [[] for _ in range(len(batch))]
        i = 0
        while i < len(flat):
            s, k = int(flat[i]), int(flat[i + 1])
            cuts[s].append(flat[i + 2 : i + 2 + k])
            i += 2 + k
        return h, cuts


def build(bm, search: str):
    """The registry's builder (planning.heuristics): LM-cut, on the model's relaxed_view, of the goals' DNF
    (task and multi-goal searches: the nearest goal) or of the current stage (window)."""
    h, literals = LMCut(relaxed_view(bm.model), bm), GoalLiterals(bm.model)
    if search == "window":
        return lambda batch, goals: h(batch, literals(goals[:1]))
    return lambda batch, goals: h(batch, literals(goals))


def _native_batch(lib, task: "Relaxed", holds: np.ndarray, landmarks: bool = False):
    """The compiled LM-cut of states given their initial literals (columns, N): values and the flat cut record."""
    rows = np.ascontiguousarray(holds.T, dtype=np.uint8)
    out = np.zeros(len(rows), dtype=np.int64)
    cap = 64 * len(task.op_cost) * len(rows) if landmarks else 0
    while True:
        cuts = np.zeros(cap, dtype=np.int64)
        used = np.zeros(1, dtype=np.int64)
        status = lib.lmcut_batch(
            len(rows),
            task.n_cols,
            len(task.eff),
            len(task.op_cost),
            task.pre.shape[1],
            task.pre,
            task.pre_of_start,
            task.pre_of,
            task.n_pre,
            task.eff,
            task.owner,
            task.eff_start,
            task.op_cost,
            task.op_start,
            task.op_ach,
            task.goal_col,
            rows,
            out,
            cuts.ctypes.data if landmarks else None,
            cap,
            used.ctypes.data if landmarks else None,
        )
        if status == -2:
            cap *= 4
            continue
        if status != 0:
            raise MemoryError("LM-cut: out of memory")
        return out, cuts[: used[0]]


_NATIVE = None


def native():
    """The compiled LM-cut (planning/heuristics/_lmcut.c, built once per source version), or None.

    None when LMCUT_NATIVE=0 or no C compiler works: the numpy version then
    computes the same heuristic, several times slower.
    """
    global _NATIVE
    if _NATIVE is None:
        _NATIVE = _load_native() or False
    return _NATIVE or None


def _load_native():
    so = load(Path(__file__).with_name("_lmcut.c"), "LMCUT_NATIVE")
    if so is None:
        return None
    i64 = np.ctypeslib.ndpointer(np.int64, flags="C_CONTIGUOUS")
    i32 = np.ctypeslib.ndpointer(np.int32, flags="C_CONTIGUOUS")
    u8 = np.ctypeslib.ndpointer(np.uint8, flags="C_CONTIGUOUS")
    n = ctypes.c_int64
    so.lmcut_batch.restype = ctypes.c_int
    so.lmcut_batch.argtypes = [
        n,
        n,
        n,
        n,
        n,
        i64,
        i64,
        i64,
        i32,
        i64,
        i64,
        i64,
        i32,
        i64,
        i64,
        n,
        u8,
        i64,
        ctypes.c_void_p,
        n,
        ctypes.c_void_p,
    ]
    return so


class Relaxed(NamedTuple):
    """A delete-relaxed task as arrays: columns are literals, then TRUE; achievers sorted by effect."""

    pre: np.ndarray  # (achievers, width) precondition columns, padded with TRUE
    eff: np.ndarray  # (achievers,) reached column
    owner: np.ndarray  # (achievers,) operator
    op_cost: np.ndarray  # (operators,) int32
    targets: np.ndarray  # columns with achievers, ascending
    starts: np.ndarray  # first achiever of each target
    wide: list  # _width_groups(pre)
    goal_col: int
    state_cols: np.ndarray  # columns that mirror a literal of the state ...
    state_lits: np.ndarray  # ... that literal (n + i: not atom i)
    n_cols: int
    keys: list  # the key of each column but TRUE
    pre_of_start: np.ndarray  # CSR, column -> the achievers it is a precondition of (TRUE for none) ...
    pre_of: np.ndarray  # ... with multiplicity
    n_pre: np.ndarray  # (achievers,) int32 precondition count
    eff_start: np.ndarray  # (columns + 1,) the achievers of column c are eff_start[c]:eff_start[c + 1]
    op_start: np.ndarray  # CSR, operator -> ...
    op_ach: np.ndarray  # ... its achievers
    op_keys: list  # the operator behind each operator index

    def holds(self, bits: np.ndarray) -> np.ndarray:
        """(columns, N) bool: the initial literals, from (atoms, N) state bits."""
        n = bits.shape[0]
        out = np.zeros((self.n_cols, bits.shape[1]), dtype=bool)
        pos = self.state_lits < n
        out[self.state_cols[pos]] = bits[self.state_lits[pos]]
        out[self.state_cols[~pos]] = ~bits[self.state_lits[~pos] - n]
        out[self.n_cols - 1] = True
        return out


def compile_relaxed(achievers: list, costs: dict, goal, initial: dict) -> Relaxed:
    """Arrays of a relaxed task: achievers [(precondition keys, operator, reached key)], operator
    costs {operator: cost}, the goal key, and {key: state literal} for the keys a state sets.

    Keys are any hashable names of relaxed literals. Only what the goal can
    depend on is kept (backwards over achievers from the goal).
    """
    by_eff: dict = {}
    for i, (_, _, e) in enumerate(achievers):
        by_eff.setdefault(e, []).append(i)
    relevant, frontier = {goal}, [goal]
    while frontier:
        for i in by_eff.get(frontier.pop(), []):
            for p in achievers[i][0]:
                if p not in relevant:
                    relevant.add(p)
                    frontier.append(p)
    keys = [k for k in initial if k in relevant] + [k for k in relevant if k not in initial]
    col = {k: j for j, k in enumerate(keys)}
    true_col = len(keys)
    rows = sorted((col[e], i) for e in keys for i in by_eff.get(e, []))
    ops = sorted({achievers[i][1] for _, i in rows}, key=repr)
    op_col = {o: j for j, o in enumerate(ops)}
    width = max((len(achievers[i][0]) for _, i in rows), default=1) or 1
    pre = np.full((len(rows), width), true_col, dtype=np.int64)
    eff = np.empty(len(rows), dtype=np.int64)
    owner = np.empty(len(rows), dtype=np.int64)
    for r, (c, i) in enumerate(rows):
        p, o, _ = achievers[i]
        pre[r, : len(p)] = [col[q] for q in p]
        eff[r], owner[r] = c, op_col[o]
    targets, starts = np.unique(eff, return_index=True)
    state = [(col[k], lit) for k, lit in initial.items() if k in col]
    entries = sorted((c, a) for a in range(len(rows)) for c in ([q for q in pre[a] if q != true_col] or [true_col]))
    pre_of = np.array([a for _, a in entries], dtype=np.int64)
    pre_of_start = np.searchsorted(np.array([c for c, _ in entries], dtype=np.int64), np.arange(true_col + 2))
    n_pre = np.bincount(pre_of, minlength=len(rows)).astype(np.int32)
    return Relaxed(
        pre,
        eff,
        owner,
        np.array([costs[o] for o in ops], dtype=np.int32),
        targets,
        starts,
        _width_groups(pre, true_col),
        col[goal],
        np.array([c for c, _ in state], dtype=np.int64),
        np.array([l for _, l in state], dtype=np.int64),
        true_col + 1,
        keys,
        pre_of_start.astype(np.int64),
        pre_of,
        n_pre,
        np.searchsorted(eff, np.arange(true_col + 2)).astype(np.int64),
        np.searchsorted(owner[np.argsort(owner, kind="stable")], np.arange(len(ops) + 1)).astype(np.int64),
        np.argsort(owner, kind="stable").astype(np.int64),
        ops,
    )


def lmcut_values(holds: np.ndarray, task: Relaxed) -> np.ndarray:
    """(N,) LM-cut of each state given its initial literals (columns, N); INF_64 for dead ends."""
    # Arrays are (literals, achievers or operators; states): every gather copies whole rows.
    pre, eff, owner, wide, goal_col = task.pre, task.eff, task.owner, task.wide, task.goal_col
    n = holds.shape[1]
    h = np.zeros(n, dtype=np.int64)
    op_cost = np.repeat(task.op_cost[:, None], n, axis=1)
    hm = np.where(holds, 0, INF).astype(np.int32)
    live = np.arange(n)
    while len(live):
        cost = op_cost[owner]
        hm = _hmax_fixpoint(hm, cost, pre, wide, task.targets, task.starts)
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
    pcf = np.repeat(pre[:, :1], n, axis=1)  # (achievers, N) column of the costliest
    best = hm[pre[:, 0]]
    for sel, col in wide:
        v = hm[col]
        better = v > best[sel]
        best[sel] = np.where(better, v, best[sel])
        pcf[sel] = np.where(better, col[:, None], pcf[sel])
    flat_pcf = pcf * n + np.arange(n)
    zero = cost == 0
    zone = np.zeros(hm.shape, dtype=bool)
    zone[goal_col] = True
    z = zone.reshape(-1)
    while True:  # backwards through zero-cost achievers
        grow = zone[eff] & zero & ~z[flat_pcf]
        if not grow.any():
            break
        z[flat_pcf[grow]] = True
    into = zone[eff]
    reach = holds.copy()
    r = reach.reshape(-1)
    flat_eff = eff[:, None] * n + np.arange(n)
    while True:  # forwards from the state, never into the zone
        grow = r[flat_pcf] & ~into & ~reach[eff]
        if not grow.any():
            break
        r[flat_eff[grow]] = True
    return r[flat_pcf] & into


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]
