"""Novelty tables of width-2 iterated-width search (Lipovetzky and Geffner, 2012), over the compiled atoms.

The Bellman–Novelty search (thesis §4.2.1, Algorithm 3) ranks its novelty lane
by a state's width w.r.t. the atoms and atom pairs of the states it has
expanded on novelty turns: 1 if the state makes true an atom never registered,
2 if it makes true a pair never registered, else not novel (None).

Representation. A state is an int bitset, so the tables are bitsets too: the
atom table is one int (bit i: atom i registered) and the pair table one int
row per atom (bit j of row i: the pair {i, j} registered; the table is kept
symmetric, and bit i of row i is set once atom i is). A width test is then one
mask for the atoms and one mask per true atom for the pairs, with no array
built per state: on the restaurant (78 atoms, ~13 true) it takes ~3 µs, where
the numpy version (index array by unpackbits, then `table[np.ix_(idx, idx)]`)
takes ~26 µs, which over the ~10 children of each of 20,000 expansions would
cost seconds per task. `atom_table()` and `pair_table()` give the tables as
numpy bool arrays for inspection. `version` changes exactly when the tables
do, so a caller may cache a state's width per version; a state found not
novel stays not novel.
"""

from __future__ import annotations

import numpy as np


def atom_indices(state: int) -> list[int]:
    """The indices of the atoms true in a state, ascending."""
    out = []
    while state:
        low = state & -state
        out.append(low.bit_length() - 1)
        state ^= low
    return out


class NoveltyTables:
    """The atoms and atom pairs registered so far; they only grow."""

    def __init__(self, n_atoms: int):
        self.n_atoms = n_atoms
        self.atoms = 0  # bit i: atom i registered
        self.rows = [0] * n_atoms  # rows[i] bit j: pair {i, j} registered
        self.version = 0  # bumped whenever a registration adds something

    def width(self, state: int, added: int | None = None) -> int | None:
        """1 if some atom of `state` is unregistered, else 2 if some pair is, else None (not novel).

        Always exact for the tables as they are now. `added` (a bitmask) is the
        fast path: only pairs with at least one atom in `added` are checked, so
        the caller asserts that every pair among the state's other atoms is
        already registered. That holds for a child of a state registered
        before it was expanded (a novelty expansion), with `added` the atoms
        the action added: the child's other atoms all held in the parent,
        whose pairs were registered, and the tables never shrink. It does not
        hold for the child of a Bellman expansion (its parent's pairs may
        never have been registered): pass None there.
        """
        if state & ~self.atoms:
            return 1
        rows = self.rows
        check = state if added is None else state & added
        while check:
            low = check & -check
            if state & ~rows[low.bit_length() - 1]:
                return 2
            check ^= low
        return None

    def register(self, state: int) -> bool:
        """Add the state's atoms and all pairs of them to the tables; True if that changed them."""
        rows = self.rows
        if state.bit_length() > len(rows):  # a model that did not say how many atoms it has
            rows.extend([0] * (state.bit_length() - len(rows)))
            self.n_atoms = len(rows)
        changed = False
        s = state
        while s:
            low = s & -s
            i = low.bit_length() - 1
            if state & ~rows[i]:
                rows[i] |= state
                changed = True
            s ^= low
        self.atoms |= state
        if changed:
            self.version += 1
        return changed

    def atom_table(self) -> np.ndarray:
        """(n_atoms,) bool: which atoms are registered."""
        return np.array([bool(self.atoms >> i & 1) for i in range(self.n_atoms)], dtype=bool)

    def pair_table(self) -> np.ndarray:
        """(n_atoms, n_atoms) bool, symmetric: which atom pairs are registered (the diagonal: the atoms)."""
        out = np.zeros((self.n_atoms, self.n_atoms), dtype=bool)
        for i, row in enumerate(self.rows):
            if row:
                out[i, atom_indices(row)] = True
        return out
