"""Admissible heuristics for the exact searches, behind one registry.

Each entry says which searches it serves ("task": one task's optimal plan,
planning.search.optimal; "window": a clairvoyant window of K tasks,
planning.search.joint; "multi-goal": every task from one state, the labelling
oracle) and whether a compiled model supports it. Pattern databases need the
domain's room locations; on a model without them a search falls back to the
entry's stand-in, and says so once on stderr. The searches build the heuristic
object themselves; this table is the one list of names the command lines offer.

Derived predicates (planning.domain.axioms): blind stays admissible everywhere;
h_max and LM-cut stay admissible in the one-task search, which computes them on
`relaxed_view` (each ground axiom a zero-cost action, a negated derived atom free:
a relaxation of the delete relaxation); pattern databases, LM-cut on P^C and the
window's layered LM-cut would read derived atoms as atoms no action reaches, so on
such a model they are refused by name rather than run inadmissibly.
"""
from __future__ import annotations

import sys
from dataclasses import dataclass, field
from types import SimpleNamespace
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
    needs: str = ""                                  # what `supports` asks of a model, for the fallback's report
    derived: tuple = ()                              # the searches where it stays admissible with derived predicates


HEURISTICS = {h.name: h for h in (
    Heuristic("pdb", "pattern databases: exact distances in projections onto a few objects (planning.heuristics.pdb)",
              supports=lambda model: bool(model.locations),
              fallback={"task": "lmcut", "window": "layered", "multi-goal": "lmcut"},
              needs="needs the locations that rooms under [layouts.{layout}] in domain.toml list"),
    Heuristic("lmcut", "LM-cut of the delete relaxation (planning.heuristics.lmcut, with its C kernel)",
              derived=("task",)),
    Heuristic("lmcut-pc", "LM-cut on the P^C compilation with the agent's atom pairs (planning.heuristics.lmcut_pc)",
              searches=("multi-goal",)),
    Heuristic("hmax", "h_max of the delete relaxation (planning.heuristics.hmax)", derived=("task",)),
    Heuristic("layered", "LM-cut on the window's stage-layered relaxation (planning.search.joint)",
              searches=("window",)),
    Heuristic("blind", "0 everywhere: Dijkstra", searches=("task", "multi-goal"), derived=("task", "multi-goal")),
)}


def names(search: str) -> list[str]:
    """The heuristics a search accepts, in registry order."""
    return [h.name for h in HEURISTICS.values() if search in h.searches]


def admissible_with_derived(search: str) -> list[str]:
    """The heuristics of a search that stay admissible on a model with derived predicates."""
    return [n for n in names(search) if search in HEURISTICS[n].derived]


_REPORTED: set = set()


def choose(name: str, model, search: str) -> str:
    """The heuristic a search will use for `name` on `model`: the name itself, or its stand-in where unsupported
    (reported once per heuristic and layout on stderr). On a model with derived predicates a heuristic that
    is not admissible with them is a one-line error naming it."""
    if name not in HEURISTICS or search not in HEURISTICS[name].searches:
        raise DomainError("--heuristic", f"'{name}' is not one of {', '.join(names(search))}")
    h = HEURISTICS[name]
    if getattr(model, "axioms", None) is not None and search not in h.derived:
        ok = admissible_with_derived(search)
        preds = ", ".join(model.source.derived) if getattr(model, "source", None) is not None else "derived"
        raise DomainError("--heuristic", f"'{name}' is not admissible with the derived predicates of "
                          f"{model.name} ({preds}) in the {search} search; "
                          + (f"use {', '.join(ok[:-1])} or {ok[-1]}" if len(ok) > 1 else f"use {ok[0]}" if ok
                             else "none of its heuristics is"))
    if h.supports(model):
        return name
    stand_in = h.fallback.get(search, "lmcut")
    key = (name, stand_in, getattr(model, "name", ""), getattr(model, "layout", ""))
    if key not in _REPORTED:
        _REPORTED.add(key)
        needs = (h.needs or "cannot run on layout {layout}").format(layout=key[3])
        print(f"note: heuristic '{name}' {needs} (domain {key[2]} gives none): using {stand_in} instead",
              file=sys.stderr)
    return stand_in


def relaxed_view(model):
    """The model as the delete-relaxation heuristics (HMax, LMCut) are to read it: the model itself, or, where it
    has derived predicates, its operators plus one zero-cost operator per ground axiom (body -> head) and one
    that makes every negated derived atom free. Relaxed reachability then follows the axioms; giving the
    negated atoms away only lowers the estimates, so both heuristics stay admissible."""
    axioms = getattr(model, "axioms", None)
    if axioms is None:
        return model
    from planning.domain.model import Op

    ops, op_action, cost = list(model.ops), list(model.op_action), list(model.action_cost)
    free = len(cost)
    cost.append(0)
    for stratum in axioms.strata:
        for pos, neg, head in stratum:
            ops.append(Op(pos, neg, head, 0))
            op_action.append(free)
    ops.append(Op(0, 0, 0, axioms.mask))
    op_action.append(free)
    return SimpleNamespace(n_atoms=model.n_atoms, atoms=model.atoms, ops=ops, op_action=op_action,
                           action_cost=cost, name=model.name, layout=model.layout)
