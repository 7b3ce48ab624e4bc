"""The command-line contract shared by every tool (SPEC.md): --domain, --layout, --sequences, --seed, --out.

Every command builds its parser with `parser`, which declares the options several commands share
(each once, here); a command adds only its own.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import os
import sys
import tempfile
import textwrap
from pathlib import Path

from planning.errors import DomainError

DEFAULT_DOMAIN = "domains/restaurant"
"""The domain folder read where none is named (--domain, `compile_domain`, the configs): the thesis's restaurant."""

SHARED_HELP = {
    "domain": "domain folder (default: %(default)s)",
    "layout": "layout name (default: the folder's first)",
    "sequences": "canonical sequences, e.g. 0-9 or 1,3,6",
    "sequence": "canonical sequence (default: %(default)s)",
    "seed": "random seed (default: %(default)s)",
    "no_progress": "no progress bars (logs of background runs)",
    "workers": "local processes (default: 1, serial)",
    "ray": "Ray tasks: a local instance, or the cluster at RAY_ADDRESS",
}
"""The help of each shared option, by dest."""
OUT_HELP = {"file": "results JSON to write", "folder": "results folder to write"}
"""The help of --out, by what it names."""


def parser(
    description: str,
    *,
    domain: bool = True,
    layout: bool = True,
    sequences: bool = False,
    sequence: bool = False,
    seed: bool = False,
    out: str | None = "file",
    progress: bool = False,
    workers: bool = False,
    helps: dict[str, str] | None = None,
) -> argparse.ArgumentParser:
    """The argument parser of a command, with the shared options it asks for.

    --domain and --layout unless `domain` or `layout` is False (a tool that reads
    another input, or names its layouts its own way); --sequences, --sequence,
    --seed, --no-progress (`progress`), --workers and --ray (`workers`) only
    where a tool uses them. --out is checked as it is parsed, before any work
    starts: `out` "file" (a results file), "folder" (a folder the tool writes
    into) or None (no --out). `helps` rewords the help of a shared option (by
    dest, "out" for --out) where a tool gives it a meaning of its own; its
    name, default and type stay the shared ones.
    """
    words = {**SHARED_HELP, "out": OUT_HELP.get(out), **(helps or {})}
    p = argparse.ArgumentParser(description=description)
    if domain:
        p.add_argument("--domain", default=DEFAULT_DOMAIN, help=words["domain"])
    if layout:
        p.add_argument("--layout", default=None, help=words["layout"])
    if sequences:
        p.add_argument("--sequences", default="0-9", help=words["sequences"])
    if sequence:
        p.add_argument("--sequence", type=int, default=0, help=words["sequence"])
    if seed:
        p.add_argument("--seed", type=int, default=0, help=words["seed"])
    if out:
        p.add_argument(
            "--out", default=None, type=writable_folder if out == "folder" else writable_file, help=words["out"]
        )
    if progress:
        p.add_argument("--no-progress", action="store_true", help=words["no_progress"])
    if workers:
        p.add_argument("--workers", type=int, default=1, help=words["workers"])
        p.add_argument("--ray", action="store_true", help=words["ray"])
    return p


def peek(**flags) -> argparse.Namespace:
    """The values of a few options on the command line, read before its parser is built: what that parser
    declares may depend on them (an agent's own options). `flags` maps each dest to its default, False
    making it a switch; every other word on the line is left for the parser."""
    p = argparse.ArgumentParser(add_help=False)
    for dest, default in flags.items():
        flag = "--" + dest.replace("_", "-")
        if default is False:
            p.add_argument(flag, action="store_true")
        else:
            p.add_argument(flag, default=default)
    return p.parse_known_args()[0]


def parse_ids(text: str) -> list[int]:
    """'0-9' -> [0..9]; '1,3,6' -> [1, 3, 6]; an empty or backwards range is an error."""
    ids = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        try:
            lo_i, hi_i = int(lo), int(hi) if hi else None
        except ValueError:
            raise DomainError("--sequences", f"'{text}' is not a list like 0-9 or 1,3,6") from None
        if hi_i is not None and hi_i < lo_i:
            raise DomainError("--sequences", f"'{part}' is an empty range (from {lo_i} down to {hi_i})")
        ids += list(range(lo_i, hi_i + 1)) if hi_i is not None else [lo_i]
    if len(set(ids)) != len(ids):
        raise DomainError("--sequences", f"'{text}' names a sequence twice")
    return ids


def format_ids(ids) -> str:
    """[0, 1, 2, 5] -> '0-2,5': the inverse of parse_ids."""
    ids, parts = sorted(ids), []
    for i in ids:
        if parts and parts[-1][1] == i - 1:
            parts[-1][1] = i
        else:
            parts.append([i, i])
    return ",".join(str(a) if a == b else f"{a}-{b}" for a, b in parts)


def check_writable(path, folder: bool = False) -> Path:
    """`path` if a file (or, with `folder`, a folder) can be written there; else a one-line DomainError.

    Run before any work starts, so an unwritable output never costs a finished
    run: an existing directory where a file is meant (or a file where a folder
    is), a path under a regular file, a folder this process may not write in.
    Nothing is created (a missing parent folder is made when the file is written).
    """
    path = Path(path)
    if not folder and path.is_dir():
        raise DomainError(path, "is a directory, not a file to write")
    if folder and path.exists() and not path.is_dir():
        raise DomainError(path, "is a file, not a folder to write into")
    probe = path if folder and path.is_dir() else path.parent
    while not probe.exists():
        if probe.is_symlink():
            raise DomainError(path, f"cannot be written: {probe} is a broken link")
        probe = probe.parent
    if not probe.is_dir():
        raise DomainError(path, f"cannot be written: {probe} is not a directory")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise DomainError(path, f"cannot be written: no permission to write in {probe}")
    try:  # what os.access misses: a read-only file system, root's squashed mounts
        fd, tmp = tempfile.mkstemp(dir=probe, prefix=".write-check.", suffix=".tmp")
        os.close(fd)
        os.unlink(tmp)
    except OSError as e:
        raise DomainError(path, f"cannot be written in {probe}: {e.strerror}") from None
    return path


def writable_file(text: str) -> str:
    """An argparse type for --out: the path, checked writable as a file."""
    check_writable(text)
    return text


def writable_folder(text: str) -> str:
    """An argparse type for a folder --out: the path, checked writable as a folder."""
    check_writable(text, folder=True)
    return text


def end_progress_lines() -> None:
    """Close every open progress bar, so that what is printed next starts on its own line."""
    try:
        from tqdm import tqdm
    except ImportError:
        return
    for bar in list(getattr(tqdm, "_instances", [])):
        try:
            bar.close()
        except Exception:  # a bar half torn down by the error itself
            pass


def run(main) -> None:
    """Call main(); bad input ends with one line on stderr and exit status 2."""
    try:
        main()
    except DomainError as e:
        end_progress_lines()
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        end_progress_lines()
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
        p.add_argument(
            f"--{f.name.replace('_', '-')}",
            dest=f.name,
            type=kind,
            default=None,
            help=f"{docs.get(f.name, '')} (default: {f.default})".replace("%", "%%"),
        )
