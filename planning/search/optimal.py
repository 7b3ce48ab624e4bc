"""Exact in-process search on the compiled model."""
from __future__ import annotations

import heapq
import weakref
from dataclasses import dataclass

import numpy as np

from planning.errors import DomainError


@dataclass
class SearchResult:
    plan: list | None          # ground action indices; None if no plan exists
    cost: int | None
    expansions: int
    complete: bool = True      # False if a limit stopped the search before a verdict
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


def optimal_plan(bm, state: int, task, max_states: int | None = None,
                 time_limit: float | None = None, heuristic: str = "pdb") -> SearchResult:
    """An optimal plan for one task: A* by f-levels, expanding each level in one numpy call.

    heuristic: "pdb" (the layout's pattern databases, planning.heuristics.pdb; LM-cut for a layout whose
    rooms do not name its locations), "lmcut" or "hmax"; all admissible, so the cost is the
    same as uniform_cost_search's, many times faster (the plan may be another of equal cost).
    `task` is anything with `bindings` (a DNF of Ops), e.g. a task with an extra clause.
    plan is None if no plan exists (complete=True) or a limit stopped the search (complete=False).
    """
    from planning.domain.batched import goal_arrays, satisfied
    from planning.search.cost_levels import CostLevels

    h = task_heuristic(bm, task, heuristic)
    pos, neg = goal_arrays(bm, task)
    levels = CostLevels(bm, state, max_states, time_limit, heuristic=h)
    for _, rows, ids, g in levels:
        hit = np.flatnonzero(satisfied(rows, pos, neg))
        if len(hit):
            i = hit[np.argmin(g[hit])]
            return SearchResult(levels.plan_to(int(ids[i])), int(g[i]), levels.closed, True)
    return SearchResult(None, None, levels.closed, levels.exhausted)


_RELAXED: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()   # per BatchedModel: its HMax and LMCut


def task_heuristic(bm, task, heuristic: str = "pdb"):
    """h(batch) -> (N,) admissible costs to the task's goal; the tables behind it are built once per model."""
    from planning.heuristics import choose
    from planning.heuristics.hmax import HMax, goal_literals
    from planning.heuristics.lmcut import LMCut
    from planning.heuristics.pdb import pattern_databases

    heuristic = choose(heuristic, bm.model, "task")
    if heuristic == "pdb":
        pdb = pattern_databases(bm.model, bm.n_words)
        return lambda batch: pdb.per_goal(batch, [task])[:, 0]
    if bm not in _RELAXED:
        hmax = HMax(bm.model, bm)
        _RELAXED[bm] = {"hmax": hmax, "lmcut": LMCut(bm.model, bm, hmax)}
    h = _RELAXED[bm]["hmax" if heuristic == "hmax" else "lmcut"]
    conjs = goal_literals(bm.model, task)
    return lambda batch: h(batch, conjs)
