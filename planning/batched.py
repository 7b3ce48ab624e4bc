"""The compiled model as numpy arrays: many states stepped at once.

A batch of states is a (N, W) uint64 array, W = ceil(atoms / 64) words per
state. Preconditions are tested word by word against (V, W) masks, so one call
tests every variant of every ground action on every state; effects are indexed
by ground action (all variants of an action share them).
"""
from __future__ import annotations

import numpy as np

from .errors import DomainError

WORD = 64


def _words(mask: int, n_words: int) -> list[int]:
    return [(mask >> (WORD * w)) & 0xFFFFFFFFFFFFFFFF for w in range(n_words)]


class BatchedModel:
    """Batched applicability, stepping and successor generation over packed states."""

    def __init__(self, model):
        self.model = model
        W = self.n_words = max(1, -(-model.n_atoms // WORD))
        arr = lambda masks: np.array([_words(m, W) for m in masks], dtype=np.uint64).reshape(len(masks), W)
        self.pre_pos = arr([o.pos for o in model.ops])
        self.pre_neg = arr([o.neg for o in model.ops])
        self.op_action = np.array(model.op_action, dtype=np.int64)
        first = {}
        for v, a in enumerate(model.op_action):
            first.setdefault(a, model.ops[v])
        effects = [first[a] for a in range(model.n_actions)]
        self.add = arr([o.add for o in effects])
        self.keep = ~arr([o.dele for o in effects])
        self.cost = np.array(model.action_cost, dtype=np.int64)
        C = max((len(o.cond) for o in effects), default=0)
        self.n_cond = C
        if C:
            pad = lambda o, k: [c[k] for c in o.cond] + [0] * (C - len(o.cond))
            self.cond = [np.array([[_words(m, W) for m in pad(o, k)] for o in effects], dtype=np.uint64)
                         for k in range(4)]    # pos, neg, add, dele: (A, C, W) each
        # Variants of multi-variant actions are OR-ed into their action's column.
        self._single = np.array([v for v, a in enumerate(model.op_action)
                                 if model.op_action.count(a) == 1], dtype=np.int64)
        self._multi = [v for v in range(len(model.ops)) if v not in set(self._single.tolist())]

    # ---- packing ---------------------------------------------------------
    def pack(self, states) -> np.ndarray:
        """(N, W) uint64 array of int states."""
        return np.array([_words(s, self.n_words) for s in states], dtype=np.uint64).reshape(-1, self.n_words)

    def unpack(self, batch: np.ndarray) -> list[int]:
        """int states of a (N, W) array."""
        out = []
        for row in batch.tolist():
            s = 0
            for w, word in enumerate(row):
                s |= int(word) << (WORD * w)
            out.append(s)
        return out

    def to_bits(self, batch: np.ndarray) -> np.ndarray:
        """(N, atoms) uint8 0/1 features of packed states, for learning."""
        bytes_ = batch.astype("<u8").view(np.uint8).reshape(batch.shape[0], -1)
        return np.unpackbits(bytes_, axis=1, bitorder="little")[:, : self.model.n_atoms]

    # ---- simulation ------------------------------------------------------
    def applicable(self, batch: np.ndarray) -> np.ndarray:
        """(N, A) bool: which ground actions apply in each state."""
        ok = np.ones((batch.shape[0], len(self.op_action)), dtype=bool)
        for w in range(self.n_words):
            s = batch[:, w, None]
            p, n = self.pre_pos[None, :, w], self.pre_neg[None, :, w]
            ok &= (s & p) == p
            ok &= (s & n) == 0
        out = np.zeros((batch.shape[0], self.model.n_actions), dtype=bool)
        out[:, self.op_action[self._single]] = ok[:, self._single]
        for v in self._multi:
            out[:, self.op_action[v]] |= ok[:, v]
        return out

    def step(self, batch: np.ndarray, actions: np.ndarray, check: bool = True):
        """(next states, costs) of one action per state; an error if one does not apply."""
        actions = np.asarray(actions, dtype=np.int64)
        if check:
            ok = self.applicable(batch)[np.arange(len(actions)), actions]
            if not ok.all():
                i = int(np.flatnonzero(~ok)[0])
                raise DomainError(self.model.actions[actions[i]], f"not applicable in batch state {i}")
        return self._apply(batch, actions), self.cost[actions]

    def successors(self, batch: np.ndarray):
        """Every applicable transition: (parent index, action, next state, cost) arrays."""
        parent, action = np.nonzero(self.applicable(batch))
        return parent, action, self._apply(batch[parent], action), self.cost[action]

    def _apply(self, batch: np.ndarray, actions: np.ndarray) -> np.ndarray:
        add, keep = self.add[actions], self.keep[actions]
        if self.n_cond:
            cpos, cneg, cadd, cdel = (c[actions] for c in self.cond)
            s = batch[:, None, :]
            fire = ((s & cpos) == cpos).all(-1) & ((s & cneg) == 0).all(-1)
            fire = fire[..., None]
            add = add | np.bitwise_or.reduce(np.where(fire, cadd, 0), axis=1)
            keep = keep & ~np.bitwise_or.reduce(np.where(fire, cdel, 0), axis=1)
        return (batch & keep) | add
