"""Packed states: sets of them keyed for fast sorting (the batched searches' duplicate detection), and INF_64.

A state (a row of W uint64 words) is keyed by a 64-bit mix of its words; every
key match is checked against the stored row, so a true collision raises, never
misleads. Shared by the cost-level A* (`planning.search.cost_levels`) and the
pattern-database projections (`planning.heuristics.pdb`). INF_64 is the int64
cost of an unreachable state: a g, f or heuristic value no plan attains, with
room to add costs to it without overflow.
"""

from __future__ import annotations

import numpy as np

INF_64 = np.iinfo(np.int64).max // 4  # "unreachable" for g, f and h values

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
        back = np.cumsum(first) - 1  # each sorted row's kept representative
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
        self.runs: list[list[np.ndarray]] = []  # [keys (sorted), rows, values]

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
            return (
                np.zeros(0, dtype=np.uint64),
                np.zeros((0, self.n_words), dtype=np.uint64),
                np.zeros(0, dtype=np.int64),
            )
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
        self.table.set(run[known], pos[known], g[known])  # reopened: a smaller g than before
        new = ~known
        self.table.add(keys[new], rows[new], g[new])
        return int(known.sum())
