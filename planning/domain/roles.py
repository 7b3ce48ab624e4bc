"""Which predicates describe the agent rather than the world, derived from the compiled model.

The agent's own facts (0-ary fluents such as hand-free, its position, its
relations to objects such as holding) are told apart from the world's by their
shape in the layout, not by name: the labeller's P^C pairs, the GNN graph and
the dataset's preparatory clauses all use this one reading.
"""

from __future__ import annotations


def agent_relations(model, locations) -> set:
    """Fluent unary predicates over objects that tie an object to the agent (holding):
    every action adding one of their atoms deletes a 0-ary fluent (hand-free)."""
    zero_ary = 0
    for i, a in enumerate(model.atoms):
        if len(a) == 1:
            zero_ary |= 1 << i
    verdict: dict[str, bool] = {}
    for op in model.ops:
        add, i = op.add, 0
        while add:
            if add & 1 and len(model.atoms[i]) == 2 and model.atoms[i][1] not in locations:
                p = model.atoms[i][0]
                verdict[p] = verdict.get(p, True) and bool(op.dele & zero_ary)
            add >>= 1
            i += 1
    return {p for p, ok in verdict.items() if ok}


def position_predicates(model, locations) -> set:
    """Fluent unary predicates over locations only: the agent's position (robot-at)."""
    by_pred: dict[str, list] = {}
    for a in model.atoms:
        if len(a) == 2:
            by_pred.setdefault(a[0], []).append(a[1])
    return {p for p, args in by_pred.items() if all(o in locations for o in args)}


def agent_predicates(model) -> set:
    """The predicates that describe the agent itself rather than the world: 0-ary fluents
    (hand-free), its position (robot-at) and its relations to objects (holding)."""
    locations = set(model.locations)
    return (
        {a[0] for a in model.atoms if len(a) == 1}
        | position_predicates(model, locations)
        | agent_relations(model, locations)
    )
