"""What a domain is, for everything made from it: its PDDL name and the digest of its folder's content.

Every results file, checkpoint, dataset and cache records `identity(model)`:

    {"domain": "restaurant",                       # the PDDL (define (domain NAME))
     "domain_sha256": "…",                         # of the files the layout is made of
     "domain_files": {"domain.pddl": "…", …}}      # each file's own sha256 (first 16 hex digits)

so that a file made from other domain content is recognised, and the error can say
which file changed. The files are those a layout is compiled from: `domain.pddl`,
`tasks.pddl`, the layout's problem and `domain.toml` (as parsed TOML, so a comment or
a reformatting changes nothing, less the tool settings of `SETTINGS_TABLES`: [training],
[search], [gnn], [streams], [preparation], [[published]]); another layout's problem file is not part of it. The canonical
sequences are checked task by task where they are used.
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from functools import lru_cache
from pathlib import Path

from planning.errors import DomainError

FILE_DIGITS = 16
"""Hex digits kept of each file's sha256 (enough to name the file that changed)."""


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


SETTINGS_TABLES = ("training", "search", "gnn", "streams", "preparation", "published")
"""domain.toml tables that configure a tool rather than define the world: the learner's and the
search's defaults, the GNN baseline's candidate generator ([gnn.candidates]) and the task streams
besides the i.i.d. one ([streams], `planning.world.streams`: a run on the i.i.d. stream does not
depend on them, and a stream's canonical sequences are stored and checked task by task) and what the
reports measure of preparation ([preparation], `planning.world.preparation`: read from plans). Runs record
the values they used in their own configuration, so these tables are left out of the digest (an edit
of them does not make every result and cache stale); so are the literature's figures the domain's report
sets beside ours ([[published]], `experiments.report.domain`)."""


@lru_cache(maxsize=32)
def _digests(files: tuple, stamp: tuple) -> tuple[str, dict]:
    parts = {}
    for path in files:
        path = Path(path)
        data = path.read_bytes()
        if path.suffix == ".toml":  # its content, not its layout: a comment changes nothing
            table = {k: v for k, v in tomllib.loads(data.decode()).items() if k not in SETTINGS_TABLES}
            data = json.dumps(table, sort_keys=True, default=str).encode()
        parts[path.name] = _digest(data)
    whole = _digest("\n".join(f"{n} {d}" for n, d in sorted(parts.items())).encode())
    return whole, {n: d[:FILE_DIGITS] for n, d in sorted(parts.items())}


def layout_digest(model) -> tuple[str, dict]:
    """(sha256 of the layout's domain, tasks, problem and domain.toml, {file name: its sha256 prefix});
    re-read when a file changes."""
    files = tuple(str(Path(model.files[k]).resolve()) for k in ("domain", "tasks", "problem", "config"))
    stamp = tuple((p.stat().st_mtime_ns, p.stat().st_size) for p in map(Path, files))
    return _digests(files, stamp)


def identity(model) -> dict:
    """The keys every file made from this model records: domain, domain_sha256, domain_files."""
    digest, files = layout_digest(model)
    return {"domain": model.name, "domain_sha256": digest, "domain_files": dict(files)}


def mismatch(saved: dict, model) -> str | None:
    """How a saved file's domain differs from the model's (its name, or the files whose content changed),
    or None when it is the same domain; a file that records no digest differs only by its name."""
    if not isinstance(saved, dict):
        return "records no domain"
    if saved.get("domain") not in (None, model.name):
        return f"domain {saved.get('domain')!r}, not {model.name!r}"
    recorded = saved.get("domain_sha256")
    if recorded is None:
        return None
    mine = identity(model)
    if recorded == mine["domain_sha256"]:
        return None
    old, new = saved.get("domain_files") or {}, mine["domain_files"]
    changed = sorted(n for n in set(old) | set(new) if old.get(n) != new.get(n))
    return f"other content of domain {model.name!r} (changed: {', '.join(changed) or 'unknown files'})"


def refuse_other(out, model, settings: dict, what: str) -> None:
    """A one-line error if the results file at `out` (`what`: "calibration") was made for another domain,
    layout, domain content or settings (`settings`: each key as the new file would record it)."""
    try:
        saved = json.loads(Path(out).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DomainError(out, f"corrupt {what} ({type(e).__name__}); delete it or pass --force") from None
    if not isinstance(saved, dict):
        raise DomainError(out, f"corrupt {what} (not a JSON object); delete it or pass --force")
    diff = mismatch(saved, model)
    if diff is None and saved.get("layout") != model.layout:
        diff = f"layout {saved.get('layout')!r}, not {model.layout!r}"
    for key, value in settings.items():
        if diff is None and key in saved and saved[key] != value:
            diff = f"{key} {saved[key]!r}, not {value!r}"
    if diff is not None:
        raise DomainError(out, f"a {what} made with {diff}; pass --force to replace it, or --out another file")
