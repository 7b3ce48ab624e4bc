"""A* by cost levels on the batched model: every state of one f expanded in one numpy call.

States are closed in order of increasing f = g + h, level by level; with no
heuristic this is Dijkstra and a state is closed at its optimal cost, the first
time it appears. Duplicate detection is exact (`planning.states`).
This is what makes exact optimal planning cheap in Python: the per-state work
happens inside numpy, at millions of transitions per second.

A time limit is honoured within about a second, also inside a level: under a
limit a large level's successors are generated in chunks (sorted back into the
order one call gives, so the search is the same) and its children scored in
growing chunks, with the clock read between chunks. With `tie_break` the states
of one f are closed lower h first (f - g, pathmax included), and within one h
the states generated last first, as Fast Downward breaks ties: on a task where h
is nearly exact (unit costs, a goal reached along a path of constant f) A* then
walks that path instead of closing the whole level breadth first. To stay
batched, each visit of an (f, h) bucket closes twice as many of its states as
the visit before (1, 2, 4, ...): a dive that fails costs O(log n) visits.
"""

from __future__ import annotations

import heapq
import time

import numpy as np

from planning.states import INF_64 as INF
from planning.states import ClosedStates, StateTable, cheapest_unique

SUCCESSOR_CHUNK = 8192  # parents per successor call of a level under a time limit
H_CHUNK = 256  # states in the first heuristic call under a time limit (doubled while cheap)
H_CHEAP = 0.05  # seconds: a heuristic call faster than this doubles the next chunk
TIE_FIRST = 1  # with tie_break: states closed on the first visit of an (f, h) bucket (then 2, 4, ...)


class _OutOfTime(Exception):
    """The deadline passed inside a level."""


class CostLevels:
    """Iterate over (f, states, ids, g): states closed at f = g + h, level by level.

    With no heuristic this is Dijkstra (f = g) and each state is closed once, at
    its optimal g. With an admissible heuristic `h(batch) -> (N,) costs` it is A*
    with pathmax (a child's f is at least its parent's) and reopening: a closed
    state reached again with a smaller g is closed again, so an inconsistent
    heuristic such as LM-cut still gives optimal costs; with a consistent one
    nothing is ever reopened. States whose h is infinite (dead ends) are never opened.
    """

    def __init__(
        self,
        bm,
        start: int,
        max_states: int | None = None,
        time_limit: float | None = None,
        heuristic=None,
        after_step=None,
        tie_break: bool = False,
        building=None,
    ):
        """`after_step(batch) -> batch` rewrites generated states (the joint search completes stages);
        `tie_break`: within an f, lower h first (each yield then holds one f and one h); `building() -> s`:
        the seconds the heuristic has spent building its tables so far, which the time limit does not count
        (a window's later stages build their pattern databases when the search first reaches them)."""
        self.bm = bm
        self._building = building
        self.h = heuristic
        self.after_step = after_step
        self.max_states = max_states
        self.tie_break = bool(tie_break) and heuristic is not None
        self.closed = 0
        self.reopened = 0  # closings of a state already closed at a larger g
        self.exhausted = False  # True when every reachable state was closed
        self.timed_out = False  # True when the time limit stopped the search
        self._closed = ClosedStates(bm.n_words)
        # h of every state evaluated so far: an open state is generated again and
        # again from different parents, and a strong heuristic is the dear part.
        self._h_table = StateTable(bm.n_words)
        self._parents: list[np.ndarray] = []
        self._actions: list[np.ndarray] = []
        self._version = 0  # bumped by rescore(); each open entry keeps the one it was scored under
        self._allowance: dict = {}  # with tie_break: states the next visit of an (f, h) bucket closes
        start_row = bm.pack([start])
        f0 = 0 if heuristic is None else int(heuristic(start_row)[0])
        self.f = f0  # the level being closed: a lower bound on any goal's cost
        # The time limit bounds the search; what the heuristic builds on its first call (pattern
        # databases, kept for later searches) is done before the clock starts.
        self.deadline = None if time_limit is None else time.perf_counter() + time_limit
        self._built = building() if building is not None else 0.0
        # Open states by (f, tie): tie is f - g (their h) with tie_break, else 0 (one bucket per f).
        start_key = (f0, f0 if self.tie_break else 0)
        self._open: dict[tuple, list] = {start_key: [(start_row, np.array([-1]), np.array([-1]), np.array([0]), 0)]}
        self._heap = [start_key]

    def __iter__(self):
        while self._heap:
            if self.max_states is not None and self.closed >= self.max_states:
                return
            if self._late():
                self.timed_out = True
                return
            key = heapq.heappop(self._heap)
            f = key[0]
            if f >= INF:
                break
            self.f = f
            try:
                rows, parents, actions, g, keys = self._pop(key)
            except _OutOfTime:
                self.timed_out = True
                return
            if not len(rows):
                continue
            ids = np.arange(self.closed, self.closed + len(rows))
            self.closed += len(rows)
            self._parents.append(parents)
            self._actions.append(actions)
            self.reopened += self._closed.close(keys, rows, g)
            yield f, rows, ids, g
            try:
                self._expand(f, rows, ids, g)
            except _OutOfTime:
                self.timed_out = True
                return
        self.exhausted = True

    def _late(self) -> bool:
        """Past the deadline, the heuristic's building since the start not counted."""
        if self.deadline is None:
            return False
        built = self._building() - self._built if self._building is not None else 0.0
        return time.perf_counter() - built > self.deadline

    def _check_time(self) -> None:
        if self._late():
            raise _OutOfTime

    def plan_to(self, state_id: int) -> list[int]:
        """The actions from the start to a closed state."""
        if len(self._parents) > 1:  # joined once: a multi-goal search asks for several plans per level
            self._parents, self._actions = [np.concatenate(self._parents)], [np.concatenate(self._actions)]
        parents, actions = self._parents[0], self._actions[0]
        plan = []
        while parents[state_id] >= 0:
            plan.append(int(actions[state_id]))
            state_id = int(parents[state_id])
        return plan[::-1]

    def rescore(self) -> None:
        """The heuristic has risen (still admissible; e.g. a multi-goal search reached one of its goals):
        states opened before are scored again when their level comes, and wait for a later level if their f rose."""
        self._version += 1
        self._h_table = StateTable(self.bm.n_words)

    def _pop(self, key):
        """The new states of a level (f, tie): those scored under an older heuristic whose f has risen go to
        their new level."""
        f = key[0]
        chunks = self._open.pop(key)
        if self.tie_break:
            chunks = self._take(key, chunks)
        stale = [c[:4] for c in chunks if c[4] < self._version]
        now = [c[:4] for c in chunks if c[4] == self._version]
        if stale and self.h is not None:
            rows, parents, actions, g, keys = self._new_states(*(np.concatenate(x) for x in zip(*stale)))
            h = self._cached_h(keys, rows)
            f_new = np.where(h >= INF, INF, np.maximum(g + h, f))
            later = f_new > f
            self._push(f_new[later], rows[later], parents[later], actions[later], g[later])
            now.append((rows[~later], parents[~later], actions[~later], g[~later]))
        else:
            now += stale
        return self._new_states(*(np.concatenate(x) for x in zip(*now)))

    def _take(self, key, chunks: list) -> list:
        """Of an (f, h) bucket, the states generated last, as many as this bucket's allowance (1 at first, doubled
        each time the search comes back to it); the rest stay open under the same key."""
        limit = self._allowance.get(key, TIE_FIRST)
        self._allowance[key] = 2 * limit
        taken, n = [], 0
        while chunks and n < limit:
            c = chunks.pop()
            room = limit - n
            if len(c[0]) > room:
                taken.append(tuple(x[-room:] for x in c[:4]) + (c[4],))
                chunks.append(tuple(x[:-room] for x in c[:4]) + (c[4],))
                n = limit
            else:
                taken.append(c)
                n += len(c[0])
        if chunks:
            self._open[key] = chunks
            heapq.heappush(self._heap, key)
        return taken

    def _push(self, f_child, child, parent_ids, action, g_child) -> None:
        """Open states at their levels (infinite f: never)."""
        if self.tie_break:
            live = f_child < INF
            pairs = np.stack([f_child[live], f_child[live] - g_child[live]], axis=1)
            uniq, which = np.unique(pairs, axis=0, return_inverse=True)
            which = which.reshape(-1)
            idx = np.flatnonzero(live)
            groups = [((int(f), int(t)), idx[which == i]) for i, (f, t) in enumerate(uniq)]
        else:
            groups = [((int(f), 0), f_child == f) for f in np.unique(f_child) if f < INF]
        for level, sel in groups:
            if level not in self._open:
                self._open[level] = []
                heapq.heappush(self._heap, level)
            self._open[level].append((child[sel], parent_ids[sel], action[sel], g_child[sel], self._version))

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
            h[new] = self._h_of(rows[new])
            self._h_table.add(keys[new], rows[new], h[new])
        return h

    def _h_of(self, rows) -> np.ndarray:
        """The heuristic of rows; under a time limit in chunks, the clock read between them."""
        if self.deadline is None:
            return self.h(rows)
        out = np.empty(len(rows), dtype=np.int64)
        lo, step = 0, H_CHUNK
        while lo < len(rows):
            self._check_time()
            t = time.perf_counter()
            out[lo : lo + step] = self.h(rows[lo : lo + step])
            lo += step
            if time.perf_counter() - t < H_CHEAP:
                step *= 2
        return out

    def _successors(self, rows):
        """bm.successors of a level; under a time limit a large level in chunks, put back in one call's order."""
        if self.deadline is None or len(rows) <= SUCCESSOR_CHUNK:
            return self.bm.successors(rows)
        parts = []
        for lo in range(0, len(rows), SUCCESSOR_CHUNK):
            self._check_time()
            parent, action, child, cost, group, place = self.bm.successors(rows[lo : lo + SUCCESSOR_CHUNK], keyed=True)
            parts.append((parent + lo, action, child, cost, group, place))
        self._check_time()
        parent, action, child, cost, group, place = (np.concatenate(x) for x in zip(*parts))
        order = np.lexsort((place, parent, group))
        return parent[order], action[order], child[order], cost[order]

    def _expand(self, f_parent, rows, ids, g) -> None:
        parent, action, child, cost = self._successors(rows)
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
        else:  # pathmax: h may be inconsistent (LM-cut)
            h = self._cached_h(keys[keep], child)
            f_child = np.where(h >= INF, INF, np.maximum(g_child + h, f_parent))
        self._push(f_child, child, ids[parent], action, g_child)
