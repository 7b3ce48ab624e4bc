"""Ground PDDL schemas against a layout: formulas to DNF over fluent atoms, schemas to variants.

Static predicates (no action or task changes them) are evaluated against the
problem's :init during grounding, so ground preconditions mention fluents only.
A precondition with a disjunction grounds into several *variants* of one ground
action: same name, same effects, one conjunctive precondition each.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import product

from tarski.fstrips import AddEffect, DelEffect, UniversalEffect
from tarski.syntax import Constant, Variable
from tarski.syntax.formulas import (
    Atom,
    CompoundFormula,
    Connective,
    Contradiction,
    QuantifiedFormula,
    Quantifier,
    Tautology,
)

from planning.errors import DomainError

AtomKey = tuple  # ("at", "cup_0", "countertop")
Conj = tuple  # (frozenset of positive AtomKeys, frozenset of negative AtomKeys)
TRUE: list = [(frozenset(), frozenset())]
FALSE: list = []


def atom_text(key: AtomKey) -> str:
    """PDDL text of a ground atom: ('at', 'a', 'b') -> '(at a b)'."""
    return "(" + " ".join(key) + ")"


def parse_atom_text(text: str) -> AtomKey:
    """'(at a b)' -> ('at', 'a', 'b'); anything but one balanced pair of parentheses around
    names is a ValueError (an unbalanced parenthesis, a nested term, an empty atom)."""
    t = text.strip()
    inner = t[1:-1] if t.startswith("(") and t.endswith(")") else None
    if inner is None or "(" in inner or ")" in inner:
        raise ValueError(f"not a ground atom like (at cup_0 shelf): {text!r}")
    parts = inner.split()
    if not parts:
        raise ValueError(f"not a ground atom like (at cup_0 shelf): {text!r} is empty")
    return tuple(parts)


@dataclass
class GroundVariant:
    """One conjunctive way to apply a ground schema."""

    name: str  # "move(countertop, fountain)"
    schema: str
    args: tuple  # object names, in parameter order
    pos: frozenset  # precondition atoms that must hold
    neg: frozenset  # precondition atoms that must not hold
    add: frozenset = frozenset()
    dele: frozenset = frozenset()
    cond: list = field(default_factory=list)  # [(pos, neg, add, dele)]: conditional effects


class Grounder:
    """Knows the layout's objects, types and static facts; turns formulas into DNF."""

    def __init__(self, problem, fluent_predicates: set[str], where, derived=()):
        """`derived`: the derived predicates (among the fluents: their atoms are state bits the axioms set)."""
        self.where = where
        self.derived = set(derived)
        self.language = problem.language
        self.fluents = fluent_predicates
        self.objects = [c.name for c in self.language.constants()]
        self.static = {
            (a.predicate.name, *(t.name for t in a.subterms))
            for a in problem.init.as_atoms()
            if isinstance(a, Atom) and a.predicate.name not in fluent_predicates
        }
        self._parents = self.language.immediate_parent
        self._by_sort: dict[str, list[str]] = {}

    def objects_of(self, sort_name: str) -> list[str]:
        """Objects of a type (its subtypes included), in the problem's declaration order."""
        if sort_name not in self._by_sort:
            self._by_sort[sort_name] = [
                c.name for c in self.language.constants() if self._is_subsort(c.sort, sort_name)
            ]
        return self._by_sort[sort_name]

    def _is_subsort(self, sort, name: str) -> bool:
        while sort is not None:
            if sort.name == name:
                return True
            sort = self._parents.get(sort)
        return False

    # ---- formulas -------------------------------------------------------
    def dnf(self, formula, binding: dict, negated: bool = False) -> list:
        """The formula under a binding, as a list of (pos, neg) conjunctions over fluent atoms."""
        if isinstance(formula, Tautology):
            return FALSE if negated else TRUE
        if isinstance(formula, Contradiction):
            return TRUE if negated else FALSE
        if isinstance(formula, Atom):
            return self._atom(formula, binding, negated)
        if isinstance(formula, CompoundFormula):
            c = formula.connective
            if c == Connective.Not:
                return self.dnf(formula.subformulas[0], binding, not negated)
            parts = [self.dnf(f, binding, negated) for f in formula.subformulas]
            conjunctive = (c == Connective.And) != negated
            return _and_all(parts) if conjunctive else _or_all(parts)
        if isinstance(formula, QuantifiedFormula):
            choices = [self.objects_of(v.sort.name) for v in formula.variables]
            parts = []
            for values in product(*choices):
                inner = dict(binding)
                inner.update({v.symbol: o for v, o in zip(formula.variables, values)})
                parts.append(self.dnf(formula.formula, inner, negated))
            universal = (formula.quantifier == Quantifier.Forall) != negated
            return _and_all(parts) if universal else _or_all(parts)
        raise DomainError(self.where, f"unsupported formula {formula}")

    def ground_atom(self, atom: Atom, binding: dict) -> AtomKey:
        name = str(atom.predicate.symbol) if atom.predicate.builtin else atom.predicate.name
        return (name, *(self._term(t, binding) for t in atom.subterms))

    def _term(self, term, binding):
        if isinstance(term, Variable):
            if term.symbol not in binding:
                raise DomainError(self.where, f"free variable {term.symbol}")
            return binding[term.symbol]
        if isinstance(term, Constant):
            return term.name
        raise DomainError(self.where, f"unsupported term {term} (only objects and variables)")

    def _atom(self, atom: Atom, binding, negated):
        key = self.ground_atom(atom, binding)
        name = key[0]
        if atom.predicate.builtin:
            if str(atom.predicate.symbol) not in ("=", "!="):
                raise DomainError(self.where, f"unsupported built-in predicate {atom.predicate.symbol}")
            truth = (key[1] == key[2]) == (str(atom.predicate.symbol) == "=")
        elif name in self.fluents:
            lit = (frozenset([key]), frozenset()) if not negated else (frozenset(), frozenset([key]))
            return [lit]
        else:
            truth = key in self.static
        return TRUE if truth != negated else FALSE

    # ---- schemas --------------------------------------------------------
    def ground_schema(self, schema, fixed: dict | None = None) -> list[GroundVariant]:
        """Every variant of every binding of a schema; `fixed` pins some parameters."""
        fixed = fixed or {}
        params = list(schema.parameters)
        domains = [[fixed[p.symbol]] if p.symbol in fixed else self.objects_of(p.sort.name) for p in params]
        variants = []
        for values in product(*domains):
            binding = {p.symbol: v for p, v in zip(params, values)}
            pre = self.dnf(schema.precondition, binding)
            if not pre:
                continue
            add, dele, cond = self._effects(schema.effects, binding)
            name = f"{schema.name}({', '.join(values)})"
            for pos, neg in pre:
                variants.append(GroundVariant(name, schema.name, tuple(values), pos, neg, add, dele, cond))
        return variants

    def _effects(self, effects, binding):
        add, dele, cond = set(), set(), []
        for eff in effects:
            if isinstance(eff, UniversalEffect):
                choices = [self.objects_of(v.sort.name) for v in eff.variables]
                for values in product(*choices):
                    inner = dict(binding)
                    inner.update({v.symbol: o for v, o in zip(eff.variables, values)})
                    a, d, c = self._effects(eff.effects, inner)
                    add |= a
                    dele |= d
                    cond += c
                continue
            if not isinstance(eff, (AddEffect, DelEffect)):
                raise DomainError(self.where, f"unsupported effect {eff} (only add, delete, when, forall)")
            key = self.ground_atom(eff.atom, binding)
            is_add = isinstance(eff, AddEffect)
            for pos, neg in self.dnf(eff.condition, binding):
                if not pos and not neg:
                    (add if is_add else dele).add(key)
                else:
                    cond.append(
                        (
                            pos,
                            neg,
                            frozenset([key]) if is_add else frozenset(),
                            frozenset() if is_add else frozenset([key]),
                        )
                    )
        return frozenset(add), frozenset(dele), cond


def _and_all(parts: list[list]) -> list:
    result = TRUE
    for part in parts:
        if not part:
            return FALSE
        merged = []
        for p1, n1 in result:
            for p2, n2 in part:
                pos, neg = p1 | p2, n1 | n2
                if not pos & neg:
                    merged.append((pos, neg))
        result = _minimal(merged)
        if not result:
            return FALSE
    return result


def _or_all(parts: list[list]) -> list:
    return _minimal([c for part in parts for c in part])


def _minimal(conjs: list) -> list:
    """Drop duplicate and subsumed conjunctions, keeping the first occurrence order."""
    out = []
    for pos, neg in conjs:
        if any(p <= pos and n <= neg for p, n in out):
            continue
        out = [(p, n) for p, n in out if not (pos <= p and neg <= n)]
        out.append((pos, neg))
    return out
