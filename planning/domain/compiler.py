"""Compile a domain folder's layout into a grounded Model.

Steps: parse (domain_folder) -> find fluent predicates -> ground the action and
task schemas and the derived predicates' axioms (grounding) -> keep what relaxed
reachability from the initial and reset states can reach -> number the atoms ->
bitset masks and integer costs; the axioms stratified (planning.domain.axioms).

Costs: a domain that declares the (total-cost) function (:action-costs) charges each
action its (increase (total-cost) ...) effect, a number or a static function of the
problem, 0 where it has none (PDDL's and Fast Downward's reading); a domain without it
charges every action 1, so a cost is a plan length.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from tarski.fstrips import UniversalEffect
from tarski.syntax import CompoundTerm, Constant

from planning.cli import DEFAULT_DOMAIN
from planning.domain.axioms import Axioms, stratify
from planning.domain.folder import DomainSource, read_domain
from planning.domain.grounding import Grounder, GroundVariant, atom_text, parse_atom_text
from planning.domain.model import Model, Op
from planning.domain.tasks import compile_tasks, probability
from planning.errors import DomainError


def compile_domain(folder: str | Path = DEFAULT_DOMAIN, layout: str | None = None) -> Model:
    """The compiled model of one layout (the folder's first layout if none is named)."""
    folder = Path(folder)
    if layout is None:
        from planning.domain.folder import layouts

        names = layouts(folder)
        if not names:
            raise DomainError(folder / "domain.toml", "declares no [layouts]")
        layout = names[0]
    return _compile_cached(str(folder.resolve()), layout)


@lru_cache(maxsize=8)
def _compile_cached(folder: str, layout: str) -> Model:
    return compile_source(read_domain(folder, layout))


def _effect_predicates(effects) -> set[str]:
    names = set()
    for eff in effects:
        if isinstance(eff, UniversalEffect):
            names |= _effect_predicates(eff.effects)
        elif hasattr(eff, "atom"):
            names.add(eff.atom.predicate.name)
    return names


def compile_source(src: DomainSource) -> Model:
    """Ground and compile a parsed domain folder layout."""
    fluents = set()
    for kind, schemas in (("action", src.actions), ("task schema", src.task_schemas)):
        for schema in schemas.values():
            changed = _effect_predicates(schema.effects)
            if changed & set(src.derived):
                where = src.domain_file if kind == "action" else src.tasks_file
                raise DomainError(
                    where,
                    f"{kind} {schema.name} changes derived predicate "
                    f"{sorted(changed & set(src.derived))[0]}: a derived predicate follows "
                    "from the other atoms, no effect may set it",
                )
            fluents |= changed
    fluents |= set(src.derived)
    grounder = Grounder(src.problem, fluents, src.domain_file, src.derived)

    variants = [v for schema in src.actions.values() for v in grounder.ground_schema(schema)]
    rules = _ground_axioms(src, grounder)  # [(GroundVariant adding the head, line)]
    tasks_raw = compile_tasks(src, grounder)  # [(TaskSpec, [GroundVariant])]
    init = set()
    for a in src.problem.init.as_atoms():
        if hasattr(a, "predicate") and a.predicate.name in fluents:
            key = grounder.ground_atom(a, {})
            if key[0] in src.derived:
                raise DomainError(
                    src.problem_file,
                    f"{atom_text(key)} in :init: {key[0]} is a derived predicate, it follows from the other atoms",
                )
            init.add(key)
    resets = _reset_choices(src, grounder, fluents)

    task_variants = [v for _, vs in tasks_raw for v in vs]
    reach = _relaxed_reachable(
        init | {a for choices, _ in resets for c in choices for a in c},
        variants + task_variants + [r for r, _ in rules],
    )
    preds = {p.name: i for i, p in enumerate(src.problem.language.predicates)}
    obj_rank = {o: i for i, o in enumerate(grounder.objects)}
    atoms = sorted(reach, key=lambda k: (preds.get(k[0], 0), [obj_rank[o] for o in k[1:]]))
    index = {a: i for i, a in enumerate(atoms)}

    def mask(keys) -> int:
        m = 0
        for k in keys:
            if k in index:
                m |= 1 << index[k]
        return m

    axioms = None
    if src.derived:
        strata = stratify(src, [(r, line) for r, line in rules if r.pos <= reach])
        axioms = Axioms(
            [[(mask(r.pos), mask(r.neg), mask(r.add)) for r in stratum] for stratum in strata],
            mask(a for a in atoms if a[0] in src.derived),
        )

    def op(v: GroundVariant) -> Op | None:
        if not v.pos <= reach:
            return None
        cond = tuple((mask(p), mask(n), mask(a), mask(d)) for p, n, a, d in v.cond if p <= reach)
        return Op(mask(v.pos), mask(v.neg), mask(v.add), mask(v.dele), cond)

    names, schemas, args, costs, ops, op_action = [], [], [], [], [], []
    seen: dict[str, int] = {}
    for v in variants:
        o = op(v)
        if o is None:
            continue
        if v.name not in seen:
            seen[v.name] = len(names)
            names.append(v.name)
            schemas.append(v.schema)
            args.append(v.args)
            costs.append(_action_cost(src, grounder, v))
        ops.append(o)
        op_action.append(seen[v.name])

    model = Model(
        name=src.name,
        layout=src.layout,
        folder=src.folder,
        config=src.config,
        atoms=atoms,
        actions=names,
        action_schema=schemas,
        action_args=args,
        action_cost=costs,
        ops=ops,
        op_action=op_action,
        init=mask(init) if axioms is None else axioms(mask(init)),
        objects=grounder.objects,
        objects_of=grounder.objects_of,
        schema_params={n: [(p.symbol, p.sort.name) for p in s.parameters] for n, s in src.actions.items()},
        resets=[([mask(c) for c in choices], probs) for choices, probs in resets],
        files={
            "domain": src.domain_file,
            "tasks": src.tasks_file,
            "problem": src.problem_file,
            "config": src.folder / "domain.toml",
        },
        axioms=axioms,
    )
    model.attach_tasks([(spec, [o for o in map(op, vs) if o is not None]) for spec, vs in tasks_raw])
    model.source = src  # the tarski schemas, for writing PDDL back out
    model.static_atoms = frozenset(grounder.static)
    return model


def _relaxed_reachable(start: set, variants: list[GroundVariant]) -> set:
    """Atoms reachable when deletes and negative conditions are ignored."""
    reach = set(start)
    pending = list(variants)
    changed = True
    while changed:
        changed = False
        rest = []
        for v in pending:
            if v.pos <= reach:
                new = v.add | {a for p, _, add, _ in v.cond if p <= reach for a in add}
                if not new <= reach:
                    reach |= new
                    changed = True
                if any(not p <= reach for p, *_ in v.cond):
                    rest.append(v)  # a conditional add may still become reachable
            else:
                rest.append(v)
        pending = rest
    return reach


def _ground_axioms(src: DomainSource, grounder: Grounder) -> list:
    """[(rule, line)]: each derived predicate's axioms grounded, one rule per conjunction of a body's DNF;
    a rule is a GroundVariant whose precondition is the body and whose add is the head atom."""
    out = []
    for pred, axioms in src.derived.items():
        for schema, line in axioms:
            for v in grounder.ground_schema(schema):
                head = frozenset([(pred, *v.args)])
                out.append((GroundVariant(f"{pred}({', '.join(v.args)})", pred, v.args, v.pos, v.neg, head), line))
    return out


def _action_cost(src: DomainSource, grounder: Grounder, v: GroundVariant) -> int:
    """The integer cost of a ground action, from a constant or a static function of the problem
    (1 in a domain without (total-cost): unit costs)."""
    schema = src.actions[v.schema]
    if not src.action_costs:
        return 1
    if schema.cost is None:
        return 0
    term = schema.cost.addend
    binding = {p.symbol: a for p, a in zip(schema.parameters, v.args)}
    if isinstance(term, Constant):
        value = float(term.symbol)
    elif isinstance(term, CompoundTerm):
        lang = src.problem.language
        sub = tuple(lang.get(grounder._term(t, binding)) for t in term.subterms)
        text = "(" + " ".join([term.symbol.name, *(s.name for s in sub)]) + ")"
        try:
            value = float(src.problem.init.value(term.symbol, sub).symbol)
        except Exception:  # tarski raises a bare error for a missing function value
            raise DomainError(src.problem_file, f"undefined cost {text} for action {v.name}") from None
    else:
        raise DomainError(src.domain_file, f"action {v.schema}: unsupported cost expression {term}")
    if value != int(value) or value < 0:
        raise DomainError(src.problem_file, f"cost of {v.name} is {value}, not a non-negative integer")
    return int(value)


def _reset_choices(src: DomainSource, grounder: Grounder, fluents: set) -> list:
    """[(choices, probabilities)]: each choice a set of atom keys made true at a world reset."""
    where = src.folder / "domain.toml"
    out = []
    for i, entry in enumerate(src.config.get("reset", [])):
        choices = entry.get("choices")
        if not choices:
            raise DomainError(where, f"[[reset]] entry {i + 1} has no choices")
        probs = entry.get("probabilities", [1.0 / len(choices)] * len(choices))
        if not isinstance(probs, list):
            raise DomainError(where, f"[[reset]] entry {i + 1}: probabilities must be a list")
        probs = [probability(q, where, f"[[reset]] entry {i + 1}: probability {k + 1}") for k, q in enumerate(probs)]
        if len(probs) != len(choices) or abs(sum(probs) - 1.0) > 1e-9:
            raise DomainError(where, f"[[reset]] entry {i + 1}: probabilities must match choices and sum to 1")
        keys = []
        for choice in choices:
            keys.append({_known_atom(text, grounder, fluents, where) for text in choice})
        out.append((keys, list(probs)))
    return out


def _known_atom(text: str, grounder: Grounder, fluents: set, where) -> tuple:
    try:
        key = parse_atom_text(text)
    except ValueError as e:
        raise DomainError(where, str(e)) from None
    lang = grounder.language
    if not lang.has_predicate(key[0]):
        raise DomainError(where, f"unknown predicate '{key[0]}' in {text}")
    for o in key[1:]:
        if o not in grounder.objects:
            raise DomainError(where, f"unknown object '{o}' in {text}")
    if key[0] not in fluents:
        raise DomainError(where, f"{atom_text(key)} is static: no action changes it")
    if key[0] in grounder.derived:
        raise DomainError(where, f"{atom_text(key)} is derived: it follows from the other atoms")
    return key
