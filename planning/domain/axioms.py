"""Derived predicates: stratified axioms evaluated on a state, the way Fast Downward reads them.

A derived predicate's atoms are bits of the state like any other, but no action sets
them: after every change of the other atoms (an action, a task's consumption, a world
reset, a state read from atom texts) they are recomputed. Each ground rule
`head <- pos, not neg` comes from one conjunction of an axiom body's DNF; a derived
atom holds iff some rule derives it (least fixpoint, negation as failure). The rules
are stratified: a predicate that depends on another only positively sits in the
same stratum or above it, one that depends on it negatively strictly above, so each
stratum's fixpoint reads the lower strata's atoms as already final. A domain whose
axioms are not stratified (p depends negatively on itself) is refused.
"""

from __future__ import annotations

import numpy as np

from planning.errors import DomainError


class Axioms:
    """The ground rules of a layout, by stratum, as masks: `axioms(state)` is the state with its derived atoms
    recomputed from its other atoms."""

    def __init__(self, strata: list, mask: int):
        """`strata`: per stratum, lowest first, [(pos, neg, head)] bit masks; `mask`: every derived atom."""
        self.strata = [list(s) for s in strata]
        self.mask = mask
        self.n_rules = sum(len(s) for s in self.strata)

    def __call__(self, state: int) -> int:
        state &= ~self.mask
        for rules in self.strata:
            pending = rules
            while pending:
                rest, fired = [], False
                for rule in pending:
                    pos, neg, head = rule
                    if state & head:
                        continue  # already derived: the rule adds nothing more
                    if state & pos == pos and not state & neg:
                        state |= head
                        fired = True
                    else:
                        rest.append(rule)
                if not fired:
                    break
                pending = rest
        return state


def stratify(src, rules: list) -> list:
    """The ground rules [(GroundVariant adding the head, line)] in strata, lowest first (a list of lists of
    GroundVariants); a one-line error naming the predicate and the line where the axioms are not stratified."""
    derived = set(src.derived)
    level = {p: 0 for p in derived}
    edges = []  # (head predicate, body predicate, strict, line)
    for r, line in rules:
        head = next(iter(r.add))[0]
        edges += [(head, a[0], False, line) for a in r.pos if a[0] in derived]
        edges += [(head, a[0], True, line) for a in r.neg if a[0] in derived]
    edges = list(dict.fromkeys(edges))
    for _ in range(len(derived) + 1):
        changed = False
        for head, body, strict, line in edges:
            need = level[body] + (1 if strict else 0)
            if level[head] < need:
                if need > len(derived):
                    raise DomainError(
                        f"{src.domain_file}:{line}",
                        f"derived predicate {head} depends negatively "
                        f"on itself (through {body}): the axioms are not stratified",
                    )
                level[head] = need
                changed = True
        if not changed:
            break
    strata = [[] for _ in range(max(level.values(), default=0) + 1)]
    for r, _ in rules:
        strata[level[next(iter(r.add))[0]]].append(r)
    return [s for s in strata if s]


class BatchedAxioms:
    """The same rules over a (N, W) uint64 batch of packed states: `derive(batch)` recomputes every derived atom."""

    CELLS = 1 << 22  # states x rules x words per numpy pass

    def __init__(self, axioms: Axioms, pack):
        """`pack(masks) -> (K, W)` packs int masks as the batched model does."""
        self.mask = pack([axioms.mask])[0]
        self.strata = [tuple(pack([r[k] for r in rules]) for k in range(3)) for rules in axioms.strata]

    def __call__(self, batch: np.ndarray) -> np.ndarray:
        out = batch & ~self.mask
        if not len(out):
            return out
        for pos, neg, head in self.strata:
            step = max(1, self.CELLS // max(1, pos.shape[0] * pos.shape[1]))
            for lo in range(0, len(out), step):
                part = out[lo : lo + step]
                while True:
                    s = part[:, None, :]
                    fire = ((s & pos[None]) == pos[None]).all(-1) & ((s & neg[None]) == 0).all(-1)  # (n, R)
                    new = part | np.bitwise_or.reduce(np.where(fire[..., None], head[None], np.uint64(0)), axis=1)
                    if (new == part).all():
                        break
                    part = new
                out[lo : lo + step] = part
        return out


def derived_names(model) -> list[str]:
    """The derived predicates of a compiled model, in atom order ([] for a model without axioms)."""
    if getattr(model, "axioms", None) is None:
        return []
    names = []
    for i, a in enumerate(model.atoms):
        if model.axioms.mask >> i & 1 and a[0] not in names:
            names.append(a[0])
    return names
