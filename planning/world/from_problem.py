"""Wrap a classical PDDL domain and problem, as written, into a one-task domain folder.

    python -m planning.world.from_problem DOMAIN PROBLEM --out DIR [--layout NAME]

DIR receives, with no hand edits:
  domain.pddl      the domain file, byte for byte
  <layout>.pddl    the problem file, byte for byte (layout: the problem file's name, or --layout)
  tasks.pddl       one task schema, `goal`, without parameters: its precondition is the problem's
                   :goal as written (it may name the problem's objects and the domain's
                   constants), its effect nothing
  domain.toml      the layout and the one task type, probability 1
  sequences/<layout>/seq-00.json   one canonical sequence of that one task

The folder is compiled before anything is written (a domain or problem the front end
refuses is a one-line error, nothing written), so every tool runs on it at once: our
exact planner, Fast Downward's through the bridge, the oracles. A domain without
:action-costs charges every action 1, so the task's optimal cost is the plan length.
An existing DIR is refused unless it holds exactly the files this command writes.
"""

from __future__ import annotations

import re
import shutil
import tempfile
from pathlib import Path

from planning import cli
from planning.atomic import write_json
from planning.domain.pddl_text import Node, Token, _sections, read_sexp
from planning.errors import DomainError

TASK = "goal"


def _problem_goal(path: Path, text: str) -> tuple[str, str]:
    """(the :goal formula as written, the problem's name) of a problem file."""
    nodes = read_sexp(text)
    if nodes is None:
        raise DomainError(path, "cannot parse PDDL problem: unbalanced parentheses")
    goal, name = None, None
    for node in _sections(nodes):
        if node.head == ":goal" and len(node.items) == 2 and isinstance(node.items[1], Node):
            goal = text[node.items[1].start : node.items[1].end]
        elif node.head == "problem" and len(node.items) > 1 and isinstance(node.items[1], Token):
            name = node.items[1].text
    if goal is None:
        raise DomainError(path, "has no (:goal ...) to wrap as the task")
    return goal, name or path.stem


def _domain_header(path: Path, text: str) -> tuple[str, str]:
    """(the domain's name, its :requirements section as written, or "")."""
    nodes = read_sexp(text)
    if nodes is None:
        raise DomainError(path, "cannot parse PDDL domain: unbalanced parentheses")
    name, reqs = None, ""
    for node in nodes:
        if isinstance(node, Node) and node.head == "define":
            for x in node.items[1:]:
                if isinstance(x, Node) and x.head == "domain" and len(x.items) > 1:
                    name = x.items[1].text
                elif isinstance(x, Node) and x.head == ":requirements":
                    reqs = text[x.start : x.end]
    if name is None:
        raise DomainError(path, "has no (define (domain NAME) ...)")
    return name, reqs


def layout_name(problem: Path) -> str:
    """A layout name from a problem file's name: its stem, lower case, characters other than letters,
    digits, '-' and '_' replaced by '-'."""
    name = re.sub(r"[^a-z0-9_-]+", "-", problem.stem.lower()).strip("-")
    return name or "problem"


def wrap(domain: Path, problem: Path, out: Path, layout: str | None = None) -> Path:
    """Write the one-task folder of a classical domain and problem into `out`; returns `out`."""
    from planning.domain.compiler import compile_domain
    from planning.world.sequences import generate

    domain, problem, out = Path(domain), Path(problem), Path(out)
    for path in (domain, problem):
        if not path.is_file():
            raise DomainError(path, "missing")
    domain_text, problem_text = domain.read_text(), problem.read_text()
    name, reqs = _domain_header(domain, domain_text)
    goal, problem_name = _problem_goal(problem, problem_text)
    layout = layout or layout_name(problem)
    if not re.fullmatch(r"[a-z0-9][a-z0-9_-]*", layout):
        raise DomainError("--layout", f"'{layout}' is not a layout name (letters, digits, '-' and '_')")
    problem_file = f"{layout}.pddl"
    if problem_file in ("domain.pddl", "tasks.pddl"):
        raise DomainError("--layout", f"'{layout}' would overwrite {problem_file}")
    tasks = (
        f"; The problem {problem_name}'s goal as the one task ({problem.name}, wrapped by\n"
        f"; python -m planning.world.from_problem).\n"
        f"(define (domain {name}-tasks)\n"
        + (f"  {reqs}\n" if reqs else "")
        + f"  (:action {TASK}\n    :parameters ()\n    :precondition {goal}\n    :effect (and)))\n"
    )
    toml = (
        f"# {domain.name} and {problem.name} wrapped as a one-task folder\n"
        f"# (python -m planning.world.from_problem).\n\n"
        f'[layouts.{layout}]\nproblem = "{problem_file}"\n\n'
        f"[tasks.{TASK}]\nprobability = 1.0\n\n"
        f"[stream]\ntasks_per_reset = 1\n"
    )
    files = {"domain.pddl": domain_text, problem_file: problem_text, "tasks.pddl": tasks, "domain.toml": toml}
    seq = Path("sequences") / layout / "seq-00.json"
    if out.exists():
        present = {str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()}
        foreign = present - set(files) - {str(seq)}
        if foreign:
            raise DomainError(out, f"exists and holds other files ({sorted(foreign)[0]}); choose another --out")
    with tempfile.TemporaryDirectory(prefix="from-problem-") as tmp:
        folder = Path(tmp) / out.name
        folder.mkdir()
        for fname, text in files.items():
            (folder / fname).write_text(text)
        model = compile_domain(folder, layout)  # refuses what the front end refuses
        record = generate(model, count=1, length=1)[0]
        out.mkdir(parents=True, exist_ok=True)
        for fname in files:
            shutil.copyfile(folder / fname, out / fname)
    write_json(out / seq, record)
    return out


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0],
        domain=False,
        out="folder",
        helps={"layout": "the layout's name (default: the problem file's name)", "out": "the domain folder to write"},
    )
    p.add_argument("domain", nargs="?", help="the PDDL domain file")
    p.add_argument("problem", nargs="?", help="the PDDL problem file")
    args = p.parse_args()
    usage = "python -m planning.world.from_problem DOMAIN PROBLEM --out DIR"
    what = f" as layout '{args.layout}'" if args.layout else ""
    if args.problem is None:
        raise DomainError("planning.world.from_problem", f"no DOMAIN and PROBLEM files to wrap{what} ({usage})")
    if args.out is None:
        raise DomainError("planning.world.from_problem", f"no --out folder to write{what} into ({usage})")
    out = wrap(Path(args.domain), Path(args.problem), Path(args.out), args.layout)
    layout = args.layout or layout_name(Path(args.problem))
    print(f"wrote {out}: layout {layout}, one task '{TASK}()' (the problem's goal)")


if __name__ == "__main__":
    cli.run(main)
