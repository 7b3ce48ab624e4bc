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


class ClosedStates:
    """The states a search has closed, with the g of their last closing; keys sorted, rows checked."""

    def __init__(self, n_words: int):
        self.keys = np.zeros(0, dtype=np.uint64)
        self.rows = np.zeros((0, n_words), dtype=np.uint64)
        self.g = np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.keys)

    def closed_mask(self, keys, rows, g) -> np.ndarray:
        """(N,) bool: which states (sorted unique keys) are closed already at a g no larger."""
        if not len(self.keys):
            return np.zeros(len(keys), dtype=bool)
        pos = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        hit = self.keys[pos] == keys
        if (self.rows[pos[hit]] != rows[hit]).any():
            raise StateKeyCollision("a new state shares its key with a closed one")
        return hit & (self.g[pos] <= g)

    def close(self, keys, rows, g) -> int:
        """Close states (sorted unique keys, none closed at a g as small); how many were reopened."""
        pos = np.searchsorted(self.keys, keys)     # keys are sorted: the merge stays sorted
        known = np.zeros(len(keys), dtype=bool)
        if len(self.keys):
            inside = pos < len(self.keys)
            known[inside] = self.keys[pos[inside]] == keys[inside]
        self.g[pos[known]] = g[known]              # reopened: a smaller g than before
        new = ~known
        self.keys = np.insert(self.keys, pos[new], keys[new])
        self.rows = np.insert(self.rows, pos[new], rows[new], axis=0)
        self.g = np.insert(self.g, pos[new], g[new])
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
        self.deadline = None if time_limit is None else time.perf_counter() + time_limit
        self.closed = 0
        self.f = 0                      # the level being closed: a lower bound on any goal's cost
        self.reopened = 0               # closings of a state already closed at a larger g
        self.exhausted = False          # True when every reachable state was closed
        self._closed = ClosedStates(bm.n_words)
        # h of every state evaluated so far: an open state is generated again and
        # again from different parents, and a strong heuristic is the dear part.
        self._h_keys = np.zeros(0, dtype=np.uint64)
        self._h_rows = np.zeros((0, bm.n_words), dtype=np.uint64)
        self._h_vals = np.zeros(0, dtype=np.int64)
        self._parents: list[np.ndarray] = []
        self._actions: list[np.ndarray] = []
        start_row = bm.pack([start])
        f0 = 0 if heuristic is None else int(heuristic(start_row)[0])
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
        """h of states with sorted unique keys, computed only for those never seen before."""
        h = np.empty(len(keys), dtype=np.int64)
        known = np.zeros(len(keys), dtype=bool)
        if len(self._h_keys):
            pos = np.minimum(np.searchsorted(self._h_keys, keys), len(self._h_keys) - 1)
            known = self._h_keys[pos] == keys
            if (self._h_rows[pos[known]] != rows[known]).any():
                raise StateKeyCollision("an evaluated state shares its key with another")
            h[known] = self._h_vals[pos[known]]
        new = ~known
        if new.any():
            h[new] = self.h(rows[new])
            pos = np.searchsorted(self._h_keys, keys[new])
            self._h_keys = np.insert(self._h_keys, pos, keys[new])
            self._h_rows = np.insert(self._h_rows, pos, rows[new], axis=0)
            self._h_vals = np.insert(self._h_vals, pos, h[new])
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
