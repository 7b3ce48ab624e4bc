"""Admissible heuristics for the exact searches, behind one registry.

Each entry says which searches it serves ("task": one task's optimal plan,
planning.search.optimal; "window": a clairvoyant window of K tasks,
planning.search.joint; "multi-goal": every task from one state, the labelling
oracle) and whether a compiled model supports it. Pattern databases need the
domain's room locations; on a model without them a search falls back to the
entry's stand-in. The searches build the heuristic object themselves; this
table is the one list of names the command lines offer.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from planning.errors import DomainError

SEARCHES = ("task", "window", "multi-goal")


@dataclass(frozen=True)
class Heuristic:
    """A registry row: what the heuristic is, where it applies, what stands in where the model lacks support."""

    name: str
    summary: str
    searches: tuple = SEARCHES
    supports: Callable = lambda model: True
    fallback: dict = field(default_factory=dict)     # search -> heuristic used where unsupported


HEURISTICS = {h.name: h for h in (
    Heuristic("pdb", "pattern databases: exact distances in projections onto a few objects (planning.heuristics.pdb)",
              supports=lambda model: bool(model.locations),
              fallback={"task": "lmcut", "window": "layered", "multi-goal": "lmcut"}),
    Heuristic("lmcut", "LM-cut of the delete relaxation (planning.heuristics.lmcut, with its C kernel)"),
    Heuristic("lmcut-pc", "LM-cut on the P^C compilation with the agent's atom pairs (planning.heuristics.lmcut_pc)",
              searches=("multi-goal",)),
    Heuristic("hmax", "h_max of the delete relaxation (planning.heuristics.hmax)"),
    Heuristic("layered", "LM-cut on the window's stage-layered relaxation (planning.search.joint)",
              searches=("window",)),
    Heuristic("blind", "0 everywhere: Dijkstra", searches=("multi-goal",)),
)}


def names(search: str) -> list[str]:
    """The heuristics a search accepts, in registry order."""
    return [h.name for h in HEURISTICS.values() if search in h.searches]


def choose(name: str, model, search: str) -> str:
    """The heuristic a search will use for `name` on `model`: the name itself, or its stand-in where unsupported."""
    if name not in HEURISTICS or search not in HEURISTICS[name].searches:
        raise DomainError("--heuristic", f"'{name}' is not one of {', '.join(names(search))}")
    h = HEURISTICS[name]
    return name if h.supports(model) else h.fallback.get(search, "lmcut")
