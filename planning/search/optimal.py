"""Exact in-process search on the compiled model."""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np


@dataclass
class SearchResult:
    plan: list | None  # ground action indices; None if no plan exists
    cost: int | None
    expansions: int
    complete: bool = True  # False if a limit stopped the search before a verdict
    lower_bound: int | None = None  # proven lower bound on the optimal cost (the last f-level closed)


def uniform_cost_search(model, state: int, task, max_expansions: int | None = None) -> SearchResult:
    """An optimal plan for one task by uniform-cost search (A* with h = 0, as the myopic oracle).

    Duplicate detection on states; a state is expanded at most once, at its
    optimal g, so the first goal state popped gives the optimal cost.
    """
    if task.satisfied(state):
        return SearchResult([], 0, 0)
    best = {state: 0}
    parent = {state: None}
    frontier = [(0, 0, state)]
    tie = 0
    expansions = 0
    successors = model.successors
    while frontier:
        g, _, s = heapq.heappop(frontier)
        if g > best[s]:
            continue
        if task.satisfied(s):
            plan = []
            while parent[s] is not None:
                s, a = parent[s]
                plan.append(a)
            return SearchResult(plan[::-1], g, expansions)
        expansions += 1
        if max_expansions is not None and expansions > max_expansions:
            break
        for a, t, c in successors(s):
            g2 = g + c
            if g2 < best.get(t, g2 + 1):
                best[t] = g2
                parent[t] = (s, a)
                tie += 1
                heapq.heappush(frontier, (g2, tie, t))
    return SearchResult(None, None, expansions, complete=not frontier)


def optimal_plan(
    bm,
    state: int,
    task,
    max_states: int | None = None,
    time_limit: float | None = None,
    heuristic: str | None = None,
    tie_break: bool | None = None,
) -> SearchResult:
    """An optimal plan for one task: A* by f-levels, expanding each level in one numpy call.

    heuristic: a name of the registry's "task" rows (planning.heuristics), e.g. "pdb" (the layout's pattern
    databases; LM-cut, reported once on stderr, for a layout whose rooms do not name its locations),
    "lmcut", "hmax" or "blind", or "a+b" (the larger of two); all admissible, so the cost is the same as
    uniform_cost_search's, many times faster (the plan may be another of equal cost). The default (None)
    is "pdb", or "lmcut" on a model with derived predicates (where pattern databases are refused).
    `task` is anything with `bindings` (a DNF of Ops), e.g. a task with an extra clause.
    plan is None if no plan exists (complete=True) or a limit stopped the search (complete=False).
    """
    return optimal_plans(bm, state, [task], max_states, time_limit, heuristic, tie_break=tie_break)[0]


PREFER_TRIES = 16
TIE_BREAK = False
"""optimal_plans' default for tie_break: off, so that the restaurant's committed results replay as they were (lower h
first picks another of the equally cheap plans for about one task in eight there); pass tie_break=True."""


def default_heuristic(model) -> str:
    """The one-task search's heuristic when none is named: pattern databases, or LM-cut where the model has
    derived predicates."""
    return "pdb" if getattr(model, "axioms", None) is None else "lmcut"


def optimal_plans(
    bm,
    state: int,
    goals: list,
    max_states: int | None = None,
    time_limit: float | None = None,
    heuristic: str | None = None,
    prefer=None,
    tie_break: bool | None = None,
) -> list[SearchResult]:
    """An optimal plan for each of several goals from one A* (e.g. a task with each of ten clauses).

    The heuristic is the minimum over the goals still unreached of their admissible estimates,
    so it is admissible for every one of them; the first f-level holding a goal state of goal k
    holds one at k's optimal cost (CostLevels' pathmax and reopening keep this for an
    inconsistent heuristic too), and the search stops when every goal is reached. Levels
    are shared, so one search costs far less than one per goal when the goals lie close together.
    When a goal is reached the remaining goals' minimum can only rise: the states already open
    are scored again when their level comes (CostLevels.rescore) and wait if their f rose.
    `prefer(k, plan) -> bool` breaks ties among goal k's optimal plans: of the goal states closed at
    k's optimal cost on that level (at most PREFER_TRIES of them), the first whose plan it accepts is
    returned; if it accepts none, the first. Without it, any optimal plan.
    `tie_break`: within an f, lower h first (CostLevels; default TIE_BREAK): far fewer expansions where h
    is nearly exact, the same costs. A time limit is honoured within about a second.
    """
    from planning.domain.batched import goal_arrays, satisfied
    from planning.heuristics import build
    from planning.search.cost_levels import CostLevels

    if not goals:
        return []
    nearest = build(heuristic or default_heuristic(bm.model), bm, "task")  # None: blind, Dijkstra
    open_ = np.ones(len(goals), dtype=bool)

    def h(batch):
        return nearest(batch, [goals[k] for k in np.flatnonzero(open_)])

    arrays = [goal_arrays(bm, g) for g in goals]
    out: list[SearchResult | None] = [None] * len(goals)
    if tie_break is None:
        tie_break = TIE_BREAK
    levels = CostLevels(
        bm, state, max_states, time_limit, heuristic=None if nearest is None else h, tie_break=tie_break
    )
    for _, rows, ids, g in levels:
        reached = False
        for k in np.flatnonzero(open_):
            hit = np.flatnonzero(satisfied(rows, *arrays[k]))
            if len(hit):
                best = hit[g[hit] == g[hit].min()]
                tries = (levels.plan_to(int(ids[i])) for i in best[: PREFER_TRIES if prefer is not None else 1])
                plan = next(tries)
                if prefer is not None and not prefer(int(k), plan):
                    plan = next((p for p in tries if prefer(int(k), p)), plan)  # else the first
                out[k] = SearchResult(plan, int(g[best[0]]), levels.closed, True)
                open_[k], reached = False, True
        if not open_.any():
            break
        if reached:
            levels.rescore()  # the minimum is over fewer goals now: states opened before may wait
    return [r if r is not None else SearchResult(None, None, levels.closed, levels.exhausted) for r in out]
