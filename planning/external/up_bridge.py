"""The same layout seen through unified-planning: its problem, its simulator, state conversion.

Used as the reference that our compiled simulator is checked and timed against, and as
the way to Fast Downward. unified-planning reads less than PDDL allows: it keeps types,
predicates, functions, actions and objects in one namespace, and has no derived
predicates. Where a domain needs it, the domain is written out again
(planning.external.pddl_writer) with clashing names renamed (`up_names`) and each
derived atom replaced by its definition; otherwise the author's own files are read as
they are. Plans and states are mapped back through the same names.
"""

from __future__ import annotations

import functools
import warnings
import weakref

from planning.errors import DomainError


@functools.cache
def up():
    """unified-planning, imported on first use (it takes about a second to import, which a command that never
    calls it should not pay), with its credits banner and warnings silenced."""
    import unified_planning.engines
    import unified_planning.io
    import unified_planning.shortcuts

    unified_planning.shortcuts.get_environment().credits_stream = None
    warnings.filterwarnings("ignore", module="unified_planning")
    return unified_planning


_NAMES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def up_names(model):
    """The renames unified-planning needs for this layout (none for most domains); computed once per model."""
    from planning.external.pddl_writer import Names

    if model not in _NAMES:
        _NAMES[model] = Names.one_namespace(model)
    return _NAMES[model]


def rewritten(model) -> bool:
    """True where unified-planning cannot read the author's files as they are: clashing names or derived
    predicates (then the domain and problems it reads are written by planning.external.pddl_writer)."""
    return up_names(model).renames or bool(model.source.derived)


def up_domain_text(model) -> str:
    """The domain text unified-planning reads: the author's file, or the domain written for it."""
    from planning.external.pddl_writer import domain_text

    if not rewritten(model):
        return model.files["domain"].read_text()
    return domain_text(model, up_names(model), inline_derived=True)


def up_goal_text(model, task) -> str:
    """A task's goal as unified-planning reads it (renamed, derived atoms replaced by their definitions)."""
    from planning.external.pddl_writer import task_goal_text

    return task_goal_text(model, task, up_names(model), inline_derived=bool(model.source.derived))


def up_problem_text(model, state: int, goal: str) -> str:
    """A problem over the layout for unified-planning: the state and a goal given as unified-planning's text."""
    from planning.external.pddl_writer import problem_text

    return problem_text(model, state, goal, names=up_names(model))


def up_problem(model, problem_pddl: str | None = None):
    """The unified-planning problem of the layout (or of a PDDL problem text over its domain, written with
    `up_names`: up_problem_text)."""
    from planning.external.pddl_writer import problem_goal_text

    reader = up().io.PDDLReader()
    domain = up_domain_text(model)
    if problem_pddl is not None:
        text = problem_pddl
    elif not rewritten(model):
        text = model.files["problem"].read_text()
    else:
        goal = problem_goal_text(model, up_names(model), inline_derived=True)
        text = up_problem_text(model, model.init, goal)
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


def up_atom(model, problem, key):
    """unified-planning's expression for one of our atom keys, through the layout's renames."""
    names = up_names(model)
    return problem.fluent(names.predicate(key[0]))(*(problem.object(names.object(o)) for o in key[1:]))


class UPStates:
    """Converts states of our model to unified-planning states and back (derived atoms: recomputed by ours)."""

    def __init__(self, model, problem, simulator):
        self.model = model
        self.problem = problem
        self.simulator = simulator
        em = problem.environment.expression_manager
        self.true, self.false = em.TRUE(), em.FALSE()
        derived = model.derived_mask
        self.bits = [i for i in range(model.n_atoms) if not derived >> i & 1]
        self.exps = [up_atom(model, problem, model.atoms[i]) for i in self.bits]
        self.initial = simulator.get_initial_state()

    def to_up(self, state: int):
        """The unified-planning state with exactly our state's fluent atoms true."""
        return self.initial.make_child(
            {e: self.true if state >> i & 1 else self.false for i, e in zip(self.bits, self.exps)}
        )

    def from_up(self, up_state) -> int:
        """Our state read off a unified-planning state (fluent atoms of our model only)."""
        s = 0
        for i, e in zip(self.bits, self.exps):
            if up_state.get_value(e).is_true():
                s |= 1 << i
        return self.model.derive(s)

    def replay(self, state: int, plan: list[int]) -> int:
        """Our ground actions applied one by one by unified-planning's simulator from our state: the state it
        ends in, read back; a DomainError naming the first action it finds inapplicable."""
        problem = self.problem
        names = up_names(self.model)
        up_state = self.to_up(state)
        for a in plan:
            action = problem.action(self.model.action_schema[a])
            params = [problem.object(names.object(o)) for o in self.model.action_args[a]]
            if not self.simulator.is_applicable(up_state, action, params):
                raise DomainError(self.model.actions[a], "not applicable under unified-planning")
            up_state = self.simulator.apply(up_state, action, params)
        return self.from_up(up_state)


def action_name(action, params, model=None) -> str:
    """Our ground action name for a unified-planning action and its parameters (objects renamed back
    through the model's `up_names` where a model is given)."""
    back = up_names(model).object_back if model is not None else str
    return f"{action.name}({', '.join(back(str(p)) for p in params)})"
