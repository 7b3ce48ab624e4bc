"""Write a state of the compiled model and a task goal back out as a PDDL problem.

The goal is printed from the task schema's own formula (arguments substituted,
the other parameters existential), so a planner reading it checks our grounding
of the goal rather than repeating it.
"""
from __future__ import annotations

from tarski.syntax import Constant, Variable
from tarski.syntax.formulas import (Atom, CompoundFormula, Connective, Contradiction,
                                    QuantifiedFormula, Quantifier, Tautology)

from planning.domain.grounding import atom_text


def formula_text(formula, binding: dict) -> str:
    """PDDL text of a tarski formula with some variables bound to objects."""
    if isinstance(formula, Tautology):
        return "(and)"
    if isinstance(formula, Contradiction):
        return "(or)"
    if isinstance(formula, Atom):
        name = str(formula.predicate.symbol) if formula.predicate.builtin else formula.predicate.name
        args = [_term_text(t, binding) for t in formula.subterms]
        return "(" + " ".join([name, *args]) + ")"
    if isinstance(formula, CompoundFormula):
        op = {Connective.And: "and", Connective.Or: "or", Connective.Not: "not"}[formula.connective]
        return f"({op} " + " ".join(formula_text(f, binding) for f in formula.subformulas) + ")"
    if isinstance(formula, QuantifiedFormula):
        inner = {k: v for k, v in binding.items() if k not in {v.symbol for v in formula.variables}}
        q = "exists" if formula.quantifier == Quantifier.Exists else "forall"
        decl = " ".join(f"{v.symbol} - {v.sort.name}" for v in formula.variables)
        return f"({q} ({decl}) {formula_text(formula.formula, inner)})"
    raise ValueError(f"cannot print {formula}")


def _term_text(term, binding) -> str:
    if isinstance(term, Variable):
        return binding.get(term.symbol, term.symbol)
    if isinstance(term, Constant):
        return term.name
    raise ValueError(f"cannot print term {term}")


def task_goal_text(model, task) -> str:
    """The task's goal as a PDDL formula: its schema's precondition, other parameters existential."""
    schema = model.source.task_schemas[task.type]
    binding = dict(zip(task.params, task.args))
    body = formula_text(schema.precondition, binding)
    free = [p for p in schema.parameters if p.symbol not in binding]
    if not free:
        return body
    decl = " ".join(f"{p.symbol} - {p.sort.name}" for p in free)
    return f"(exists ({decl}) {body})"


def problem_text(model, state: int, goal: str, name: str = "state") -> str:
    """A PDDL problem: the layout's objects and static facts, the state's fluents, the goal."""
    src = model.source
    lang = src.problem.language
    objects = "\n    ".join(f"{c.name} - {c.sort.name}" for c in lang.constants())
    init = [atom_text(a) for a in sorted(model.static_atoms)]
    init += [atom_text(a) for a in model.true_atoms(state)]
    for item in src.problem.init.as_atoms():
        if isinstance(item, tuple):  # a numeric value: (term, value)
            term, value = item
            args = " ".join(t.name for t in term.subterms)
            number = float(value.symbol)
            number = int(number) if number == int(number) else number
            init.append(f"(= ({term.symbol.name}{' ' + args if args else ''}) {number})")
    body = "\n    ".join(init)
    return (f"(define (problem {name})\n  (:domain {src.problem.domain_name.strip()})\n"
            f"  (:objects\n    {objects})\n  (:init\n    {body})\n"
            f"  (:goal {goal})\n  (:metric minimize (total-cost)))\n")
