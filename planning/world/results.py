"""The results file of a run (SPEC.md) on disk: its failure protocols, its name, reading and checking it,
comparing it with the run about to be made, resuming from it and writing it.

A run of an agent on canonical sequences keeps each finished sequence's rows in OUT.partial.json
(`write_partial`), so an interrupted run resumes where it stopped, and writes OUT once every sequence
asked for is in (`write`: atomic, the partial file removed). `resume` reads what a finished OUT and
OUT.partial.json already hold for this run: a finished OUT made by another agent, configuration,
failure protocol or domain content is an error naming the difference (`difference`) unless `force`;
every saved sequence is checked against the canonical one (one well-formed row per task, in order,
figures that add up), and a sequence whose failed tasks were accounted for under another protocol
is left to be played again. The play itself is `planning.world.runner`'s.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from planning.atomic import write_json
from planning.domain.identity import identity, mismatch
from planning.errors import DomainError
from planning.world import sequences

FAILURE_PROTOCOLS = {
    "fallback": (
        "a failed task is completed by the fallback: the optimal completion from where it was "
        "left (planning.search.optimal) is executed, its consumption applied, and the task charged "
        "its executed cost plus the completion's"
    ),
    "abandon": (
        "the thesis's protocol: a failed task is abandoned, the world persists as it was left, and "
        "the task is charged its executed cost only; not comparable with the myopic oracle unless "
        "every task succeeded"
    ),
}
"""The failure protocols (`--failure-protocol`), as a results file describes them (`failure_accounting`)."""

DEFAULT_PROTOCOL = "fallback"
COMPLETED_BY = {"fallback": "fallback", "abandon": "nothing"}
"""What a failed task's row says completed it (`completed_by`), per protocol."""


def check_protocol(protocol: str) -> None:
    """A one-line error for a failure protocol that is not one of FAILURE_PROTOCOLS."""
    if protocol not in FAILURE_PROTOCOLS:
        raise DomainError(
            "--failure-protocol", f"unknown protocol '{protocol}' (known: {', '.join(FAILURE_PROTOCOLS)})"
        )


UNPREFIXED_DOMAIN = "restaurant"
"""The one domain whose results, checkpoint and calibration files carry no domain prefix: the thesis's
reproduction, whose committed names came before any other domain. Every other domain's names start with its
PDDL name and a dash (`file_prefix`)."""


def file_prefix(domain: str | None) -> str:
    """What the name of a domain's results, checkpoint or calibration file starts with: the PDDL domain's name and
    a dash, nothing for UNPREFIXED_DOMAIN (or a file that records no domain)."""
    return "" if domain in (None, UNPREFIXED_DOMAIN) else f"{domain}-"


def default_out(agent, model, results_dir="results", protocol: str = DEFAULT_PROTOCOL) -> str:
    """results/<run name>-<layout>.json (the layout once, where the run name already holds it); for any
    domain but the restaurant (whose committed names stay) the domain's name comes first, and a run under
    a failure protocol other than the default ends in `-<protocol>`."""
    return results_file(agent.run_name, model.name, model.layout, results_dir, protocol)


def results_file(
    run_name: str, domain: str, layout: str, results_dir="results", protocol: str = DEFAULT_PROTOCOL
) -> str:
    """`default_out` from the names alone (for tools that name a run's file without building its agent)."""
    base = run_name if layout in run_name else f"{run_name}-{layout}"
    base = f"{file_prefix(domain)}{base}"
    if protocol != DEFAULT_PROTOCOL:
        base = f"{base}-{protocol}"
    return f"{results_dir}/{base}.json"


def read(path: Path, what: str) -> dict:
    """A saved results file (or partial file, or reference) as a JSON object; a one-line error otherwise."""
    try:
        saved = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise DomainError(path, f"corrupt {what} ({e}); delete it to start over") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DomainError(
            path, f"cannot read the {what} ({getattr(e, 'strerror', None) or type(e).__name__})"
        ) from None
    if not isinstance(saved, dict):
        raise DomainError(path, f"corrupt {what} (not a JSON object); delete it to start over")
    return saved


ROW_KEYS = {"sequence": int, "index": int, "task": str, "cost": (int, float), "actions": int, "success": bool}


def row_problem(row: dict, model) -> str | None:
    """Why a saved row cannot be what the runner wrote (its figures do not add up), or None."""
    if row["cost"] < 0 or row["actions"] < 0:
        return f"a negative cost or action count ({row['cost']}, {row['actions']})"
    plan = row.get("plan")
    if isinstance(plan, list):
        try:
            spent = sum(model.action_cost[model.action_index[a]] for a in plan)
        except (KeyError, TypeError):
            return "its plan names an action the layout does not have"
        executed = row.get("executed_cost", row["cost"])
        if len(plan) != row["actions"] or spent != executed:
            return f"its plan costs {spent} in {len(plan)} actions, the row says {executed} in {row['actions']}"
    if not row["success"]:
        executed, rest, charged = row.get("executed_cost"), row.get("completion_cost"), row.get("charged_cost")
        if row.get("completed_by") == "fallback" and (
            not isinstance(executed, (int, float))
            or not isinstance(rest, (int, float))
            or charged != executed + rest
            or row["cost"] != charged
        ):
            return "its charged cost is not its executed cost plus its completion"
    elif row.get("auto") and (row["cost"] != 0 or row["actions"] != 0):
        return "a task that already held, with a cost"
    return None


def kept_rows(path: Path, what: str, seq, rows, model=None) -> list:
    """A saved sequence's rows, checked against the sequence itself: one well-formed row per task,
    in order, naming its task, with figures that add up. A sequence cut short or edited is a one-line error."""
    where = f"{what}, sequence {seq.id}"
    if not isinstance(rows, list):
        raise DomainError(path, f"corrupt {where} (its rows are not a list); delete it to start over")
    if len(rows) != len(seq.tasks):
        raise DomainError(
            path,
            f"corrupt {where}: {len(rows)} rows for its {len(seq.tasks)} tasks "
            "(cut short or edited by hand); delete it to start over",
        )
    for k, (row, task) in enumerate(zip(rows, seq.tasks)):
        bad = not isinstance(row, dict) or any(
            not isinstance(row.get(key), kind) or (kind is int and isinstance(row.get(key), bool))
            for key, kind in ROW_KEYS.items()
        )
        if bad or row["sequence"] != seq.id or row["index"] != k or row["task"] != task.name:
            raise DomainError(
                path, f"corrupt {where}: row {k} is not task {k} ({task.name}) of the sequence; delete it to start over"
            )
        problem = row_problem(row, model) if model is not None else None
        if problem:
            raise DomainError(path, f"corrupt {where}: row {k} ({task.name}): {problem}; delete it to start over")
    return rows


def accounted_under(rows, protocol: str) -> bool:
    """True if every failed task of the rows was accounted for under `protocol` (rows of another
    protocol, or written before failed tasks were completed, are played again rather than mixed in)."""
    return all(r["success"] or r.get("completed_by") == COMPLETED_BY[protocol] for r in rows)


def saved_sequences(path: Path, what: str, table) -> dict:
    """{id: rows} of a saved run's finished sequences (ids checked as numbers)."""
    if not isinstance(table, dict):
        raise DomainError(path, f"corrupt {what} (its finished sequences are not a table); delete it to start over")
    try:
        return {int(k): v for k, v in table.items()}
    except (TypeError, ValueError):
        raise DomainError(path, f"corrupt {what} (a sequence id is not a number); delete it to start over") from None


def saved_protocol(saved: dict) -> str | None:
    """The failure protocol a saved run played under: its `failure_protocol`; for a file written before
    protocols were recorded, 'charged' (failed tasks charged, the world left as it was) if a task
    failed, else None (with no failure, every protocol gives the same rows)."""
    if saved.get("failure_protocol"):
        return saved["failure_protocol"]
    rows = saved.get("per_task")
    if rows is None and isinstance(saved.get("done"), dict):
        rows = [r for rs in saved["done"].values() if isinstance(rs, list) for r in rs]
    failed = any(isinstance(r, dict) and r.get("success") is False for r in rows or [])
    return "charged (the world left where the failed task stopped)" if failed else None


def difference(saved: dict, agent, model, protocol: str = DEFAULT_PROTOCOL) -> str | None:
    """The first setting in which a saved run differs from this one ('agent', the domain, 'layout', the
    failure protocol or a config key), or None."""
    if saved.get("agent") != agent.name:
        return f"agent {saved.get('agent')!r}, not {agent.name!r}"
    diff = mismatch(saved, model)
    if diff is not None:
        return diff
    if saved.get("layout") != model.layout:
        return f"layout {saved.get('layout')!r}, not {model.layout!r}"
    theirs = saved_protocol(saved)
    if theirs not in (None, protocol):
        return f"failure protocol {theirs!r}, not {protocol!r}"
    old, new = saved.get("config") or {}, agent.config
    for key in sorted(set(old) | set(new)):
        if old.get(key) != new.get(key):
            return f"{key} {old.get(key)!r}, not {new.get(key)!r}"
    return None


def sequence_provenance(saved: dict) -> dict:
    """{sequence id: {commit, date_utc}} of a saved results file: its per-sequence record where it keeps
    one, else the file's own commit and date for each of its sequences."""
    prov = saved.get("provenance") if isinstance(saved.get("provenance"), dict) else {}
    per = prov.get("sequences") if isinstance(prov.get("sequences"), dict) else {}
    whole = {"commit": prov.get("commit"), "date_utc": prov.get("date_utc") or prov.get("written")}
    ids = saved.get("sequences") if isinstance(saved.get("sequences"), list) else list((saved.get("done") or {}))
    out = {}
    for i in ids:
        try:
            out[int(i)] = per.get(str(i)) or whole
        except (TypeError, ValueError):
            continue
    return out


@dataclass
class Saved:
    """What a run's finished OUT and OUT.partial.json already hold for it (`resume`).

    done:       {sequence id: its checked rows}, the partial file's over OUT's (it is newer).
    wall:       the seconds of the runs that played them.
    finished:   OUT as it is, when it is a finished run of this configuration (else None).
    provenance: {sequence id: the run that played it} (`sequence_provenance`).
    files:      how many files they came from (OUT alone: 1).
    """

    done: dict = field(default_factory=dict)
    wall: float = 0.0
    finished: dict | None = None
    provenance: dict = field(default_factory=dict)
    files: int = 0


def resume(
    model, agent, out, partial: Path | None, protocol: str = DEFAULT_PROTOCOL, force: bool = False, played_by_workers=()
) -> Saved:
    """What the run of `agent` on `model` under `protocol` keeps of a finished OUT and of OUT.partial.json.

    A finished OUT made otherwise is an error naming the difference; with `force` OUT is not read, nor
    the partial file unless this command's workers just played into it (`played_by_workers`). A partial
    file of another configuration is ignored (replaced by this run's). A saved sequence that is not a
    canonical sequence of the layout, or whose rows do not match it, is an error; one whose failed tasks
    were accounted for under another protocol is dropped (played again).
    """
    runs: list = []
    kept = Saved()
    wall = 0.0
    if out and Path(out).is_file() and not force:
        saved = read(Path(out), "results")
        diff = difference(saved, agent, model, protocol)
        if diff:
            raise DomainError(out, f"a finished run with {diff}; pass --force to play it again, or --out another file")
        rows = saved.get("per_task")
        if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
            raise DomainError(out, "corrupt results (per_task is not a list of rows); delete it to start over")
        ids = saved.get("sequences", [])
        if not isinstance(ids, list):
            raise DomainError(out, "corrupt results (sequences is not a list); delete it to start over")
        table = {i: [r for r in rows if r.get("sequence") == i] for i in ids}
        runs.append((Path(out), "results", saved_sequences(Path(out), "results", table)))
        kept.provenance.update(sequence_provenance(saved))
        wall = saved.get("wall_seconds", 0.0)
        kept.finished = saved
    if partial and partial.is_file() and not (force and not played_by_workers):
        saved = read(partial, "partial results")
        if difference(saved, agent, model, protocol) is None:
            runs.append(
                (
                    partial,
                    "partial results",  # newer than OUT
                    saved_sequences(partial, "partial results", saved.get("done")),
                )
            )
            kept.provenance.update(
                {int(k): v for k, v in (saved.get("provenance_of") or {}).items() if str(k).lstrip("-").isdigit()}
            )
            wall += saved.get("wall_seconds", 0.0)
    canonical = {}
    for path, what, table in runs:
        for i in table:
            if i not in canonical:
                try:
                    canonical[i] = sequences.load(model, [i], agent.config.get("stream"))[0]
                except DomainError:
                    raise DomainError(
                        path,
                        f"corrupt {what}: sequence {i} is not a canonical sequence of "
                        f"{model.layout}; delete it to start over",
                    ) from None
    for path, what, table in runs:
        for i, rows in table.items():
            rows = kept_rows(path, what, canonical[i], rows, model)
            if accounted_under(rows, protocol):
                kept.done[i] = rows
            else:
                kept.done.pop(i, None)
    kept.wall = wall if isinstance(wall, (int, float)) else 0.0
    kept.files = len(runs)
    return kept


def write_partial(partial: Path, agent, model, protocol: str, wall: float, done: dict, provenance: dict) -> None:
    """OUT.partial.json: the finished sequences' rows so far, under this run's agent, configuration, domain
    and protocol (what `resume` compares), with the seconds they took and the runs that played the kept ones."""
    write_json(
        partial,
        {
            "agent": agent.name,
            **identity(model),
            "layout": model.layout,
            "config": agent.config,
            "failure_protocol": protocol,
            "wall_seconds": wall,
            "done": done,
            "provenance_of": {str(i): v for i, v in provenance.items()},
        },
    )


def write(out, partial: Path, result: dict) -> None:
    """OUT, atomically (`planning.atomic.write_json`), and the partial file it replaces removed."""
    write_json(out, result)
    partial.unlink(missing_ok=True)
