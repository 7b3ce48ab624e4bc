"""Admissible heuristics for the exact searches, behind one registry whose rows build them.

Each row says which searches it serves ("task": one task's optimal plan,
planning.search.optimal; "window": a clairvoyant window of K tasks,
planning.search.joint; "multi-goal": every task from one state, the labelling
oracle), whether a compiled model supports it, and how to build it:
`row.build(bm, search)` returns the heuristic for packed states of the batched
model bm, one callable with one call shape for every search,

    h(batch, goals) -> (N,) int64 admissible costs (INF_64: a dead end)

for (N, W) packed states and a list of goals (anything with `bindings`, a DNF
of Ops: a task, or a task with an extra clause). In the task and multi-goal
searches it estimates the cost to the nearest of the goals (the multi-goal
search's goals are the model's tasks); in the window search the cost to
complete them in order (the window's stages left, goals[0] the current one).
A builder may return None: no estimate, the search is Dijkstra (blind).
`build(name, bm, search)` is what the searches call: it takes the row
`choose` names, builds it once per batched model and search, and refuses by
name a heuristic the search does not serve. Adding a heuristic is its module
(with its builder) and its row.

Pattern databases need the domain's room locations; on a model without them a
search falls back to the row's stand-in, and says so once on stderr.

Derived predicates (planning.domain.axioms): blind stays admissible everywhere;
h_max and LM-cut stay admissible in the one-task search, which computes them on
`relaxed_view` (planning.heuristics.hmax: each ground axiom a zero-cost action,
a negated derived atom free: a relaxation of the delete relaxation); pattern
databases, LM-cut on P^C and the window's layered LM-cut would read derived
atoms as atoms no action reaches, so on such a model they are refused by name
rather than run inadmissibly.
"""

from __future__ import annotations

import sys
import weakref
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from planning.errors import DomainError
from planning.heuristics import hmax, layered, lmcut, lmcut_pc, pdb

SEARCHES = ("task", "window", "multi-goal")


@dataclass(frozen=True)
class Heuristic:
    """A registry row: how to build the heuristic, where it applies, what stands in where the model lacks support."""

    name: str
    summary: str
    build: Callable  # build(bm, search) -> h(batch, goals), or None (Dijkstra)
    searches: tuple = SEARCHES
    supports: Callable = lambda model: True
    fallback: dict = field(default_factory=dict)  # search -> heuristic used where unsupported
    needs: str = ""  # what `supports` asks of a model, for the fallback's report
    derived: tuple = ()  # the searches where it stays admissible with derived predicates
    records: dict = field(default_factory=dict)  # search -> the estimate as results files name it (default: name)
    lookup: bool = False  # its estimate is a table lookup: not worth memoizing


HEURISTICS = {
    h.name: h
    for h in (
        Heuristic(
            "pdb",
            "pattern databases: exact distances in projections onto a few objects (planning.heuristics.pdb)",
            pdb.build,
            supports=lambda model: bool(model.locations),
            fallback={"task": "lmcut", "window": "layered", "multi-goal": "lmcut"},
            needs="needs the locations that rooms under [layouts.{layout}] in domain.toml list",
            records={
                "window": "max(pattern databases of the current stage, "
                "the window's pattern databases over the stages left)"
            },
            lookup=True,
        ),
        Heuristic(
            "pdb-grown",
            "pattern databases with each chosen window pattern grown by one neighbour object "
            "(planning.heuristics.pdb, up to GROW_STATES abstract states)",
            pdb.build_grown,
            searches=("window",),
            supports=lambda model: bool(model.locations),
            fallback={"window": "layered"},
            needs="needs the locations that rooms under [layouts.{layout}] in domain.toml list",
            records={
                "window": "max(pattern databases of the current stage, the window's pattern databases over the "
                "stages left, each chosen pattern grown by one neighbour object)"
            },
            lookup=True,
        ),
        Heuristic(
            "layered",
            "LM-cut on the window's stage-layered relaxation (planning.heuristics.layered)",
            layered.build,
            searches=("window",),
            records={"window": "lmcut of the stage-layered relaxation"},
        ),
        Heuristic(
            "lmcut",
            "LM-cut of the delete relaxation (planning.heuristics.lmcut, with its C kernel)",
            lmcut.build,
            derived=("task",),
            records={"window": "lmcut of the current stage"},
        ),
        Heuristic(
            "lmcut-pc",
            "LM-cut on the P^C compilation with the agent's atom pairs (planning.heuristics.lmcut_pc)",
            lmcut_pc.build,
            searches=("multi-goal",),
        ),
        Heuristic(
            "hmax",
            "h_max of the delete relaxation (planning.heuristics.hmax)",
            hmax.build,
            derived=("task",),
            records={"window": "hmax of the current stage"},
        ),
        Heuristic(
            "blind",
            "0 everywhere: Dijkstra",
            lambda bm, search: None,
            searches=("task", "multi-goal"),
            derived=("task", "multi-goal"),
        ),
    )
}


def names(search: str) -> list[str]:
    """The heuristics a search accepts, in registry order."""
    return [h.name for h in HEURISTICS.values() if search in h.searches]


def admissible_with_derived(search: str) -> list[str]:
    """The heuristics of a search that stay admissible on a model with derived predicates."""
    return [n for n in names(search) if search in HEURISTICS[n].derived]


_REPORTED: set = set()


def choose(name: str, model, search: str) -> str:
    """The heuristic a search will use for `name` on `model`: the name itself, or the stand-in its row declares
    for that search where the model lacks support (reported once per heuristic and layout on stderr; a row
    without one is a one-line error naming it). On a model with derived predicates a heuristic that is not
    admissible with them is a one-line error naming it."""
    if name not in HEURISTICS or search not in HEURISTICS[name].searches:
        raise DomainError("--heuristic", f"'{name}' is not one of {', '.join(names(search))}")
    h = HEURISTICS[name]
    if getattr(model, "axioms", None) is not None and search not in h.derived:
        ok = admissible_with_derived(search)
        preds = ", ".join(model.source.derived) if getattr(model, "source", None) is not None else "derived"
        raise DomainError(
            "--heuristic",
            f"'{name}' is not admissible with the derived predicates of "
            f"{model.name} ({preds}) in the {search} search; "
            + (
                f"use {', '.join(ok[:-1])} or {ok[-1]}"
                if len(ok) > 1
                else f"use {ok[0]}"
                if ok
                else "none of its heuristics is"
            ),
        )
    if h.supports(model):
        return name
    needs = (h.needs or "cannot run on layout {layout}").format(layout=getattr(model, "layout", ""))
    if search not in h.fallback:
        raise DomainError("--heuristic", f"'{name}' {needs} (domain {getattr(model, 'name', '')} gives none)")
    stand_in = h.fallback[search]
    key = (name, stand_in, getattr(model, "name", ""), getattr(model, "layout", ""))
    if key not in _REPORTED:
        _REPORTED.add(key)
        print(
            f"note: heuristic '{name}' {needs} (domain {key[2]} gives none): using {stand_in} instead", file=sys.stderr
        )
    return stand_in


def describe(name: str, search: str) -> str:
    """The estimate of a row in a search as results files record it."""
    return HEURISTICS[name].records.get(search, name)


_BUILT: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()  # bm -> {(name, search, builder): h}


def build(name: str, bm, search: str):
    """The heuristic `search` runs for `name` on packed states of bm: the row `choose` names (the name itself,
    or its declared stand-in) built by its builder, once per batched model and search; None for no estimate.
    "a+b": the larger of a's and b's estimates (admissible, and as good as the better)."""
    if "+" in name:
        parts = [h for h in (build(part, bm, search) for part in name.split("+")) if h is not None]
        if not parts:
            return None
        return lambda batch, goals: np.max([h(batch, goals) for h in parts], axis=0)
    row = HEURISTICS[choose(name, bm.model, search)]
    built = _BUILT.setdefault(bm, {})
    key = (row.name, search, row.build)
    if key not in built:
        built[key] = row.build(bm, search)
    return built[key]
