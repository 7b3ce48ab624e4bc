"""The two frontiers of the Bellman–Novelty search in Python, over one node set (thesis Algorithms 3-4).

Both heaps break ties by one shared push counter (NEXT), so a node keeps the
order it was enqueued in.

- `BellmanFrontier` (H_B) follows the value toward completing τ: max-first on
  G + γ^d q_max(s, τ). Enqueued nodes wait in `pending` and are valued in one
  batched call, then pushed with the counter they got when enqueued, just
  before the next Bellman pop: the heap is the same at every pop as with
  eager valuation. q_max is cached per state within a search. A flush that
  has to call the value also values, in the same call and up to `prefetch`
  states in all, the non-completing successors of the states it values (the
  likeliest next pushes; `prefetch=0`: off).
- `NoveltyFrontier` (H_N) is value-free: min-first on (width, depth, counter),
  the width taken against atom and pair tables (`planning.search.novelty`)
  that grow only when a node is expanded on a novelty turn. A state's width
  is cached per version of the tables (a state found not novel stays so).
  A pop (NOVELTYPOP) goes on until it finds work: it skips stale nodes,
  recomputes the width, drops a node no longer novel and re-pushes one whose
  width got worse.
"""

from __future__ import annotations

from heapq import heappop, heappush
from time import perf_counter

import numpy as np

from planning.search.bn_stats import BNStats
from planning.search.expansion import INF, SearchTree
from planning.search.novelty import NoveltyTables


class BellmanFrontier:
    """H_B with its pending nodes and its per-state q_max cache."""

    def __init__(self, tree: SearchTree, value, task, tick, prefetch: int, stats: BNStats):
        self.tree, self.value, self.task, self.tick = tree, value, task, tick
        self.prefetch, self.stats = prefetch, stats
        self.heap: list = []  # (-(G + γ^d q_max), counter, node)
        self.pending: list = []  # (node, counter) enqueued but not yet valued and pushed
        self.q: dict = {}  # state -> q_max(state, τ)

    def enqueue(self, nid: int) -> None:
        """Line 5: the node goes on H_B at the next flush, with the counter it gets now."""
        self.pending.append((nid, next(self.tick)))

    def flush(self) -> None:
        """Value the pending nodes (one batched call) and push them on H_B with their enqueue counters."""
        tree, q_cache, pending, prefetch = self.tree, self.q, self.pending, self.prefetch
        n_state = tree.state
        need = list(dict.fromkeys(n_state[nid] for nid, _ in pending if n_state[nid] not in q_cache))
        if need and prefetch > len(need):
            # The children of these states are the likely next pushes: value them in the same call.
            extra = dict.fromkeys(
                s2 for s in need for _, s2, _, hit in tree.successors_of(s) if not hit and s2 not in q_cache
            )
            for s in need:
                extra.pop(s, None)
            need += list(extra)[: prefetch - len(need)]
        if need:
            stats = self.stats
            t0 = perf_counter()
            q = self.value.q_max(need, self.task)
            stats.value_seconds += perf_counter() - t0
            stats.value_calls += 1
            stats.value_states += len(need)
            q_cache.update(zip(need, np.asarray(q, dtype=float).tolist()))
        heap, n_G, n_depth, gpow = self.heap, tree.G, tree.depth, tree.gpow
        for nid, k in pending:
            heappush(heap, (-(n_G[nid] + gpow[n_depth[nid]] * q_cache[n_state[nid]]), k, nid))
        pending.clear()

    def pop(self) -> int | None:
        """The node with the highest key after a flush, or None (the heap is empty: the turn is forfeited)."""
        if self.pending:
            self.flush()
        return heappop(self.heap)[2] if self.heap else None


class NoveltyFrontier:
    """H_N, the novelty tables and the per-state width cache."""

    def __init__(self, tree: SearchTree, n_atoms: int, tick, stats: BNStats):
        self.tree, self.tick, self.stats = tree, tick, stats
        self.tables = NoveltyTables(n_atoms)
        self.heap: list = []  # (width, depth, counter, node)
        self.widths: dict = {}  # state -> (tables version, width)

    def width(self, s: int, added: int | None = None) -> int | None:
        """WIDTH(s; A, P), cached per state while the tables are unchanged (not novel is for good)."""
        tables = self.tables
        hit = self.widths.get(s)
        if hit is not None:
            version, w = hit
            if w is None or version == tables.version:
                return w
        t0 = perf_counter()
        w = tables.width(s, added)
        self.stats.novelty_seconds += perf_counter() - t0
        self.widths[s] = (tables.version, w)
        return w

    def offer(self, nid: int, s: int, d: int, added: int | None = None) -> None:
        """Line 6: push the node (state s at depth d) if s is novel; `added`: `NoveltyTables.width`'s fast path."""
        w = self.width(s, added)
        if w is not None:
            heappush(self.heap, (w, d, next(self.tick), nid))

    def pop(self) -> int | None:
        """NOVELTYPOP: the first node that is still novel and not stale, or None when the heap runs out."""
        heap, stats, width = self.heap, self.stats, self.width
        tree = self.tree
        n_state, n_G, expanded, cap = tree.state, tree.G, tree.expanded, tree.depth_cap
        while heap:
            w_old, d, _, nid = heappop(heap)
            s = n_state[nid]
            if d >= cap or expanded[d].get(s, -INF) >= n_G[nid]:  # SearchTree.is_stale, inlined
                stats.novelty_skipped += 1
                continue
            w = width(s)
            if w is None:
                stats.novelty_dropped += 1
                continue
            if w > w_old:
                heappush(heap, (w, d, next(self.tick), nid))
                stats.novelty_repushed += 1
                continue
            return nid
        return None

    def register(self, s: int) -> None:
        """Line 15: the tables grow only here, with the atoms and pairs of a state about to be expanded."""
        t0 = perf_counter()
        self.tables.register(s)
        self.stats.novelty_seconds += perf_counter() - t0
