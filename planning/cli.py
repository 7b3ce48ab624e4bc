"""The command-line contract shared by every tool (SPEC.md): --domain, --layout, --sequences, --seed, --out."""
from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import sys
import textwrap

from planning.errors import DomainError


def parser(description: str, sequences: bool = False, seed: bool = False) -> argparse.ArgumentParser:
    """An argument parser with the common options; --sequences and --seed only where a tool uses them."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--domain", default="domains/restaurant", help="domain folder (default: %(default)s)")
    p.add_argument("--layout", default=None, help="layout name (default: the folder's first)")
    if sequences:
        p.add_argument("--sequences", default="0-9", help="canonical sequences, e.g. 0-9 or 1,3,6")
    if seed:
        p.add_argument("--seed", type=int, default=0, help="random seed (default: %(default)s)")
    p.add_argument("--out", default=None, help="results JSON to write")
    return p


def parse_ids(text: str) -> list[int]:
    """'0-9' -> [0..9]; '1,3,6' -> [1, 3, 6]."""
    ids = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        try:
            ids += list(range(int(lo), int(hi) + 1)) if hi else [int(lo)]
        except ValueError:
            raise DomainError("--sequences", f"'{text}' is not a list like 0-9 or 1,3,6") from None
    return ids


def run(main) -> None:
    """Call main(); bad input ends with one line on stderr and exit status 2."""
    try:
        main()
    except DomainError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)


def field_docs(cls) -> dict[str, str]:
    """{field: its docstring} of a dataclass whose fields each carry a string literal below them."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body, docs = tree.body[0].body, {}
    for node, nxt in zip(body, body[1:]):
        if isinstance(node, ast.AnnAssign) and isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant):
            docs[node.target.id] = str(nxt.value.value)
    return docs


def add_dataclass_options(p: argparse.ArgumentParser, cls, skip=()) -> None:
    """One --flag per field of a config dataclass (its docstring as help, its default shown).

    Every flag defaults to None, so a caller can layer defaults (dataclass, then
    domain file, then command line) and apply only what was given.
    """
    docs = field_docs(cls)
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        kind = type(f.default) if f.default is not None and f.default is not dataclasses.MISSING else str
        if f.type in ("float | None", "float"):
            kind = float
        elif f.type in ("int | None", "int"):
            kind = int
        p.add_argument(f"--{f.name.replace('_', '-')}", dest=f.name, type=kind, default=None,
                       help=f"{docs.get(f.name, '')} (default: {f.default})".replace("%", "%%"))
