"""The focused candidate generator of the one-task GNN's native selection, declared as domain data.

Prior work's evaluation (Talukder et al. 2024) builds the augmented candidates of a task around its
myopic plan, not from the whole map. A domain declares the rule in `domain.toml`:

    [gnn.candidates]
    hops = 1                              # the region: the plan's locations and those within this many base hops
    max_clauses = 10                      # the first this many clauses are planned (no cost sort)
    relevant_when_nowhere = ["machinewater"]   # objects of these types are relevant while at no location

    [[gnn.candidates.clause]]             # one clause family, in the order the families are tried
    name = "clean"
    roles = { "?o" = "washable" }         # typed roles; the FIRST is the relevant object the clause is about
    when = "(dirty ?o)"                   # a condition on the current state (default: always)
    goal = "(not (dirty ?o))"             # the preparatory clause: a conjunction of literals

For a state, its task's myopic plan (cut where the task first holds) and the path of states it makes:

  * the *region* is the locations the agent stands at along the path plus every location within
    `hops` x the base hop of one of them, the base hop being the smallest move cost of the layout
    (distances are shortest paths over the move actions' costs);
  * the *relevant objects* are those the plan's actions name, those whose location now (through
    containers; a held object is where the agent is) lies in the region, and those of the
    `relevant_when_nowhere` types that are at no location now (a used-up resource);
  * for each relevant object in sorted name order, each family in declaration order whose first role's
    type the object has, and each binding of the other roles (objects of their types, in sorted name
    order), where `when` holds in the state, the family's goal instantiated is one clause, unless an
    earlier one had the same goal, it holds already, or it can never hold (a static fact denied).

`when` is a PDDL-like formula: `and`, `or`, `not` and atoms over the domain's predicates (fluent or
static; an atom the layout never reaches is false), the roles and object names, and two predicates of
the generator: `(in-region ?x)` (a location in the region, or an object whose location is) and
`(nowhere ?x)` (an object at no location: not at one, not held, not in something that is).
`goal` is `(and ...)` of atoms and negated atoms over the domain's predicates.

A domain without the table keeps the clause-library candidates of `learning.agents.gnn_native` (see there).
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass

from planning.errors import DomainError

# A task with a clause (the dataset's clauses, gnn-native's candidates) is planned with the larger of the pattern databases' estimate and LM-cut's. Neither is
# better alone: on a three-room state, make-coffee with the jar brought to the countertop closes 1.8 million
# states with the PDBs and 138,421 with LM-cut, and make-coffee with a bowl moved 495,506 and 2,431; but on
# another, wash(bowls) with its clauses takes the PDBs seconds and LM-cut minutes. All are admissible: the
# cost is the same.
JOINT_HEURISTIC = "pdb+lmcut"

TABLE_KEYS = ("hops", "max_clauses", "relevant_when_nowhere", "clause")
FAMILY_KEYS = ("name", "roles", "when", "goal")
GENERATOR_PREDICATES = {"in-region": 1, "nowhere": 1}
DEFAULT_HOPS = 1
DEFAULT_MAX_CLAUSES = 10


@dataclass(frozen=True)
class Clause:
    """One preparatory clause: its text, its family, the relevant object it is about, and its literals as masks."""

    text: str
    family: str
    obj: str
    pos: int
    neg: int


def parse_formula(text: str):
    """A PDDL-like formula as nested tuples: ('and', f, ...), ('or', ...), ('not', f), ('atom', pred, args)."""
    tokens = text.replace("(", " ( ").replace(")", " ) ").split()
    if not tokens:
        raise ValueError("an empty formula")
    pos = 0

    def expr():
        nonlocal pos
        if pos >= len(tokens) or tokens[pos] != "(":
            raise ValueError(f"expected '(' at {' '.join(tokens[pos : pos + 3]) or 'the end'}")
        pos += 1
        if pos >= len(tokens) or tokens[pos] in "()":
            raise ValueError("expected a predicate or and/or/not after '('")
        head = tokens[pos].lower()
        pos += 1
        if head in ("and", "or", "not"):
            parts = []
            while pos < len(tokens) and tokens[pos] == "(":
                parts.append(expr())
            if pos >= len(tokens) or tokens[pos] != ")":
                raise ValueError(f"({head} ...) takes formulas only")
            pos += 1
            if head == "not" and len(parts) != 1:
                raise ValueError("(not ...) takes one formula")
            return (head, *parts)
        args = []
        while pos < len(tokens) and tokens[pos] not in "()":
            args.append(tokens[pos])
            pos += 1
        if pos >= len(tokens) or tokens[pos] != ")":
            raise ValueError(f"({head} ...) takes names only")
        pos += 1
        return ("atom", head, tuple(args))

    out = expr()
    if pos != len(tokens):
        raise ValueError(f"text after the formula: {' '.join(tokens[pos:])}")
    return out


def _atoms(f):
    if f[0] == "atom":
        yield f
    else:
        for g in f[1:]:
            yield from _atoms(g)


def _literals(f) -> list[tuple[bool, str, tuple]]:
    """A goal formula as [(positive, predicate, args)]; only a conjunction of literals is accepted."""
    if f[0] == "atom":
        return [(True, f[1], f[2])]
    if f[0] == "not" and f[1][0] == "atom":
        return [(False, f[1][1], f[1][2])]
    if f[0] == "and":
        return [lit for g in f[1:] for lit in _literals(g)]
    raise ValueError("a goal is an atom, a negated atom or (and ...) of them")


class Family:
    """One clause family of the table, checked against the model."""

    def __init__(self, model, entry: dict, where: str, predicates: dict, types: set | None):
        if not isinstance(entry, dict):
            raise DomainError(model.files["config"], f"{where} is {entry!r}, not a table")
        unknown = [k for k in entry if k not in FAMILY_KEYS]
        if unknown:
            raise DomainError(
                model.files["config"], f"{where} has unknown key '{unknown[0]}' (known: {', '.join(FAMILY_KEYS)})"
            )
        for key in ("name", "roles", "goal"):
            if key not in entry:
                raise DomainError(model.files["config"], f"{where} has no '{key}'")
        self.name = entry["name"]
        if not isinstance(self.name, str) or not self.name:
            raise DomainError(model.files["config"], f"{where} name is {self.name!r}, not a name")
        where = f"{where} ({self.name})"
        roles = entry["roles"]
        if not isinstance(roles, dict) or not roles:
            raise DomainError(model.files["config"], f"{where} roles is {roles!r}, not a table of '?var' = type(s)")
        self.roles: list[tuple[str, tuple]] = []
        for var, spec in roles.items():
            names = (spec,) if isinstance(spec, str) else tuple(spec) if isinstance(spec, list) else None
            if not var.startswith("?") or not names or not all(isinstance(t, str) for t in names):
                raise DomainError(
                    model.files["config"],
                    f"{where} role {var!r} = {spec!r}: a role is '?var' = a type or a list of types",
                )
            bad = [t for t in names if types is not None and t not in types]
            if bad:
                raise DomainError(
                    model.files["config"],
                    f"{where} role {var} names type '{bad[0]}', which the domain does not declare",
                )
            self.roles.append((var, names))
        self.vars = [v for v, _ in self.roles]
        try:
            self.when = parse_formula(entry["when"]) if entry.get("when") else None
            self.goal = _literals(parse_formula(entry["goal"]))
        except (ValueError, AttributeError, TypeError) as e:
            raise DomainError(model.files["config"], f"{where}: {e}") from None
        for f, allowed in (
            (self.when, {**predicates, **GENERATOR_PREDICATES}),
            (("and", *(("atom", p, a) for _, p, a in self.goal)), predicates),
        ):
            if f is None:
                continue
            for _, pred, args in _atoms(f):
                if pred not in allowed:
                    raise DomainError(
                        model.files["config"],
                        f"{where} names predicate '{pred}', which is not "
                        + ("one of the domain's" if pred in GENERATOR_PREDICATES else "declared"),
                    )
                if allowed[pred] != len(args):
                    raise DomainError(
                        model.files["config"], f"{where}: ({pred} ...) takes {allowed[pred]} arguments, not {len(args)}"
                    )
                for a in args:
                    if a.startswith("?") and a not in self.vars:
                        raise DomainError(model.files["config"], f"{where} uses {a}, which is not one of its roles")
                    if not a.startswith("?") and a not in model.objects:
                        raise DomainError(
                            model.files["config"],
                            f"{where} names '{a}', which is not an object of layout {model.layout}",
                        )

    def describe(self) -> dict:
        return {
            "name": self.name,
            "roles": {v: list(t) for v, t in self.roles},
            "when": _text(self.when) if self.when else None,
            "goal": _text(("and", *((("atom", p, a) if s else ("not", ("atom", p, a))) for s, p, a in self.goal))),
        }


def _text(f) -> str:
    if f[0] == "atom":
        return f"({' '.join((f[1], *f[2]))})"
    if f[0] == "and" and len(f) == 2:
        return _text(f[1])
    return f"({f[0]} {' '.join(_text(g) for g in f[1:])})"


class Region:
    """Where the agent is along a path and where one move takes it, and where a clause's places are."""

    def __init__(self, model):
        from planning.domain.roles import agent_relations, position_predicates

        self.model = model
        locs = set(model.locations)
        self.locations = locs
        self.position = {i: a[1] for i, a in enumerate(model.atoms) if a[0] in position_predicates(model, locs)}
        held = agent_relations(model, locs)
        self.held = {i: a[1] for i, a in enumerate(model.atoms) if a[0] in held and len(a) == 2}
        self.placed = {
            i: (a[1], a[2])
            for i, a in enumerate(model.atoms)
            if len(a) == 3 and a[1] not in locs and (a[2] in locs or a[2] in model.objects)
        }
        pos_mask = sum(1 << i for i in self.position)
        self.moves: dict[str, set] = {}
        for op in model.ops:
            src = [self.position[i] for i in _bits(op.pos & pos_mask)]
            dst = [self.position[i] for i in _bits(op.add & pos_mask)]
            for a in src:
                self.moves.setdefault(a, set()).update(b for b in dst if b != a)

    def agent_at(self, state: int) -> str | None:
        return next((loc for i, loc in self.position.items() if state >> i & 1), None)

    def around(self, path: list[int]) -> set:
        """The locations the agent stands at along the path, plus those one move away."""
        on = {loc for s in path if (loc := self.agent_at(s)) is not None}
        return on | {b for a in on for b in self.moves.get(a, ())}

    def where(self, state: int, obj: str) -> str | None:
        """The location of an object now: through containers; a held object is at the agent's location."""
        at = {}
        for i, (o, x) in self.placed.items():
            if state >> i & 1:
                at.setdefault(o, x)
        seen, cur = set(), obj
        while cur not in self.locations and cur not in seen:
            seen.add(cur)
            if any(state >> i & 1 and o == cur for i, o in self.held.items()):
                return self.agent_at(state)
            if cur not in at:
                return None
            cur = at[cur]
        return cur if cur in self.locations else None

    def places(self, state: int, atoms) -> set:
        """The locations a clause's atoms name, and where the objects they name are now."""
        out = set()
        for i in atoms:
            for arg in self.model.atoms[i][1:]:
                out.add(arg if arg in self.locations else self.where(state, arg))
        out.discard(None)  # an object that is nowhere now (the machine water, used up)
        return out


class FocusedCandidates:
    """The generator of a domain's `[gnn.candidates]` table (see the module docstring)."""

    def __init__(self, model, table: dict):

        cfg = model.files["config"]
        if not isinstance(table, dict):
            raise DomainError(cfg, f"[gnn.candidates] is {table!r}, not a table")
        unknown = [k for k in table if k not in TABLE_KEYS]
        if unknown:
            raise DomainError(cfg, f"[gnn.candidates] has unknown key '{unknown[0]}' (known: {', '.join(TABLE_KEYS)})")
        self.model = model
        self.hops = table.get("hops", DEFAULT_HOPS)
        self.max_clauses = table.get("max_clauses", DEFAULT_MAX_CLAUSES)
        for key, value in (("hops", self.hops), ("max_clauses", self.max_clauses)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
                raise DomainError(cfg, f"[gnn.candidates] {key} is {value!r}, not a number at least 0")
        if isinstance(self.max_clauses, float) and not self.max_clauses.is_integer():
            raise DomainError(cfg, f"[gnn.candidates] max_clauses is {self.max_clauses!r}, not a whole number")
        self.max_clauses = int(self.max_clauses)
        lang = model.source.problem.language if model.source is not None else None
        types = {s.name for s in lang.sorts} if lang is not None else None
        predicates = (
            {str(p.name): p.arity for p in lang.predicates if isinstance(p.name, str)}
            if lang is not None
            else {a[0]: len(a) - 1 for a in [*model.atoms, *model.static_atoms]}
        )
        nowhere = table.get("relevant_when_nowhere", [])
        if not isinstance(nowhere, list) or not all(isinstance(t, str) for t in nowhere):
            raise DomainError(cfg, f"[gnn.candidates] relevant_when_nowhere is {nowhere!r}, not a list of types")
        bad = [t for t in nowhere if types is not None and t not in types]
        if bad:
            raise DomainError(
                cfg, f"[gnn.candidates] relevant_when_nowhere names type '{bad[0]}', which the domain does not declare"
            )
        self.nowhere_types = list(nowhere)
        entries = table.get("clause", [])
        if not isinstance(entries, list) or not entries:
            raise DomainError(cfg, "[gnn.candidates] declares no [[gnn.candidates.clause]] family")
        self.families = [
            Family(model, e, f"[[gnn.candidates.clause]] {k + 1}", predicates, types) for k, e in enumerate(entries)
        ]
        self.region_model = Region(model)
        self.locations = set(model.locations)
        if not self.locations:
            raise DomainError(cfg, f"[gnn.candidates] needs the layout's locations ([layouts.{model.layout}] rooms)")
        self.distance, self.base_hop = self._distances()
        self.static = set(model.static_atoms)
        self._of: dict[tuple, set] = {}

    @classmethod
    def from_model(cls, model) -> "FocusedCandidates | None":
        """The generator the domain declares, or None for a domain without [gnn.candidates]."""
        gnn = model.config.get("gnn")
        if gnn is None or (isinstance(gnn, dict) and "candidates" not in gnn):
            return None
        if not isinstance(gnn, dict):
            raise DomainError(model.files["config"], f"[gnn] is {gnn!r}, not a table")
        return cls(model, gnn["candidates"])

    # ---- the region -------------------------------------------------------------------------------
    def _distances(self) -> tuple[dict, int]:
        """Shortest move-cost distances between locations, and the smallest move cost (the base hop)."""
        r, m = self.region_model, self.model
        pos_mask = sum(1 << i for i in r.position)
        edges: dict[str, dict[str, int]] = {}
        for op, a in zip(m.ops, m.op_action):
            src = [r.position[i] for i in _bits(op.pos & pos_mask)]
            dst = [r.position[i] for i in _bits(op.add & pos_mask)]
            for x in src:
                for y in dst:
                    if x != y:
                        c = int(m.action_cost[a])
                        edges.setdefault(x, {})[y] = min(edges.get(x, {}).get(y, c), c)
        costs = [c for e in edges.values() for c in e.values() if c > 0]
        base = min(costs) if costs else 1
        dist = {}
        for src in self.locations:
            d = {src: 0}
            heap = [(0, src)]
            while heap:
                du, u = heapq.heappop(heap)
                if du > d.get(u, du):
                    continue
                for v, c in edges.get(u, {}).items():
                    if du + c < d.get(v, 1 << 62):
                        d[v] = du + c
                        heapq.heappush(heap, (du + c, v))
            dist[src] = d
        return dist, base

    def path_locations(self, path: list[int]) -> set:
        """The locations the agent stands at along the path (its first state included)."""
        return {loc for s in path if (loc := self.region_model.agent_at(s)) is not None}

    def region(self, path: list[int]) -> set:
        """The path's locations plus those within hops x the base hop of one of them."""
        on = self.path_locations(path)
        reach = self.hops * self.base_hop
        return on | {b for a in on for b, d in self.distance.get(a, {}).items() if d <= reach}

    # ---- relevant objects -------------------------------------------------------------------------
    def _objects_of(self, types: tuple) -> set:
        if types not in self._of:
            self._of[types] = {o for t in types for o in self.model.objects_of(t)}
        return self._of[types]

    def named(self, plan) -> set:
        """The objects (not locations) the plan's actions name."""
        return {x for a in plan for x in self.model.action_args[a] if x not in self.locations}

    def nowhere(self, state: int, obj: str) -> bool:
        return obj not in self.locations and self.region_model.where(state, obj) is None

    def relevant(self, state: int, plan, region: set) -> set:
        """Objects the plan names, objects located in the region now, and the relevant_when_nowhere types' objects at no location."""
        out = self.named(plan)
        for o in self.model.objects:
            if o not in self.locations and self.region_model.where(state, o) in region:
                out.add(o)
        for o in self._objects_of(tuple(self.nowhere_types)):
            if self.nowhere(state, o):
                out.add(o)
        return out

    # ---- clauses ----------------------------------------------------------------------------------
    def _holds(self, f, state: int, env: dict, region: set) -> bool:
        head = f[0]
        if head == "and":
            return all(self._holds(g, state, env, region) for g in f[1:])
        if head == "or":
            return any(self._holds(g, state, env, region) for g in f[1:])
        if head == "not":
            return not self._holds(f[1], state, env, region)
        pred, args = f[1], tuple(env.get(a, a) for a in f[2])
        if pred == "in-region":
            x = args[0]
            return x in region if x in self.locations else self.region_model.where(state, x) in region
        if pred == "nowhere":
            return self.nowhere(state, args[0])
        key = (pred, *args)
        i = self.model.atom_index.get(key)
        if i is not None:
            return bool(state >> i & 1)
        return key in self.static

    def _goal(self, family: Family, env: dict) -> tuple[str, int, int] | None:
        """(text, pos, neg) of a family's goal under a binding; None if it can never hold."""
        pos = neg = 0
        texts = []
        for positive, pred, args in family.goal:
            key = (pred, *(env.get(a, a) for a in args))
            i = self.model.atom_index.get(key)
            text = f"({' '.join(key)})"
            texts.append(text if positive else f"(not {text})")
            if i is not None:
                if positive:
                    pos |= 1 << i
                else:
                    neg |= 1 << i
            elif (key in self.static) != positive:  # a static fact denied, or an atom never reached asked for
                return None
        if pos & neg:
            return None
        return (texts[0] if len(texts) == 1 else f"(and {' '.join(texts)})"), pos, neg

    def clauses(self, state: int, plan, path: list[int]) -> list[Clause]:
        """Every clause of the state, in the generator's order (see the module docstring); not capped."""
        region = self.region(path)
        relevant = self.relevant(state, plan, region)
        out, seen = [], set()
        for obj in sorted(relevant):
            for fam in self.families:
                (var, types), rest = fam.roles[0], fam.roles[1:]
                if obj not in self._objects_of(types):
                    continue
                pools = [sorted(self._objects_of(t)) for _, t in rest]
                for combo in itertools.product(*pools):
                    env = {var: obj, **{v: o for (v, _), o in zip(rest, combo)}}
                    if fam.when is not None and not self._holds(fam.when, state, env, region):
                        continue
                    goal = self._goal(fam, env)
                    if goal is None or goal[0] in seen:
                        continue
                    text, pos, neg = goal
                    if state & pos == pos and not state & neg:  # holds already
                        continue
                    seen.add(text)
                    out.append(Clause(text, fam.name, obj, pos, neg))
        return out

    def describe(self) -> dict:
        """The generator as a results file's configuration records it."""
        return {
            "kind": "focused",
            "source": "domain.toml [gnn.candidates]",
            "hops": self.hops,
            "base_hop": self.base_hop,
            "max_clauses": self.max_clauses,
            "relevant_when_nowhere": self.nowhere_types,
            "families": [f.describe() for f in self.families],
        }


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]


def actions_along(model, path: list[int]) -> list[int]:
    """A plan making the path's steps: for each step, the first ground action (in model order) that makes it."""
    out = []
    for s, t in zip(path, path[1:]):
        a = next((a for a in model.applicable(s) if model.apply(s, a) == t), None)
        if a is None:
            raise DomainError(model.layout, "a step of the path no action makes")
        out.append(a)
    return out
