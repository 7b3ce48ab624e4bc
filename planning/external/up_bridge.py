"""The same layout seen through unified-planning: its problem, its simulator, state conversion.

Used as the reference that our compiled simulator is checked and timed against.
"""
from __future__ import annotations

import warnings

from unified_planning.io import PDDLReader
from unified_planning.shortcuts import get_environment

get_environment().credits_stream = None
warnings.filterwarnings("ignore", module="unified_planning")


def up_problem(model, problem_pddl: str | None = None):
    """The unified-planning problem of the layout (or of a PDDL problem text over its domain)."""
    reader = PDDLReader()
    domain = model.files["domain"].read_text()
    text = problem_pddl if problem_pddl is not None else model.files["problem"].read_text()
    problem = reader.parse_problem_string(domain, text)
    _define_unset_numbers(problem)
    return problem


def _define_unset_numbers(problem) -> None:
    """Give unset static numbers (move-cost x x) the value 0.

    unified-planning's simulator refuses undefined numeric initial values even
    where no applicable grounding reads them (a move to the same place is
    excluded by its precondition); our compiler already refuses any undefined
    cost of a reachable action.
    """
    em = problem.environment.expression_manager
    defined = problem.explicit_initial_values
    tables = {e.fluent() for e in defined if e.is_fluent_exp() and e.fluent().signature}
    for fluent in tables:
        if not fluent.type.is_real_type() and not fluent.type.is_int_type():
            continue
        for values in _tuples([list(problem.objects(p.type)) for p in fluent.signature]):
            exp = fluent(*values)
            if exp not in defined:
                problem.set_initial_value(exp, em.Int(0))


def _tuples(domains):
    if not domains:
        yield ()
        return
    for head in domains[0]:
        for rest in _tuples(domains[1:]):
            yield (head, *rest)


class UPStates:
    """Converts states of our model to unified-planning states and back."""

    def __init__(self, model, problem, simulator):
        self.model = model
        self.simulator = simulator
        em = problem.environment.expression_manager
        self.true, self.false = em.TRUE(), em.FALSE()
        self.exps = [problem.fluent(a[0])(*(problem.object(o) for o in a[1:])) for a in model.atoms]
        self.initial = simulator.get_initial_state()

    def to_up(self, state: int):
        """The unified-planning state with exactly our state's fluent atoms true."""
        return self.initial.make_child({e: self.true if state >> i & 1 else self.false
                                        for i, e in enumerate(self.exps)})

    def from_up(self, up_state) -> int:
        """Our state read off a unified-planning state (fluent atoms of our model only)."""
        s = 0
        for i, e in enumerate(self.exps):
            if up_state.get_value(e).is_true():
                s |= 1 << i
        return s


def action_name(action, params) -> str:
    """Our ground action name for a unified-planning action and its parameters."""
    return f"{action.name}({', '.join(str(p) for p in params)})"
