"""The compiled model as numpy arrays: many states stepped at once.

A batch of states is a (N, W) uint64 array, W = ceil(atoms / 64) words per
state. Preconditions are tested word by word against (V, W) masks, so one call
tests every variant of every ground action on every state; effects are indexed
by ground action (all variants of an action share them). Derived atoms are
recomputed after each step by the batched axioms (planning.domain.axioms).
"""

from __future__ import annotations

import numpy as np

from planning.errors import DomainError

WORD = 64


def _words(mask: int, n_words: int) -> list[int]:
    return [(mask >> (WORD * w)) & 0xFFFFFFFFFFFFFFFF for w in range(n_words)]


class BatchedModel:
    """Batched applicability, stepping and successor generation over packed states."""

    def __init__(self, model, extra_bits: int = 0):
        """`extra_bits` reserves room above the atoms (the joint search keeps its stage there)."""
        self.model = model
        W = self.n_words = max(1, -(-(model.n_atoms + extra_bits) // WORD))
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
        # Conditional effects, kept only for the actions that have any.
        self.cond_actions = np.array([a for a, o in enumerate(effects) if o.cond], dtype=np.int64)
        self.has_cond = np.zeros(model.n_actions, dtype=bool)
        self.has_cond[self.cond_actions] = True
        C = max((len(o.cond) for o in effects), default=0)
        if C:
            pad = lambda o, k: [c[k] for c in o.cond] + [0] * (C - len(o.cond))
            self.cond = [
                np.array([[_words(m, W) for m in pad(o, k)] for o in effects], dtype=np.uint64) for k in range(4)
            ]  # pos, neg, add, dele: (A, C, W) each
        # A state may satisfy two variants of one action: keep the first only.
        first_variant: dict[int, int] = {}
        self._later = []  # (variant, first variant of its action)
        for v, a in enumerate(model.op_action):
            if a in first_variant:
                self._later.append((v, first_variant[a]))
            else:
                first_variant[a] = v
        self._neg_words = [w for w in range(W) if self.pre_neg[:, w].any()]
        # successors() tests each variant only on the states where its trigger
        # atom holds (the same index as Model.successors uses).
        self._groups = [(t, np.array(vs, dtype=np.int64)) for t, vs in model.trigger_groups().items()]
        self._first_of = {v: f for v, f in self._later}
        self.derive = None  # BatchedAxioms where the domain has derived predicates
        if getattr(model, "axioms", None) is not None:
            from planning.domain.axioms import BatchedAxioms

            self.derive = BatchedAxioms(model.axioms, self.pack)

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
    def _violations(self, batch: np.ndarray, variants=None) -> np.ndarray:
        """(N, V) uint64, zero where the variant's precondition holds in the state."""
        pos = self.pre_pos if variants is None else self.pre_pos[variants]
        neg = self.pre_neg if variants is None else self.pre_neg[variants]
        violated = np.zeros((batch.shape[0], pos.shape[0]), dtype=np.uint64)
        tmp = np.empty_like(violated)
        for w in range(self.n_words):
            s = batch[:, w, None]
            np.bitwise_and(~s, pos[None, :, w], out=tmp)  # required but false
            violated |= tmp
            if w in self._neg_words:
                np.bitwise_and(s, neg[None, :, w], out=tmp)  # forbidden but true
                violated |= tmp
        return violated

    def _applicable_variants(self, batch: np.ndarray) -> np.ndarray:
        """(N, V) bool: which variants apply, at most one per action and state."""
        ok = self._violations(batch) == 0
        for v, first in self._later:
            ok[:, v] &= ~ok[:, first]
        return ok

    def applicable(self, batch: np.ndarray) -> np.ndarray:
        """(N, A) bool: which ground actions apply in each state."""
        ok = self._applicable_variants(batch)
        out = np.zeros((batch.shape[0], self.model.n_actions), dtype=bool)
        rows, variants = np.nonzero(ok)
        out[rows, self.op_action[variants]] = True
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

    def successors(self, batch: np.ndarray, keyed: bool = False):
        """Every applicable transition: (parent index, action, next state, cost) arrays.

        They come grouped by trigger atom, then by parent, then by variant. `keyed` adds two arrays
        that give that order ((group, parent, position in the group) sorts them): the successors of
        a batch cut into chunks, so sorted, come in the order of one call over the whole batch."""
        bits = self.to_bits(batch).T.copy()  # (atoms, N): a row per atom
        parents, variants, groups, places = [], [], [], []
        for k, (trigger, vs) in enumerate(self._groups):
            rows = np.flatnonzero(bits[trigger]) if trigger >= 0 else np.arange(len(batch))
            if not len(rows):
                continue
            r, v = np.nonzero(self._violations(batch[rows], vs) == 0)
            parents.append(rows[r])
            variants.append(vs[v])
            if keyed:
                groups.append(np.full(len(r), k, dtype=np.int64))
                places.append(v)
        empty = np.zeros(0, dtype=np.int64)
        parent = np.concatenate(parents) if parents else empty
        variant = np.concatenate(variants) if variants else empty
        group = np.concatenate(groups) if groups else empty
        place = np.concatenate(places) if places else empty
        if self._later:  # drop a later variant where its action's first variant applies too
            dup = np.zeros(len(variant), dtype=bool)
            for v, first in self._later:
                sel = np.flatnonzero(variant == v)
                if len(sel):
                    dup[sel] = self._violations(batch[parent[sel]], np.array([first]))[:, 0] == 0
            parent, variant = parent[~dup], variant[~dup]
            if keyed:
                group, place = group[~dup], place[~dup]
        action = self.op_action[variant]
        out = parent, action, self._apply(batch[parent], action), self.cost[action]
        return (*out, group, place) if keyed else out

    def apply_op(self, batch: np.ndarray, op) -> np.ndarray:
        """One Op (e.g. a task's consumption) applied to every state of a batch."""
        add, dele = self.pack([op.add])[0], self.pack([op.dele])[0]
        out = (batch & ~dele) | add
        for cp, cn, ca, cd in op.cond:
            cp, cn, ca, cd = (self.pack([m])[0] for m in (cp, cn, ca, cd))
            fire = ((batch & cp) == cp).all(1) & ((batch & cn) == 0).all(1)
            out[fire] = (out[fire] & ~cd) | ca
        return out if self.derive is None else self.derive(out)

    def _apply(self, batch: np.ndarray, actions: np.ndarray) -> np.ndarray:
        out = (batch & self.keep[actions]) | self.add[actions]
        if len(self.cond_actions):
            rows = np.flatnonzero(self.has_cond[actions])
            if len(rows):
                a, s = actions[rows], batch[rows][:, None, :]
                cpos, cneg, cadd, cdel = (c[a] for c in self.cond)
                fire = (((s & cpos) == cpos).all(-1) & ((s & cneg) == 0).all(-1))[..., None]
                add = np.bitwise_or.reduce(np.where(fire, cadd, 0), axis=1)
                dele = np.bitwise_or.reduce(np.where(fire, cdel, 0), axis=1)
                out[rows] = (out[rows] & ~dele) | add
        return out if self.derive is None else self.derive(out)


def goal_arrays(bm, task) -> tuple[np.ndarray, np.ndarray]:
    """(pos, neg) as (K, W) word arrays: the task goal's K conjunctions."""
    return bm.pack([o.pos for o in task.bindings]), bm.pack([o.neg for o in task.bindings])


def satisfied(rows: np.ndarray, pos: np.ndarray, neg: np.ndarray) -> np.ndarray:
    """(N,) bool: which packed states satisfy a DNF goal given as (K, W) arrays."""
    s = rows[:, None, :]
    return (((s & pos[None]) == pos[None]).all(-1) & ((s & neg[None]) == 0).all(-1)).any(-1)
