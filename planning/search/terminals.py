"""The terminals of the Bellman–Novelty search and the choice among them (thesis §4.2, Eq. 4.1).

A terminal is a way found to complete the current task τ: the myopic
reference plan replayed from the root and cut where τ first holds
(`reference_terminal`, admitted first; its cost is C_myo), or a successor
that completes τ during the search. At the end (Algorithm 3, line 19,
SELECTTERMINAL) the terminals whose cost is within β·C_myo (C_myo: the
cheapest terminal when there is no reference) are scored in one batched call
by V_AP of their post-consumption state (`score_eligible`), and the highest
V_AP wins, then the lower cost, the smaller depth, the earlier discovery
(`select_terminal`).
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from planning.search.bn_stats import BNStats


class Terminal(NamedTuple):
    """A candidate completion of the current task, in discovery order."""

    source: str  # "reference" (the myopic plan) or "search"
    cost: float  # undiscounted PDDL cost of the prefix
    depth: int
    G: float  # discounted prefix return (RL units, ≤ 0)
    state: int  # the completing state, before consumption
    v_ap: float | None = None  # V_AP of the post-consumption state; None if not scored (ineligible)


def within(cost: float, bound: float) -> bool:
    """cost ≤ bound, up to the rounding of β·C in floats (1.25 * 4 must admit 5)."""
    return cost <= bound + 1e-9 * max(1.0, abs(bound))


def select_terminal(terminals: list, c_myo: float | None, beta: float) -> int | None:
    """Eq. 4.1: the index of the terminal with the highest V_AP among those with cost ≤ β·C_myo.

    Ties go to the lower cost, then the smaller depth, then the earlier
    discovery (list order). None if there is no terminal or none is eligible.
    """
    if not terminals or c_myo is None:
        return None
    bound = beta * c_myo
    best, best_key = None, None
    for i, t in enumerate(terminals):
        if not within(t.cost, bound):
            continue
        key = (-t.v_ap, t.cost, t.depth, i)
        if best_key is None or key < best_key:
            best, best_key = i, key
    return best


def reference_terminal(
    model, state: int, task, goal, reference_plan: list, gamma: float, scale: float
) -> tuple[Terminal, list]:
    """Algorithm 3, lines 2-3: the myopic reference plan replayed from the root and cut where τ first holds.

    goal: the task's goal test. Returns the terminal (source "reference") and
    the plan's prefix up to it; G discounts each step's cost by γ^depth / scale.
    """
    s, G, c, prefix = state, 0.0, 0, []
    if not goal(s):
        for a in reference_plan:
            k = model.action_cost[a]
            G -= gamma ** len(prefix) * k / scale
            s = model.apply(s, a)
            c += k
            prefix.append(a)
            if goal(s):
                break
        else:
            raise ValueError(f"the reference plan does not complete {getattr(task, 'name', task)}")
    return Terminal("reference", c, len(prefix), G, s), prefix


def score_eligible(
    terminals: list, c_myo: float | None, beta: float, task, v_ap, stats: BNStats
) -> tuple[list, float | None, int]:
    """V_AP of the post-consumption states of the terminals within β·C_myo, in one call of `v_ap`.

    Returns (the terminals with `v_ap` set where eligible, C_myo, the number
    eligible); C_myo is the cheapest terminal's cost when None is given.
    Adds the consumption time to the stats' simulator time and the V_AP call
    to their value time, calls and states.
    """
    clock = time.perf_counter
    if c_myo is None and terminals:
        c_myo = min(t.cost for t in terminals)
    bound = beta * c_myo if c_myo is not None else None
    eligible = [i for i, t in enumerate(terminals) if within(t.cost, bound)] if terminals else []
    t0 = clock()
    after = {i: task.consume(terminals[i].state) for i in eligible}
    stats.simulator_seconds += clock() - t0
    need = list(dict.fromkeys(after.values()))
    if not need:
        return list(terminals), c_myo, len(eligible)
    t0 = clock()
    v = v_ap(need)
    stats.value_seconds += clock() - t0
    stats.value_calls += 1
    stats.value_states += len(need)
    v_of = dict(zip(need, np.asarray(v, dtype=float).tolist()))
    scored = list(terminals)
    for i, s in after.items():
        scored[i] = scored[i]._replace(v_ap=v_of[s])
    return scored, c_myo, len(eligible)
