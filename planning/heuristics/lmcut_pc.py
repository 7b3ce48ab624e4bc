"""LM-cut on the P^C compilation: the delete relaxation that knows some pairs of atoms.

The plain delete relaxation lets the robot be everywhere it has ever been: a jar
fetched from the pantry "is" at the serving table as soon as the robot has been
to both, so LM-cut counts the 875 walk to the pantry once where every plan walks
it twice. P^C (Haslum 2012; Keyder, Hoffmann & Haslum 2014, the conditional-
effects version) adds one relaxed atom pi_c per conjunction c in a set C: pi_c
is reached only by an action that makes c true from a state where the rest of c
already held, so "(holding jar_0) and (robot-at servingtable)" needs a move to
the serving table *while holding the jar*. h+(P^C) <= h*, so LM-cut of it is
admissible, and at least as informed as on the plain relaxation.

What is generic here:
  * mutexes: the largest set of atom pairs that no initial state holds together
    and that every action keeps apart (the h^2-style fixpoint on pairs); with
    them the compilation drops achievers whose regression is impossible. They
    are invariants of every state reachable from a state that respects them, so
    P^C is read only on states that respect them (`MutexPairs.respected`); a
    state that breaks one gets LM-cut of the plain relaxation.
  * C: every non-mutex pair of fluent atoms that occurs together in an action's
    positive precondition or in a task goal's conjunction.

The relaxed task is built with planning.heuristics.lmcut.compile_relaxed; its state columns
are the atoms, then one bit per conjunction (both atoms true), so an LMCut whose
state bits carry those conjunctions evaluates it.
"""

from __future__ import annotations

import itertools

import numpy as np


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]


def _cases(op):
    """(positive pre, negative pre, adds, deletes) of each way an op can fire: every subset of its
    conditional effects (their conditions joined to the precondition); deletes exclude adds (add wins)."""
    conds = list(op.cond)
    if len(conds) > 8:
        raise ValueError(f"{len(conds)} conditional effects on one action: too many cases to enumerate")
    out = []
    for k in range(len(conds) + 1):
        for sub in itertools.combinations(conds, k):
            pos, neg, add, dele = op.pos, op.neg, op.add, op.dele
            for cp, cn, ca, cd in sub:
                pos, neg, add, dele = pos | cp, neg | cn, add | ca, dele | cd
            out.append((pos, neg, add, dele & ~add))
    return out


class MutexPairs:
    """Pairs of atoms that can never hold together in a state reachable from a state respecting them."""

    CHUNK = 1024  # states per check in `respected`

    def __init__(self, model, initial_states):
        n = model.n_atoms
        m = ~np.eye(n, dtype=bool)
        for s in initial_states:
            t = np.array([s >> i & 1 for i in range(n)], dtype=bool)
            m &= ~np.outer(t, t)
        cases = []
        for op in model.ops:
            for pos, neg, add, dele in _cases(op):
                P = np.array(_bits(pos), dtype=np.int64)
                mask = lambda x: np.array([x >> i & 1 for i in range(n)], dtype=bool)
                cases.append((P, mask(neg), mask(add), mask(dele), np.array(_bits(add), dtype=np.int64)))
        changed = True
        while changed:
            changed = False
            for P, neg, add, dele, A in cases:
                if not len(A):
                    continue
                if len(P) and (m[np.ix_(P, P)].any() or neg[P].any()):
                    continue  # never applicable in a state respecting m
                # q may hold after the op together with an added p unless it is deleted,
                # required false, or mutex with a precondition (then it was false before)
                kept_apart = dele | neg | (m[P].any(0) if len(P) else np.zeros(n, dtype=bool))
                together = ~kept_apart | add
                hit = m[A] & together
                if hit.any():
                    for row, p in zip(hit, A):
                        if row.any():
                            m[p, row] = False
                            m[row, p] = False
                            m[p, p] = False
                    changed = True
        self.matrix = m
        self.n = n
        pairs = np.argwhere(np.triu(m, 1))
        self.p = pairs[:, 0]
        self.q = pairs[:, 1]

    def __len__(self) -> int:
        return len(self.p)

    def respects(self, state: int) -> bool:
        """True if no mutex pair holds together in `state`."""
        t = np.array([state >> i & 1 for i in range(self.n)], dtype=bool)
        return not (t[self.p] & t[self.q]).any()

    def respected(self, bits: np.ndarray) -> np.ndarray:
        """(N,) bool of (N, atoms) state bits: which states hold no mutex pair together."""
        out = np.ones(len(bits), dtype=bool)
        for lo in range(0, len(bits), self.CHUNK):
            b = bits[lo : lo + self.CHUNK].astype(bool)
            out[lo : lo + self.CHUNK] = ~(b[:, self.p] & b[:, self.q]).any(1)
        return out

    def any_pair(self, atoms) -> bool:
        a = np.asarray(list(atoms), dtype=np.int64)
        return len(a) > 1 and bool(self.matrix[np.ix_(a, a)].any())


class ConjunctionBits:
    """to_bits of a BatchedModel, then one column per conjunction: both of its atoms true."""

    def __init__(self, bm, pairs):
        self.bm, self.model = bm, bm.model
        self.a = np.array([p for p, _ in pairs], dtype=np.int64)
        self.b = np.array([q for _, q in pairs], dtype=np.int64)

    def to_bits(self, batch: np.ndarray) -> np.ndarray:
        bits = self.bm.to_bits(batch)
        return np.concatenate([bits, bits[:, self.a] & bits[:, self.b]], axis=1)


class ConjunctionLMCut:
    """LM-cut of P^C for DNF goals of model literals (n + i: not atom i): `h(batch, goal) -> (N,)`."""

    name = "lmcut-pc"

    def __init__(self, model, bm, mutex: MutexPairs, extra_goals=(), keep=None):
        from planning.heuristics.lmcut import LMCut

        self.model, self.mutex = model, mutex
        n = self.n = model.n_atoms
        # C: non-mutex pairs of fluents required together by an action or a goal conjunction
        pairs = set()
        for op in model.ops:
            for pos, _, _, _ in _cases(op):
                for p, q in itertools.combinations(_bits(pos), 2):
                    if not mutex.matrix[p, q]:
                        pairs.add((p, q))
        for lits in extra_goals:
            for conj in lits:
                for p, q in itertools.combinations(sorted(x for x in conj if x < n), 2):
                    if not mutex.matrix[p, q]:
                        pairs.add((p, q))
        self.pairs = sorted(c for c in pairs if keep is None or keep(model.atoms[c[0]], model.atoms[c[1]]))
        self.index = {c: k for k, c in enumerate(self.pairs)}
        self.n_bits = n + len(self.pairs)
        by_atom: dict[int, list] = {}
        for k, (p, q) in enumerate(self.pairs):
            by_atom.setdefault(p, []).append(k)
            by_atom.setdefault(q, []).append(k)
        self._by_atom = by_atom
        achievers, costs = [], {}
        for o, (op, a) in enumerate(zip(model.ops, model.op_action)):
            costs[o] = model.action_cost[a]
            for pos, neg, add, dele in _cases(op):
                pre_atoms = _bits(pos)
                if mutex.any_pair(pre_atoms) or pos & neg:
                    continue
                pre = self._pre(pre_atoms, neg)
                for i in _bits(add):
                    achievers.append((pre, o, ("+", i)))
                for i in _bits(dele):
                    achievers.append((pre, o, ("-", i)))
                # pi_c for each conjunction the case makes true: part added, none deleted
                touched = {k for i in _bits(add) for k in by_atom.get(i, [])}
                for k in sorted(touched):
                    p, q = self.pairs[k]
                    if (dele >> p & 1) or (dele >> q & 1):
                        continue
                    rest = [x for x in (p, q) if not add >> x & 1]
                    if any(neg >> x & 1 for x in rest):
                        continue
                    atoms = sorted(set(pre_atoms) | set(rest))
                    if mutex.any_pair(atoms):
                        continue
                    achievers.append((self._pre(atoms, neg), o, ("c", k)))
        self._achievers, self._costs = achievers, costs
        self.initial = {("+", i): i for i in range(n)}
        self.initial.update({("-", i): self.n_bits + i for i in range(n)})
        self.initial.update({("c", k): n + k for k in range(len(self.pairs))})
        self.lmcut = LMCut(model, bm)
        self.lmcut.bm = ConjunctionBits(bm, self.pairs)  # its state bits carry the conjunctions
        self._tables: dict = {}

    def _pre(self, atoms, neg: int) -> list:
        """Precondition keys: the atoms, the negated atoms, and pi_c of every conjunction inside the atoms."""
        keys = [("+", i) for i in atoms] + [("-", i) for i in _bits(neg)]
        s = set(atoms)
        for i in atoms:
            for k in self._by_atom.get(i, []):
                p, q = self.pairs[k]
                if p == i and q in s:
                    keys.append(("c", k))
        return keys

    def tables(self, goal: list[list[int]]):
        from planning.heuristics.lmcut import compile_relaxed

        key = tuple(tuple(c) for c in goal)
        if key not in self._tables:
            rows = list(self._achievers)
            costs = dict(self._costs)
            n = self.n
            for j, conj in enumerate(goal):
                atoms = [x for x in conj if x < n]
                neg = 0
                for x in conj:
                    if x >= n:
                        neg |= 1 << (x - n)
                if mutex_free(self.mutex, atoms):
                    rows.append((self._pre(atoms, neg), ("goal", j), "goal"))
                costs[("goal", j)] = 0
            if len(self._tables) > 256:
                self._tables.clear()
            self._tables[key] = compile_relaxed(rows, costs, "goal", self.initial)
        return self._tables[key]

    def __call__(self, batch: np.ndarray, goal: list[list[int]]) -> np.ndarray:
        return self.lmcut.of_relaxed(batch, self.tables(goal))


class PairsLMCut:
    """The multi-goal search's LM-cut on P^C: h(batch, goals) of the goals' DNF, P^C on the states that respect
    its mutexes, the plain relaxation's LM-cut on any other."""

    def __init__(self, model, bm):
        from planning.heuristics.hmax import GoalLiterals, goal_literals
        from planning.heuristics.lmcut import LMCut

        self.bm = bm
        self.mutex = MutexPairs(model, [model.init] + [model.reset_state(seed) for seed in range(32)])
        self.pc = ConjunctionLMCut(
            model, bm, self.mutex, [goal_literals(model, t) for t in model.tasks], keep=agent_pairs(model)
        )
        self.plain = LMCut(model, bm)
        self.literals = GoalLiterals(model)

    def __call__(self, batch: np.ndarray, goals: list) -> np.ndarray:
        dnf = self.literals(goals)
        ok = self.mutex.respected(self.bm.to_bits(batch))
        if ok.all():
            return self.pc(batch, dnf)
        out = np.empty(len(batch), dtype=np.int64)
        out[ok] = self.pc(batch[ok], dnf)
        out[~ok] = self.plain(batch[~ok], dnf)
        return out


def build(bm, search: str) -> PairsLMCut:
    """The registry's builder (planning.heuristics); the multi-goal search is the one it serves."""
    return PairsLMCut(bm.model, bm)


def mutex_free(mutex: MutexPairs, atoms) -> bool:
    return not mutex.any_pair(atoms)


def agent_pairs(model):
    """The filter of C used by the labeller: both atoms describe the agent (planning.domain.roles.agent_predicates:
    its position, hand and grip), e.g. (robot-at pantry) with (holding jar_0)."""
    from planning.domain.roles import agent_predicates

    agent = agent_predicates(model)
    return lambda a, b: a[0] in agent and b[0] in agent
