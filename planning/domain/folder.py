"""Read a domain folder: PDDL domain, task schemas, one problem per layout, and domain.toml.

A domain folder holds no Python. Its files:
  domain.pddl   types (a hierarchy of any depth), constants, predicates, derived predicates,
                actions; with :action-costs (a (total-cost) function) the costs of its
                (increase (total-cost) ...) effects, else every action costs 1 (plan length)
  tasks.pddl    one action schema per task type: precondition = goal, effect = consumption;
                it may name the domain's constants and the problem's objects
  <layout>.pddl one problem per layout (objects, initial state, static costs)
  domain.toml   task probabilities and arguments, world-reset randomness, rooms,
                coordinates, the factored-action heads, stream and reward settings;
                [layouts.<name>] may override tasks, resets and coordinates for its layout
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from tarski.fstrips import Action
from tarski.io import PDDLReader
from tarski.io._fstrips.reader import FStripsParser
from tarski.syntax import Constant

from planning.domain.pddl_text import check_problem, prepare_domain
from planning.errors import DomainError


@dataclass
class DomainSource:
    """The parsed files of one layout of a domain folder."""

    folder: Path
    layout: str
    domain_file: Path
    tasks_file: Path
    problem_file: Path
    config: dict  # domain.toml with the layout's overrides applied (layout_config)
    problem: object  # tarski Problem: language, init, goal
    actions: dict[str, Action]  # domain action schemas, in file order
    task_schemas: dict[str, Action]  # task schemas, in file order
    domain_name: str = ""  # the PDDL `(define (domain NAME))`: the domain's name everywhere
    derived: dict = field(default_factory=dict)  # derived predicate -> [(Action, line)]: its axioms, in file order
    domain_constants: tuple = ()  # the objects domain.pddl declares under :constants
    action_costs: bool = True  # the domain declares (total-cost): costs from its effects, else 1 each

    @property
    def name(self) -> str:
        return self.domain_name or self.folder.name


def read_config(folder: Path) -> dict:
    """domain.toml as a dict; a one-line error if it is missing or malformed."""
    if not folder.is_dir():
        raise DomainError(folder, "no such domain folder")
    path = folder / "domain.toml"
    if not path.is_file():
        raise DomainError(path, "missing (every domain folder needs domain.toml)")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise DomainError(path, f"malformed TOML: {e}") from None


def layouts(folder: str | Path) -> list[str]:
    """The layout names a domain folder declares."""
    return list(read_config(Path(folder)).get("layouts", {}))


LAYOUT_OVERRIDES = ("tasks", "reset", "coordinates")
"""The tables a [layouts.<name>] table may override for its layout (besides its own problem and rooms)."""


def layout_config(config: dict, layout: str, where) -> dict:
    """domain.toml as one layout sees it: [layouts.<name>] values replace the global ones, for it only.

    [layouts.L.tasks.T]: its probability replaces [tasks.T]'s, each parameter under its arguments
    replaces that parameter's (the others are kept), and a type not under [tasks] is added;
    [[layouts.L.reset]] (or `reset = []`) replaces the whole [[reset]] list;
    [layouts.L.coordinates] replaces or adds objects' coordinates. A folder without overrides
    reads exactly as before (the same dict)."""
    own = config.get("layouts", {}).get(layout, {})
    if not isinstance(own, dict):
        raise DomainError(where, f"[layouts.{layout}] is {own!r}, not a table")
    if not any(k in own for k in LAYOUT_OVERRIDES):
        return config
    out = dict(config)
    if "tasks" in own:
        tasks = own["tasks"]
        if not isinstance(tasks, dict):
            raise DomainError(
                where, f"[layouts.{layout}] tasks is {tasks!r}, not a table of [layouts.{layout}.tasks.<type>]"
            )
        merged = {k: dict(v) if isinstance(v, dict) else v for k, v in config.get("tasks", {}).items()}
        for ttype, entry in tasks.items():
            if not isinstance(entry, dict):
                raise DomainError(where, f"[layouts.{layout}.tasks.{ttype}] is {entry!r}, not a table")
            base = merged.setdefault(ttype, {})
            if not isinstance(base, dict):
                continue  # tasks.check_entry reports the global entry
            for key, value in entry.items():
                if key == "arguments" and isinstance(value, dict) and isinstance(base.get("arguments"), dict):
                    base["arguments"] = {**base["arguments"], **value}
                else:
                    base[key] = value
        out["tasks"] = merged
    if "reset" in own:
        if not isinstance(own["reset"], list):
            raise DomainError(
                where, f"[layouts.{layout}] reset is {own['reset']!r}, not a list of [[layouts.{layout}.reset]] entries"
            )
        out["reset"] = own["reset"]
    if "coordinates" in own:
        coords = own["coordinates"]
        if not isinstance(coords, dict):
            raise DomainError(where, f"[layouts.{layout}.coordinates] is {coords!r}, not a table")
        out["coordinates"] = {**config.get("coordinates", {}), **coords}
    return out


class _Parser(FStripsParser):
    """tarski's PDDL visitor, with a function's value set for objects of a subtype of its argument types.

    tarski casts each argument of `(= (move-cost dock desk_1) 3)` to the declared argument type
    and fails (`unhashable type: 'Constant'`) when the object's type is a proper subtype; the
    object is kept as it is, checked to be of a subtype at any depth."""

    def visitInitFunctionAssignment(self, ctx):
        fun, subterms = self.visit(ctx.flat_term())
        value = self.visit(ctx.constant_name())
        args = []
        for sort, x in zip(fun.domain, subterms):
            if isinstance(x, Constant):
                if not self.language.is_subtype(x.sort, sort):
                    raise ValueError(f"{x.name} is a {x.sort.name}, not a {sort.name}, in ({fun.name} ...)")
                args.append(x)
            else:
                args.append(sort.to_constant(x))
        self.init.set(fun(*args), value)


def _reader() -> PDDLReader:
    reader = PDDLReader(raise_on_error=True, strict_with_requirements=False)
    reader.parser = _Parser(reader.problem, True, False)
    return reader


def _parse(reader: PDDLReader, path: Path, kind: str, derived: dict | None = None, domain: str = ""):
    """Parse one file; `kind` is "domain", "tasks" or "problem" (which must name `domain`). A domain
    file's `:derived` blocks are parsed as actions (pddl_text.prepare_domain), recorded in `derived`
    by their action name."""
    if not path.is_file():
        raise DomainError(path, "missing")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise DomainError(path, f"cannot read: {e}") from None
    if kind == "problem":
        declared = check_problem(path, text)
        if declared is not None and declared != domain.lower():
            raise DomainError(path, f"names domain '{declared}', not '{domain}'")
    else:
        prepared = prepare_domain(path, text, kind)
        text = prepared.text
        if derived is not None:
            derived.update(prepared.derived)
    try:
        if kind == "problem":
            return reader.parse_instance_string(text)
        return reader.parse_domain_string(text)
    except DomainError:
        raise
    except Exception as e:  # tarski raises many types; all mean the file is bad
        what = "problem" if kind == "problem" else "domain"
        raise DomainError(path, f"cannot parse PDDL {what}: {parser_reason(e)}") from None


def parser_reason(e: Exception) -> str:
    """A parser's message on one line, without tarski's empty "(error msg: None)" tail."""
    import re

    reason = " ".join(str(e).split())
    reason = re.sub(r"\s*\(error msg: None\)", "", reason)
    return reason or type(e).__name__


def read_domain(folder: str | Path, layout: str) -> DomainSource:
    """Parse the domain, the layout's problem and the task schemas into one tarski language.

    The task schemas are read last, so that they may name the problem's objects as well as the
    domain's constants."""
    folder = Path(folder)
    config = read_config(folder)
    known = config.get("layouts", {})
    if layout not in known:
        raise DomainError(folder / "domain.toml", f"unknown layout '{layout}' (known: {', '.join(known) or 'none'})")
    config = layout_config(config, layout, folder / "domain.toml")
    problem_file = folder / known[layout].get("problem", f"{layout}.pddl")
    domain_file, tasks_file = folder / "domain.pddl", folder / "tasks.pddl"

    reader = _reader()
    pseudo: dict = {}
    _parse(reader, domain_file, "domain", pseudo)
    domain_name = reader.problem.domain_name
    lang = reader.problem.language
    domain_constants = tuple(c.name for c in lang.constants())
    action_costs = lang.has_function("total-cost")
    actions, derived = {}, {}
    for name, action in reader.problem.actions.items():
        if name in pseudo:
            pred, line = pseudo[name]
            derived.setdefault(pred, []).append((action, line))
        else:
            actions[name] = action
    for pred, axioms in derived.items():
        if not lang.has_predicate(pred):
            raise DomainError(
                f"{domain_file}:{axioms[0][1]}", f"derived predicate {pred} is not declared under :predicates"
            )
        arity = lang.get_predicate(pred).arity
        for action, line in axioms:
            if len(action.parameters) != arity:
                raise DomainError(
                    f"{domain_file}:{line}",
                    f"derived predicate {pred} takes {arity} arguments, its :derived names {len(action.parameters)}",
                )
    reader.problem.actions.clear()
    reader.problem.actions.update(actions)
    problem = _parse(reader, problem_file, "problem", domain=domain_name)
    # Task schemas may share a name with an action (make-coffee, wash): parse them
    # into the same language, then keep the two sets apart.
    reader.problem.actions.clear()
    _parse(reader, tasks_file, "tasks")
    task_schemas = dict(reader.problem.actions)
    reader.problem.actions.clear()
    reader.problem.actions.update(actions)
    reader.problem.domain_name = domain_name
    return DomainSource(
        folder,
        layout,
        domain_file,
        tasks_file,
        problem_file,
        config,
        problem,
        actions,
        task_schemas,
        domain_name,
        derived,
        domain_constants,
        action_costs,
    )
