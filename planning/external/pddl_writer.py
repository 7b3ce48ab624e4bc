"""Write a compiled layout back out as PDDL: its domain, a state of it as a problem, a task goal.

The goal is printed from the task schema's own formula (arguments substituted,
the other parameters existential), so a planner reading it checks our grounding
of the goal rather than repeating it.

What is written is valid PDDL for every domain the front end accepts:
- the domain's `:constants` stay in the domain; a problem declares only the other objects;
- `(:metric minimize (total-cost))` and `(= (total-cost) 0)` only where the domain declares
  (total-cost) (without it every action costs 1 and planners count plan length);
- a state's derived atoms are never written (they follow from the others);
- `domain_text` writes the domain from its parsed form, with `Names` renaming what a
  stricter reader refuses (unified-planning keeps types, predicates, functions, actions
  and objects in one namespace) and, for a reader without derived predicates, each
  derived atom replaced by its definition (`inline_derived`; recursive axioms cannot be).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import count

from tarski.fstrips import AddEffect, DelEffect, UniversalEffect
from tarski.syntax import CompoundTerm, Constant, Variable
from tarski.syntax.formulas import (
    Atom,
    CompoundFormula,
    Connective,
    Contradiction,
    QuantifiedFormula,
    Quantifier,
    Tautology,
)

from planning.domain.grounding import atom_text
from planning.errors import DomainError

NUMERIC_SORTS = ("object", "number")


@dataclass
class Names:
    """Our names -> the names written out, by kind; a name not listed is written as it is."""

    types: dict = field(default_factory=dict)
    predicates: dict = field(default_factory=dict)
    functions: dict = field(default_factory=dict)
    objects: dict = field(default_factory=dict)

    @property
    def renames(self) -> bool:
        return bool(self.types or self.predicates or self.functions or self.objects)

    def type(self, name: str) -> str:
        return self.types.get(name, name)

    def predicate(self, name: str) -> str:
        return self.predicates.get(name, name)

    def function(self, name: str) -> str:
        return self.functions.get(name, name)

    def object(self, name: str) -> str:
        return self.objects.get(name, name)

    def object_back(self, written: str) -> str:
        """Our object for a written one (a planner's plan names written objects)."""
        back = {v: k for k, v in self.objects.items()}
        return back.get(written, written)

    @classmethod
    def one_namespace(cls, model) -> "Names":
        """Renames so that no two of types, predicates, functions, actions and objects share a name (as
        unified-planning needs). Actions keep their names, then objects, then predicates and functions;
        a type, predicate, function or object that meets a name already taken gets `<name>-<kind>`
        (`charge` the type beside `charge` the action becomes `charge-type`)."""
        src = model.source
        lang = src.problem.language
        taken = set(src.actions)
        out = cls()
        kinds = [
            ("object", [c.name for c in lang.constants()], out.objects),
            ("predicate", [p.name for p in lang.predicates if not p.builtin], out.predicates),
            ("function", [f.name for f in lang.functions if not f.builtin], out.functions),
            ("type", [s.name for s in lang.sorts if not s.builtin and s.name not in NUMERIC_SORTS], out.types),
        ]
        everything = set(taken) | {n for _, names, _ in kinds for n in names}
        for kind, names, table in kinds:
            for name in names:
                if name in taken:
                    new = f"{name}-{kind}"
                    k = 2
                    while new in everything or new in taken:
                        new = f"{name}-{kind}{k}"
                        k += 1
                    table[name] = new
                    everything.add(new)
                    taken.add(new)
                else:
                    taken.add(name)
        return out


IDENTITY = Names()


class Printer:
    """Formulas and effects as PDDL text, with names renamed and (optionally) derived atoms replaced by their
    definitions."""

    def __init__(self, model, names: Names = IDENTITY, inline_derived: bool = False):
        self.names = names
        self.derived = model.source.derived if inline_derived else {}
        self.where = model.files["domain"]
        self._fresh = count()
        self._stack: list = []

    def formula(self, formula, binding: dict) -> str:
        """PDDL text of a tarski formula; `binding` maps a variable to the text written for it."""
        if isinstance(formula, Tautology):
            return "(and)"
        if isinstance(formula, Contradiction):
            return "(or)"
        if isinstance(formula, Atom):
            if formula.predicate.builtin:
                name = str(formula.predicate.symbol)
            else:
                name = formula.predicate.name
                if name in self.derived:
                    return self._inline(name, [self.term(t, binding) for t in formula.subterms])
                name = self.names.predicate(name)
            args = [self.term(t, binding) for t in formula.subterms]
            return "(" + " ".join([name, *args]) + ")"
        if isinstance(formula, CompoundFormula):
            op = {Connective.And: "and", Connective.Or: "or", Connective.Not: "not"}[formula.connective]
            return f"({op} " + " ".join(self.formula(f, binding) for f in formula.subformulas) + ")"
        if isinstance(formula, QuantifiedFormula):
            inner = dict(binding)
            decl = []
            for v in formula.variables:
                name = v.symbol if not self._stack else f"{v.symbol}-{next(self._fresh)}"  # no capture when inlined
                inner[v.symbol] = name
                decl.append(f"{name} - {self.names.type(v.sort.name)}")
            q = "exists" if formula.quantifier == Quantifier.Exists else "forall"
            return f"({q} ({' '.join(decl)}) {self.formula(formula.formula, inner)})"
        raise ValueError(f"cannot print {formula}")

    def _inline(self, pred: str, args: list) -> str:
        if pred in self._stack:
            raise DomainError(
                self.where,
                f"derived predicate {pred} is recursive (through "
                f"{' -> '.join(self._stack + [pred])}): it cannot be written out "
                "for a reader without derived predicates",
            )
        self._stack.append(pred)
        try:
            bodies = [
                self.formula(schema.precondition, {p.symbol: a for p, a in zip(schema.parameters, args)})
                for schema, _ in self.derived[pred]
            ]
        finally:
            self._stack.pop()
        return bodies[0] if len(bodies) == 1 else "(or " + " ".join(bodies) + ")"

    def term(self, term, binding) -> str:
        if isinstance(term, Variable):
            return binding.get(term.symbol, term.symbol)
        if isinstance(term, Constant):
            return self.names.object(term.name)
        if isinstance(term, CompoundTerm):
            args = [self.term(t, binding) for t in term.subterms]
            return "(" + " ".join([self.names.function(term.symbol.name), *args]) + ")"
        raise ValueError(f"cannot print term {term}")

    def effects(self, effects, binding: dict) -> list[str]:
        out = []
        for eff in effects:
            if isinstance(eff, UniversalEffect):
                inner = dict(binding)
                decl = " ".join(f"{v.symbol} - {self.names.type(v.sort.name)}" for v in eff.variables)
                inner.update({v.symbol: v.symbol for v in eff.variables})
                out.append(f"(forall ({decl}) (and {' '.join(self.effects(eff.effects, inner))}))")
                continue
            if not isinstance(eff, (AddEffect, DelEffect)):
                raise ValueError(f"cannot print effect {eff}")
            lit = self.formula(eff.atom, binding)
            if isinstance(eff, DelEffect):
                lit = f"(not {lit})"
            if isinstance(eff.condition, Tautology):
                out.append(lit)
            else:
                out.append(f"(when {self.formula(eff.condition, binding)} {lit})")
        return out


def formula_text(formula, binding: dict) -> str:
    """PDDL text of a tarski formula with some variables bound to objects (names as they are)."""
    return _PLAIN.formula(formula, binding)


class _Plain(Printer):
    def __init__(self):
        self.names, self.derived, self.where, self._fresh, self._stack = IDENTITY, {}, "formula", count(), []


_PLAIN = _Plain()


def _typed(params, names: Names) -> str:
    return " ".join(f"{p.symbol} - {names.type(p.sort.name)}" for p in params)


def _number(value) -> str:
    number = float(value.symbol) if hasattr(value, "symbol") else float(value)
    return str(int(number)) if number == int(number) else str(number)


def domain_text(model, names: Names = IDENTITY, inline_derived: bool = False) -> str:
    """The layout's domain written from its parsed form: types, constants, predicates, functions, derived
    predicates (or, with `inline_derived`, their definitions in their place), actions with their costs."""
    src = model.source
    lang = src.problem.language
    pr = Printer(model, names, inline_derived)
    parent = lang.immediate_parent
    reqs = [
        ":strips",
        ":typing",
        ":negative-preconditions",
        ":disjunctive-preconditions",
        ":equality",
        ":existential-preconditions",
        ":universal-preconditions",
        ":conditional-effects",
    ]
    if src.derived and not inline_derived:
        reqs.append(":derived-predicates")
    if src.action_costs:
        reqs.append(":action-costs")
    types = [s for s in lang.sorts if not s.builtin and s.name not in NUMERIC_SORTS]
    type_lines = [
        f"{names.type(s.name)} - {names.type(parent[s].name) if parent.get(s) is not None else 'object'}" for s in types
    ]
    const = [lang.get(c) for c in src.domain_constants]
    preds = [p for p in lang.predicates if not p.builtin and not (inline_derived and p.name in src.derived)]
    pred_lines = []
    for p in preds:
        args = " ".join(f"?x{i} - {names.type(s.name)}" for i, s in enumerate(p.sort))
        pred_lines.append(f"({names.predicate(p.name)}{' ' + args if args else ''})")
    funcs = [f for f in lang.functions if not f.builtin]
    func_lines = []
    for f in funcs:
        args = " ".join(f"?x{i} - {names.type(s.name)}" for i, s in enumerate(f.domain))
        func_lines.append(f"({names.function(f.name)}{' ' + args if args else ''}) - number")
    parts = [f"(define (domain {src.domain_name})", f"  (:requirements {' '.join(reqs)})"]
    if type_lines:
        parts.append("  (:types\n    " + "\n    ".join(type_lines) + ")")
    if const:
        parts.append(
            "  (:constants\n    "
            + "\n    ".join(f"{names.object(c.name)} - {names.type(c.sort.name)}" for c in const)
            + ")"
        )
    parts.append("  (:predicates\n    " + "\n    ".join(pred_lines) + ")")
    if func_lines:
        parts.append("  (:functions\n    " + "\n    ".join(func_lines) + ")")
    if not inline_derived:
        for pred, axioms in src.derived.items():
            for schema, _ in axioms:
                head = " ".join([names.predicate(pred), _typed(schema.parameters, names)]).strip()
                parts.append(f"  (:derived ({head})\n    {pr.formula(schema.precondition, {})})")
    for schema in src.actions.values():
        effects = pr.effects(schema.effects, {})
        if src.action_costs and schema.cost is not None:
            term = schema.cost.addend
            value = _number(term) if isinstance(term, Constant) else pr.term(term, {})
            effects.append(f"(increase (total-cost) {value})")
        parts.append(
            f"  (:action {schema.name}\n    :parameters ({_typed(schema.parameters, names)})\n"
            f"    :precondition {pr.formula(schema.precondition, {})}\n"
            f"    :effect (and {' '.join(effects)}))"
        )
    return "\n".join(parts) + ")\n"


def task_goal_text(model, task, names: Names = IDENTITY, inline_derived: bool = False) -> str:
    """The task's goal as a PDDL formula: its schema's precondition, other parameters existential."""
    schema = model.source.task_schemas[task.type]
    pr = Printer(model, names, inline_derived)
    binding = {p: names.object(a) for p, a in zip(task.params, task.args)}
    body = pr.formula(schema.precondition, binding)
    free = [p for p in schema.parameters if p.symbol not in binding]
    if not free:
        return body
    return f"(exists ({_typed(free, names)}) {body})"


def problem_goal_text(model, names: Names = IDENTITY, inline_derived: bool = False) -> str:
    """The layout problem's own :goal as PDDL text."""
    return Printer(model, names, inline_derived).formula(model.source.problem.goal, {})


def problem_text(model, state: int, goal: str, name: str = "state", names: Names = IDENTITY) -> str:
    """A PDDL problem: the layout's objects (not the domain's constants), its static facts and numbers,
    the state's fluents (not its derived atoms), the goal; total-cost and the metric where the domain
    has them."""
    src = model.source
    lang = src.problem.language
    domain_constants = set(src.domain_constants)
    objects = "\n    ".join(
        f"{names.object(c.name)} - {names.type(c.sort.name)}"
        for c in lang.constants()
        if c.name not in domain_constants
    )

    def atom(key) -> str:
        return atom_text((names.predicate(key[0]), *map(names.object, key[1:])))

    init = [atom(a) for a in sorted(model.static_atoms)]
    init += [atom(a) for a in model.true_atoms(state & ~model.derived_mask)]
    zero_cost = False
    for item in src.problem.init.as_atoms():
        if isinstance(item, tuple):  # a numeric value: (term, value)
            term, value = item
            if term.symbol.name == "total-cost":
                if src.action_costs and not zero_cost:
                    init.append("(= (total-cost) 0)")
                    zero_cost = True
                continue
            args = " ".join(names.object(t.name) for t in term.subterms)
            init.append(f"(= ({names.function(term.symbol.name)}{' ' + args if args else ''}) {_number(value)})")
    if src.action_costs and not zero_cost:
        init.append("(= (total-cost) 0)")
    body = "\n    ".join(init)
    metric = "\n  (:metric minimize (total-cost))" if src.action_costs else ""
    return (
        f"(define (problem {name})\n  (:domain {src.problem.domain_name.strip()})\n"
        f"  (:objects\n    {objects})\n  (:init\n    {body})\n"
        f"  (:goal {goal}){metric})\n"
    )
