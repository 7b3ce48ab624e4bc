"""Dijkstra by cost levels on the batched model: every state of one g expanded in one numpy call.

States are closed in order of increasing g, level by level; a state is closed at
its optimal cost, the first time it appears. Duplicate detection is exact: states
are keyed by a 64-bit mix of their words for fast sorting, and every key match
is checked against the stored state (a true collision raises, never misleads).
This is what makes exact optimal planning cheap in Python: the per-state work
happens inside numpy, at millions of transitions per second.
"""
from __future__ import annotations

import heapq
import time

import numpy as np

from .heuristics import INF_64 as INF

_MIX = np.uint64(0x9E3779B97F4A7C15)


def state_keys(batch: np.ndarray) -> np.ndarray:
    """(N,) uint64 keys of packed states; the state itself when it fits one word."""
    if batch.shape[1] == 1:
        return batch[:, 0].copy()
    h = np.zeros(batch.shape[0], dtype=np.uint64)
    with np.errstate(over="ignore"):
        for w in range(batch.shape[1]):
            h = (h ^ batch[:, w]) * _MIX
            h ^= h >> np.uint64(29)
    return h


class StateKeyCollision(RuntimeError):
    """Two distinct states share a 64-bit key (about 1 in 10^7 for 10^6 states); never ignored."""


def cheapest_unique(rows: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(indices, sorted keys): one row per distinct state, the one of smallest g (key collisions raise)."""
    keys = state_keys(rows)
    order = np.lexsort((g, keys))
    keys = keys[order]
    first = np.ones(len(keys), dtype=bool)
    first[1:] = keys[1:] != keys[:-1]
    pick = order[first]
    if len(pick) < len(rows):
        back = np.cumsum(first) - 1              # each sorted row's kept representative
        if (rows[pick][back] != rows[order]).any():
            raise StateKeyCollision("two states of one batch share a key")
    return pick, keys[first]


class StateTable:
    """Packed states with an int64 value each, in sorted runs of keys (a log-structured merge).

    A search adds states level by level; one sorted array would copy everything at
    every level (np.insert), quadratic in the states closed. Here each add is a new
    sorted run, merged with the runs before it while they are no more than twice its
    size, so there are O(log n) runs and every state is merged O(log n) times.
    Lookups search each run; a key match is checked against the stored row."""

    def __init__(self, n_words: int):
        self.n_words = n_words
        self.runs: list[list[np.ndarray]] = []      # [keys (sorted), rows, values]

    def __len__(self) -> int:
        return sum(len(r[0]) for r in self.runs)

    def find(self, keys: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(run, position) of each state; run -1 for one not in the table."""
        run = np.full(len(keys), -1, dtype=np.int64)
        pos = np.zeros(len(keys), dtype=np.int64)
        for r, (k, stored, _) in enumerate(self.runs):
            p = np.minimum(np.searchsorted(k, keys), len(k) - 1)
            hit = np.flatnonzero(k[p] == keys)
            if (stored[p[hit]] != rows[hit]).any():
                raise StateKeyCollision("a state shares its key with a stored one")
            run[hit], pos[hit] = r, p[hit]
        return run, pos

    def get(self, run: np.ndarray, pos: np.ndarray, default: int = 0) -> np.ndarray:
        """The values at find's (run, position); `default` where run is -1."""
        out = np.full(len(run), default, dtype=np.int64)
        for r, (_, _, values) in enumerate(self.runs):
            at = run == r
            out[at] = values[pos[at]]
        return out

    def set(self, run: np.ndarray, pos: np.ndarray, values: np.ndarray) -> None:
        """Overwrite the values at find's (run, position) (run -1 is not allowed)."""
        for r, (_, _, stored) in enumerate(self.runs):
            at = run == r
            stored[pos[at]] = values[at]

    def add(self, keys: np.ndarray, rows: np.ndarray, values: np.ndarray) -> None:
        """Add states that are not in the table (distinct keys, any order)."""
        if not len(keys):
            return
        order = np.argsort(keys, kind="stable")
        run = [keys[order], rows[order], np.asarray(values, dtype=np.int64)[order]]
        while self.runs and len(self.runs[-1][0]) <= 2 * len(run[0]):
            last = self.runs.pop()
            merged = [np.concatenate((a, b)) for a, b in zip(last, run)]
            order = np.argsort(merged[0], kind="stable")
            run = [x[order] for x in merged]
        self.runs.append(run)

    def merged(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(keys, rows, values) of every state, in key order."""
        if not self.runs:
            return (np.zeros(0, dtype=np.uint64), np.zeros((0, self.n_words), dtype=np.uint64),
                    np.zeros(0, dtype=np.int64))
        keys, rows, values = (np.concatenate(x) for x in zip(*self.runs))
        order = np.argsort(keys, kind="stable")
        return keys[order], rows[order], values[order]


class ClosedStates:
    """The states a search has closed, with the g of their last closing (a StateTable)."""

    def __init__(self, n_words: int):
        self.table = StateTable(n_words)

    def __len__(self) -> int:
        return len(self.table)

    def closed_mask(self, keys, rows, g) -> np.ndarray:
        """(N,) bool: which states are closed already at a g no larger."""
        run, pos = self.table.find(keys, rows)
        return (run >= 0) & (self.table.get(run, pos) <= g)

    def close(self, keys, rows, g) -> int:
        """Close distinct states (none closed at a g as small); how many were reopened."""
        run, pos = self.table.find(keys, rows)
        known = run >= 0
        self.table.set(run[known], pos[known], g[known])        # reopened: a smaller g than before
        new = ~known
        self.table.add(keys[new], rows[new], g[new])
        return int(known.sum())


class CostLevels:
    """Iterate over (f, states, ids, g): states closed at f = g + h, level by level.

    With no heuristic this is Dijkstra (f = g) and each state is closed once, at
    its optimal g. With an admissible heuristic `h(batch) -> (N,) costs` it is A*
    with pathmax (a child's f is at least its parent's) and reopening: a closed
    state reached again with a smaller g is closed again, so an inconsistent
    heuristic such as LM-cut still gives optimal costs; with a consistent one
    nothing is ever reopened. States whose h is infinite (dead ends) are never opened.
    """

    def __init__(self, bm, start: int, max_states: int | None = None, time_limit: float | None = None,
                 heuristic=None, after_step=None):
        """`after_step(batch) -> batch` rewrites generated states (the joint search completes stages)."""
        self.bm = bm
        self.h = heuristic
        self.after_step = after_step
        self.max_states = max_states
        self.closed = 0
        self.reopened = 0               # closings of a state already closed at a larger g
        self.exhausted = False          # True when every reachable state was closed
        self._closed = ClosedStates(bm.n_words)
        # h of every state evaluated so far: an open state is generated again and
        # again from different parents, and a strong heuristic is the dear part.
        self._h_table = StateTable(bm.n_words)
        self._parents: list[np.ndarray] = []
        self._actions: list[np.ndarray] = []
        start_row = bm.pack([start])
        f0 = 0 if heuristic is None else int(heuristic(start_row)[0])
        self.f = f0                     # the level being closed: a lower bound on any goal's cost
        # The time limit bounds the search; what the heuristic builds on its first call (pattern
        # databases, kept for later searches) is done before the clock starts.
        self.deadline = None if time_limit is None else time.perf_counter() + time_limit
        self._open: dict[int, list] = {f0: [(start_row, np.array([-1]), np.array([-1]), np.array([0]))]}
        self._heap = [f0]

    def __iter__(self):
        while self._heap:
            if self.max_states is not None and self.closed >= self.max_states:
                return
            if self.deadline is not None and time.perf_counter() > self.deadline:
                return
            f = heapq.heappop(self._heap)
            if f >= INF:
                break
            self.f = f
            rows, parents, actions, g = (np.concatenate(x) for x in zip(*self._open.pop(f)))
            rows, parents, actions, g, keys = self._new_states(rows, parents, actions, g)
            if not len(rows):
                continue
            ids = np.arange(self.closed, self.closed + len(rows))
            self.closed += len(rows)
            self._parents.append(parents)
            self._actions.append(actions)
            self.reopened += self._closed.close(keys, rows, g)
            yield f, rows, ids, g
            self._expand(f, rows, ids, g)
        self.exhausted = True

    def plan_to(self, state_id: int) -> list[int]:
        """The actions from the start to a closed state."""
        parents = np.concatenate(self._parents)
        actions = np.concatenate(self._actions)
        plan = []
        while parents[state_id] >= 0:
            plan.append(int(actions[state_id]))
            state_id = int(parents[state_id])
        return plan[::-1]

    def _new_states(self, rows, parents, actions, g):
        """The rows not yet closed at a g as small, one per distinct state (its smallest g), with keys."""
        pick, keys = cheapest_unique(rows, g)
        rows, parents, actions, g = rows[pick], parents[pick], actions[pick], g[pick]
        fresh = ~self._closed.closed_mask(keys, rows, g)
        return rows[fresh], parents[fresh], actions[fresh], g[fresh], keys[fresh]

    def _cached_h(self, keys, rows) -> np.ndarray:
        """h of distinct states, computed only for those never seen before."""
        run, pos = self._h_table.find(keys, rows)
        h = self._h_table.get(run, pos)
        new = run < 0
        if new.any():
            h[new] = self.h(rows[new])
            self._h_table.add(keys[new], rows[new], h[new])
        return h

    def _expand(self, f_parent, rows, ids, g) -> None:
        parent, action, child, cost = self.bm.successors(rows)
        if not len(child):
            return
        if self.after_step is not None:
            child = self.after_step(child)
        # One copy of each child, the one of smallest g; sorted keys make the closed lookup sequential.
        g_child = g[parent] + cost
        order, keys = cheapest_unique(child, g_child)
        parent, action, child, g_child = parent[order], action[order], child[order], g_child[order]
        keep = ~self._closed.closed_mask(keys, child, g_child)
        parent, action, child, g_child = parent[keep], action[keep], child[keep], g_child[keep]
        if self.h is None:
            f_child = g_child
        else:                                      # pathmax: h may be inconsistent (LM-cut)
            h = self._cached_h(keys[keep], child)
            f_child = np.where(h >= INF, INF, np.maximum(g_child + h, f_parent))
        for f in np.unique(f_child):
            if f >= INF:
                continue
            sel = f_child == f
            level = int(f)
            if level not in self._open:
                self._open[level] = []
                heapq.heappush(self._heap, level)
            self._open[level].append((child[sel], ids[parent[sel]], action[sel], g_child[sel]))


def goal_arrays(bm, task) -> tuple[np.ndarray, np.ndarray]:
    """(pos, neg) as (K, W) word arrays: the task goal's K conjunctions."""
    return bm.pack([o.pos for o in task.bindings]), bm.pack([o.neg for o in task.bindings])


def satisfied(rows: np.ndarray, pos: np.ndarray, neg: np.ndarray) -> np.ndarray:
    """(N,) bool: which packed states satisfy a DNF goal given as (K, W) arrays."""
    s = rows[:, None, :]
    return (((s & pos[None]) == pos[None]).all(-1) & ((s & neg[None]) == 0).all(-1)).any(-1)
