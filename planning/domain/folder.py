"""Read a domain folder: PDDL domain, task schemas, one problem per layout, and domain.toml.

A domain folder holds no Python. Its files:
  domain.pddl   types, predicates, actions with :action-costs
  tasks.pddl    one action schema per task type: precondition = goal, effect = consumption
  <layout>.pddl one problem per layout (objects, initial state, static costs)
  domain.toml   task probabilities and arguments, world-reset randomness, rooms,
                coordinates, the factored-action heads, stream and reward settings
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

from tarski.fstrips import Action
from tarski.io import PDDLReader

from planning.errors import DomainError


@dataclass
class DomainSource:
    """The parsed files of one layout of a domain folder."""

    folder: Path
    layout: str
    domain_file: Path
    tasks_file: Path
    problem_file: Path
    config: dict
    problem: object                 # tarski Problem: language, init, goal
    actions: dict[str, Action]      # domain action schemas, in file order
    task_schemas: dict[str, Action]  # task schemas, in file order
    domain_name: str = ""           # the PDDL `(define (domain NAME))`: the domain's name everywhere

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


def _parse(reader: PDDLReader, path: Path, kind: str):
    if not path.is_file():
        raise DomainError(path, "missing")
    try:
        if kind == "problem":
            return reader.parse_instance(str(path))
        return reader.parse_domain(str(path))
    except DomainError:
        raise
    except Exception as e:  # tarski raises many types; all mean the file is bad
        raise DomainError(path, f"cannot parse PDDL {kind}: {parser_reason(e)}") from None


def parser_reason(e: Exception) -> str:
    """A parser's message on one line, without tarski's empty "(error msg: None)" tail."""
    import re

    reason = " ".join(str(e).split())
    reason = re.sub(r"\s*\(error msg: None\)", "", reason)
    return reason or type(e).__name__


def read_domain(folder: str | Path, layout: str) -> DomainSource:
    """Parse the domain, the task schemas and the layout's problem into one tarski language."""
    folder = Path(folder)
    config = read_config(folder)
    known = config.get("layouts", {})
    if layout not in known:
        raise DomainError(folder / "domain.toml", f"unknown layout '{layout}' (known: {', '.join(known) or 'none'})")
    problem_file = folder / known[layout].get("problem", f"{layout}.pddl")
    domain_file, tasks_file = folder / "domain.pddl", folder / "tasks.pddl"

    reader = PDDLReader(raise_on_error=True, strict_with_requirements=False)
    _parse(reader, domain_file, "domain")
    domain_name = reader.problem.domain_name
    actions = dict(reader.problem.actions)
    # Task schemas may share a name with an action (make-coffee, wash): parse them
    # into the same language, then keep the two sets apart.
    reader.problem.actions.clear()
    _parse(reader, tasks_file, "domain")
    task_schemas = dict(reader.problem.actions)
    reader.problem.actions.clear()
    reader.problem.actions.update(actions)
    reader.problem.domain_name = domain_name
    problem = _parse(reader, problem_file, "problem")
    if problem.domain_name.strip() != domain_name:
        raise DomainError(problem_file, f"names domain '{problem.domain_name.strip()}', not '{domain_name}'")
    return DomainSource(folder, layout, domain_file, tasks_file, problem_file, config,
                        problem, actions, task_schemas, domain_name)
