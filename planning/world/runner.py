"""The sequence runner: an agent plays tasks in a persistent world; the results JSON of SPEC.md.

Rules (thesis Chapter 3, §5.2.3): the world is reset once per sequence and
persists across its tasks; a task already satisfied completes at zero cost; a
task not completed within the action budget (64) is abandoned; a planner that
finds no plan (no plan exists, it ran out of time, it crashed) fails the task.

A failed task never makes an agent look cheaper. Under the default failure
protocol, `fallback` (SPEC.md), a failed task is completed by the fallback: the
optimal completion from where it was left (our exact A*,
`planning.search.optimal`) is executed in the world, its consumption applied,
and the next task starts there, where a finished task would have left the
world. Its row keeps `executed_cost`, `completion_cost`, `charged_cost`, the
`completion_plan` and `"completed_by": "fallback"`; its `cost` is the charged
cost, so every figure built on `cost` charges it. An agent that never acts
therefore costs exactly what the myopic oracle costs. The thesis's protocol,
`abandon` (the world persists as it was left, the executed cost only), is kept
for reproducing its Table A.4; a results file made under it reports no
improvement over the myopic oracle unless every task succeeded.

An improvement is computed only against a reference that played the same
tasks, in the same order, from the same world reset, on the same domain
content (checked row by row); otherwise it is null and `improvement_note` says why.

Finished sequences are kept in OUT.partial.json, so an interrupted run resumes
where it stopped, and a finished OUT is extended, never replaced, by a run of
the same agent, configuration, failure protocol and domain content; a run that
differs in any of them stops with an error naming the difference unless
`force` is given, which replays every sequence asked for. One process writes
an OUT at a time (`planning.atomic.OutputLock`).
"""
from __future__ import annotations

import json
import sys
import time
from contextlib import nullcontext
from pathlib import Path

from tqdm import tqdm

from planning.atomic import OutputLock, write_json
from planning.domain.batched import BatchedModel
from planning.domain.identity import identity, mismatch
from planning.errors import DomainError
from planning.search.optimal import optimal_plan
from planning.world.agents import Planner
from planning.world.sequences import load
from planning.world.task_stream import PersistentWorld


def play_task(world: PersistentWorld, agent, task, upcoming=()) -> dict:
    """Play one task to its end: begin it; a planner's plan is executed (no plan: abandoned), a policy
    acts until the task completes or is abandoned. Returns what the agent said about it (Reply.info)."""
    if world.begin(task):
        return {}
    if not isinstance(agent, Planner):
        while world.task is not None:
            world.act(agent.act(world.state, task))
        return {}
    reply = agent.plan(world.state, task, list(upcoming))
    info = dict(reply.info)
    if reply.plan is None:
        world.abandon()
    else:
        info["executed"] = world.execute(reply.plan)
    return info


FAILURE_PROTOCOLS = {
    "fallback": ("a failed task is completed by the fallback: the optimal completion from where it was "
                 "left (planning.search.optimal) is executed, its consumption applied, and the task charged "
                 "its executed cost plus the completion's"),
    "abandon": ("the thesis's protocol: a failed task is abandoned, the world persists as it was left, and "
                "the task is charged its executed cost only; not comparable with the myopic oracle unless "
                "every task succeeded"),
}
"""The failure protocols (`--failure-protocol`), as a results file describes them (`failure_accounting`)."""

DEFAULT_PROTOCOL = "fallback"
COMPLETED_BY = {"fallback": "fallback", "abandon": "nothing"}
"""What a failed task's row says completed it (`completed_by`), per protocol."""

def check_protocol(protocol: str) -> None:
    """A one-line error for a failure protocol that is not one of FAILURE_PROTOCOLS."""
    if protocol not in FAILURE_PROTOCOLS:
        raise DomainError("--failure-protocol", f"unknown protocol '{protocol}' (known: {', '.join(FAILURE_PROTOCOLS)})")


PLANNER_FAULTS = ("out-of-time", "out-of-memory", "crashed", "crash")
"""Row statuses of a planner that gave up or died (an unsolvable verdict is not a fault)."""


class Completions:
    """The optimal completion of a task from a state (plan and cost), memoized per model and (state, task)."""

    def __init__(self):
        self._models: dict = {}

    def plan(self, model, state: int, task) -> tuple[list, int] | None:
        """(an optimal plan, C*_task(state)), None if the task cannot be completed from there."""
        key = id(model)
        if key not in self._models or self._models[key][0] is not model:
            self._models[key] = (model, BatchedModel(model), {})
        _, bm, memo = self._models[key]
        if (state, task.index) not in memo:
            r = optimal_plan(bm, state, task)
            memo[(state, task.index)] = None if r.plan is None else (list(r.plan), r.cost)
        return memo[(state, task.index)]


COMPLETIONS = Completions()


def complete_failed(row: dict, world: PersistentWorld, task, protocol: str = DEFAULT_PROTOCOL) -> dict:
    """A failed task's row under the protocol; under `fallback` the completion is executed in `world`.

    fallback: charged = executed + the optimal completion from where the task was left, and the
    world moves on as the completion leaves it. abandon: charged = executed, the world stays.
    A task that nothing can complete (a dead end) keeps its executed cost and says so; the
    summary refuses a fallback run holding one (it has no finite charge).
    """
    executed = row["cost"]
    row.update(executed_cost=executed, completed_by=COMPLETED_BY[protocol])
    if protocol == "abandon":
        row.update(completion_cost=None, charged_cost=executed)
        return row
    found = COMPLETIONS.plan(world.model, world.state, task)
    if found is None:
        row.update(completion_cost=None, charged_cost=None, completion="impossible from where it was left")
        return row
    plan, rest = found
    world.complete(task, plan)
    row.update(completion_cost=rest, charged_cost=executed + rest, cost=executed + rest,
               completion_plan=[world.model.actions[a] for a in plan])
    return row


def play_sequence(model, agent, seq, bar=None, protocol: str = DEFAULT_PROTOCOL) -> list[dict]:
    """Per-task rows of one sequence (failed tasks under `protocol`, see the module's docstring)."""
    check_protocol(protocol)
    world = PersistentWorld(model, reset_seed=seq.reset_seed)
    agent.start(model, seq)
    rows = []
    for i, task in enumerate(seq.tasks):
        start = time.perf_counter()
        info = play_task(world, agent, task, seq.tasks[i + 1:])
        if "executed" in info:
            info["plan"] = [model.actions[a] for a in info.pop("executed")]
        o = world.outcomes[-1]
        row = {"sequence": seq.id, "index": i, "task": o.task, "cost": o.cost,
               "actions": o.actions, "success": o.success, "auto": o.auto,
               "seconds": round(time.perf_counter() - start, 4), **info}
        if not o.success:
            complete_failed(row, world, task, protocol)
        rows.append(row)
        if bar is not None:
            bar.update(1)
    return rows


def results_provenance(config: dict, played=(), kept: dict | None = None) -> dict:
    """A results file's `provenance` (SPEC.md): commit, command and date (`planning.parallel.provenance`),
    whether tracked code differed from the commit, the UTC date, the machine, the sha256 of the
    checkpoint the configuration names, the sequences this command played (here or on its workers)
    and, per sequence of the file, the run that played it (`sequences`: this one's commit and date
    for the sequences played now, the earlier run's for those kept; `kept` gives those)."""
    import os
    import platform
    import subprocess
    from datetime import datetime, timezone

    from planning.atomic import sha256
    from planning.parallel import provenance

    out = provenance()
    if getattr(sys, "orig_argv", None) and "-m" in sys.orig_argv:
        out["command"] = " ".join(["python", *sys.orig_argv[sys.orig_argv.index("-m"):]])
    try:
        changed = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "*.py", "*.pddl",
                                  "*.toml", ":(exclude)tests"], cwd=Path(__file__).resolve().parents[2], capture_output=True,
                                 text=True, timeout=10).stdout.split("\n")
        out["uncommitted_code"] = sorted(line[3:] for line in changed if line.strip())
    except (OSError, subprocess.SubprocessError):
        out["uncommitted_code"] = None
    out["date_utc"] = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    out["machine"] = {"host": platform.node(), "platform": platform.platform(), "cpus": os.cpu_count(),
                      "python": platform.python_version()}
    checkpoint = next((v for k in ("checkpoint", "model") if isinstance(v := (config or {}).get(k), str)), None)
    if checkpoint and Path(checkpoint).is_file():
        out["checkpoint"] = checkpoint
        out["checkpoint_sha256"] = sha256(checkpoint)
    out["played_in_this_process"] = sorted(played)
    if kept is not None:
        this = {"commit": out["commit"], "date_utc": out["date_utc"]}
        out["sequences"] = {str(i): dict(kept.get(i) or this) for i in sorted(set(kept) | set(played))}
        for i in played:
            out["sequences"][str(i)] = this
    return out


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


def planner_faults(rows) -> list[dict]:
    """The rows whose planner ran out of time or memory, or crashed."""
    return [r for r in rows if r.get("status") in PLANNER_FAULTS]


def fault_warning(rows) -> str | None:
    """One line: how many tasks ended in a planner timeout or crash, and the first (None if none)."""
    faults = planner_faults(rows)
    if not faults:
        return None
    r = faults[0]
    msg = f" ({r['message'][:120]})" if r.get("message") else ""
    how = ("abandoned where they were left, their executed cost charged" if r.get("completed_by") == "nothing"
           else "each completed by the fallback and charged its executed cost plus the optimal completion")
    return (f"{len(faults)} of {len(rows)} tasks ended in a planner timeout or crash, the first "
            f"sequence {r['sequence']} task {r['index']} {r['task']}: {r['status']}{msg}; {how}")


def summary(agent_name, model, ids, rows, wall, config, reference=None, protocol: str = DEFAULT_PROTOCOL,
            resets: dict | None = None) -> dict:
    """The results JSON of SPEC.md; `reference`: the myopic oracle's results file for the improvement.

    Every cost figure sums the rows' `cost`: under `fallback` the charged cost of a failed task
    (executed plus the completion the world then went through), under `abandon` its executed
    cost. `resets`: {sequence id: its world-reset seed}, recorded per sequence so that a later
    run can check it played from the same world. The improvement is null, with
    `improvement_note` saying why, when no comparable reference exists or, under `abandon`,
    when a task failed.
    """
    n = len(rows)
    if not n:
        raise DomainError("--sequences", "no tasks to summarise (an empty list of sequences)")
    uncharged = [r for r in rows if not r["success"] and r.get("charged_cost") is None]
    if uncharged:
        r = uncharged[0]
        raise DomainError(f"sequence {r['sequence']} task {r['index']}",
                          f"{r['task']} failed and cannot be completed from where it was left, so it has "
                          "no charged cost")
    cost = sum(r["cost"] for r in rows) / n
    per_seq = []
    for i in ids:
        mine = [r for r in rows if r["sequence"] == i]
        per_seq.append({"id": i, "cost": sum(r["cost"] for r in mine), "tasks": len(mine),
                        "successes": sum(r["success"] for r in mine),
                        "actions": sum(r["actions"] for r in mine)})
        if resets and i in resets:
            per_seq[-1]["reset_seed"] = resets[i]
        if any(not r["success"] for r in mine):
            per_seq[-1]["executed_cost"] = sum(r.get("executed_cost", r["cost"]) for r in mine)
    success = sum(r["success"] for r in rows) / n
    if protocol == "abandon" and success < 1:
        gain, note = None, ("not comparable: under the thesis's abandon protocol a failed task leaves the "
                            f"world unfinished, and {n - sum(r['success'] for r in rows)} of {n} tasks failed")
    else:
        gain, note = improvement(cost, model, ids, reference, rows, resets)
    out = {"agent": agent_name, **identity(model), "layout": model.layout, "sequences": list(ids),
           "tasks": n, "cost_per_task": round(cost, 2),
           "actions_per_task": round(sum(r["actions"] for r in rows) / n, 3),
           "success_rate": round(success, 4),
           "improvement_vs_myopic": gain}
    if note:
        out["improvement_note"] = note
    out.update({"failure_protocol": protocol, "per_sequence": per_seq, "per_task": rows,
                "wall_seconds": round(wall, 1), "config": config})
    failed = [r for r in rows if not r["success"]]
    if failed:
        out["failure_accounting"] = FAILURE_PROTOCOLS[protocol]
        out["executed_cost_per_task"] = round(sum(r.get("executed_cost", r["cost"]) for r in rows) / n, 2)
        out["planner_faults"] = len(planner_faults(rows))
    return out


def improvement(cost: float, model, ids, reference=None, rows=None, resets=None) -> tuple[float | None, str | None]:
    """((C_oracle - C) / C_oracle, None) against the myopic oracle's results file, or (None, why not).

    The reference must have played the same tasks, in the same order, from the same world resets,
    on the same domain content: checked row by row against `rows` (and `resets`, where both
    record them), never by sequence id alone.
    """
    path = Path(reference) if reference else None
    if path is None or not path.is_file():
        return None, f"no myopic oracle results file {path}" if path else "no reference given"
    ref = _read(path, "myopic oracle results")
    diff = mismatch(ref, model)
    if diff is not None:
        return None, f"the reference {path} was made from {diff}"
    if ref.get("layout") != model.layout:
        return None, f"the reference {path} is of layout {ref.get('layout')!r}"
    try:
        seqs = {s["id"]: s for s in ref["per_sequence"]}
        missing = [i for i in ids if i not in seqs]
        if missing:
            return None, f"the reference {path} lacks sequence {missing[0]}"
        if rows is not None:
            theirs = {}
            for r in ref["per_task"]:
                theirs.setdefault(r["sequence"], []).append(r["task"])
            for i in ids:
                mine = [r["task"] for r in rows if r["sequence"] == i]
                if theirs.get(i) != mine:
                    k = next((k for k, (a, b) in enumerate(zip(theirs.get(i, []), mine)) if a != b),
                             min(len(theirs.get(i, [])), len(mine)))
                    return None, f"the reference {path} played other tasks in sequence {i} (from task {k} on)"
                if resets and i in resets and seqs[i].get("reset_seed") not in (None, resets[i]):
                    return None, f"the reference {path} played sequence {i} from another world reset"
                if resets and i in resets and "reset_seed" not in seqs[i]:
                    return None, f"the reference {path} does not record the world reset of sequence {i}"
        c_ref = sum(seqs[i]["cost"] for i in ids) / sum(seqs[i]["tasks"] for i in ids)
    except (KeyError, TypeError, ZeroDivisionError) as e:
        raise DomainError(path, f"corrupt myopic oracle results ({type(e).__name__}: {e})") from None
    return round((c_ref - cost) / c_ref, 4), None


def default_out(agent, model, results_dir="results", protocol: str = DEFAULT_PROTOCOL) -> str:
    """results/<run name>-<layout>.json (the layout once, where the run name already holds it); for any
    domain but the restaurant (whose committed names stay) the domain's name comes first, and a run under
    a failure protocol other than the default ends in `-<protocol>`."""
    return results_file(agent.run_name, model.name, model.layout, results_dir, protocol)


def results_file(run_name: str, domain: str, layout: str, results_dir="results",
                 protocol: str = DEFAULT_PROTOCOL) -> str:
    """`default_out` from the names alone (for tools that name a run's file without building its agent)."""
    base = run_name if layout in run_name else f"{run_name}-{layout}"
    if domain != "restaurant":
        base = f"{domain}-{base}"
    if protocol != DEFAULT_PROTOCOL:
        base = f"{base}-{protocol}"
    return f"{results_dir}/{base}.json"


def _read(path: Path, what: str) -> dict:
    try:
        saved = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise DomainError(path, f"corrupt {what} ({e}); delete it to start over") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DomainError(path, f"cannot read the {what} ({getattr(e, 'strerror', None) or type(e).__name__})") from None
    if not isinstance(saved, dict):
        raise DomainError(path, f"corrupt {what} (not a JSON object); delete it to start over")
    return saved


ROW_KEYS = {"sequence": int, "index": int, "task": str, "cost": (int, float), "actions": int, "success": bool}


def _row_problem(row: dict, model) -> str | None:
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
        if row.get("completed_by") == "fallback" and (not isinstance(executed, (int, float)) or
                                                      not isinstance(rest, (int, float)) or
                                                      charged != executed + rest or row["cost"] != charged):
            return "its charged cost is not its executed cost plus its completion"
    elif row.get("auto") and (row["cost"] != 0 or row["actions"] != 0):
        return "a task that already held, with a cost"
    return None


def _kept_rows(path: Path, what: str, seq, rows, model=None) -> list:
    """A saved sequence's rows, checked against the sequence itself: one well-formed row per task,
    in order, naming its task, with figures that add up. A sequence cut short or edited is a one-line error."""
    where = f"{what}, sequence {seq.id}"
    if not isinstance(rows, list):
        raise DomainError(path, f"corrupt {where} (its rows are not a list); delete it to start over")
    if len(rows) != len(seq.tasks):
        raise DomainError(path, f"corrupt {where}: {len(rows)} rows for its {len(seq.tasks)} tasks "
                                "(cut short or edited by hand); delete it to start over")
    for k, (row, task) in enumerate(zip(rows, seq.tasks)):
        bad = not isinstance(row, dict) or any(not isinstance(row.get(key), kind) or
                                               (kind is int and isinstance(row.get(key), bool))
                                               for key, kind in ROW_KEYS.items())
        if bad or row["sequence"] != seq.id or row["index"] != k or row["task"] != task.name:
            raise DomainError(path, f"corrupt {where}: row {k} is not task {k} ({task.name}) of the "
                                    "sequence; delete it to start over")
        problem = _row_problem(row, model) if model is not None else None
        if problem:
            raise DomainError(path, f"corrupt {where}: row {k} ({task.name}): {problem}; delete it to start over")
    return rows


def _under(rows, protocol: str) -> bool:
    """True if every failed task of the rows was accounted for under `protocol` (rows of another
    protocol, or written before failed tasks were completed, are played again rather than mixed in)."""
    return all(r["success"] or r.get("completed_by") == COMPLETED_BY[protocol] for r in rows)


def _saved_sequences(path: Path, what: str, table) -> dict:
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


class Evaluation(dict):
    """The results of `evaluate` (the file's content, a dict) and what this call did.

    asked:  the results of the sequences asked for only (what a command prints), computed from
            their rows; equal to the whole file when the file holds nothing else.
    played: the sequences played by this call (here or on its workers); empty if all were kept.
    wrote:  whether OUT was written (False: a finished file was kept as it was).
    seconds: how long this call played (0 when it played nothing; the file's `wall_seconds` is
            the time of every run that played its sequences).
    """

    asked: dict
    played: list
    wrote: bool
    out: str | None
    seconds: float


def evaluate(model, agent, ids, out=None, progress=True, reference=None, force=False, strict=False,
             protocol: str = DEFAULT_PROTOCOL, played_by_workers=()) -> Evaluation:
    """Play the sequences (resuming from OUT.partial.json), then write and return the results.

    Sequences already in a finished OUT of the same agent, configuration, failure protocol and
    domain content are kept, not replayed: `--sequences 0-9` extends a 0-3 run. A finished OUT
    made otherwise is an error naming the difference, unless `force`: then every sequence asked
    for is played again and OUT holds them only. A saved sequence that does not match the
    canonical one (cut short, edited, figures that do not add up) is an error; one whose failed
    tasks were accounted for under another protocol is played again. OUT is checked writable
    and locked (one writer at a time) before anything is played. A finished OUT that already
    holds every sequence asked for is returned as it is, not rewritten, so its provenance still
    names the run that played it. Planner timeouts and crashes print one warning line; with
    `strict` they are an error (exit 2) once the results are written. `played_by_workers`: the
    sequences this command's workers played into OUT.partial.json (`experiments.workers`).
    """
    from planning.cli import check_writable

    if not ids:
        raise DomainError("--sequences", "no sequences given")
    check_protocol(protocol)
    partial = Path(f"{out}.partial.json") if out else None
    if out:
        check_writable(out)
        check_writable(partial)
    with OutputLock(out, "results file") if out else nullcontext():
        return _evaluate(model, agent, ids, out, partial, progress, reference, force, strict, protocol,
                         played_by_workers)


def _evaluate(model, agent, ids, out, partial, progress, reference, force, strict, protocol,
              played_by_workers) -> Evaluation:
    saved_runs: list = []
    wall = 0.0
    finished = None                        # OUT as it is, when it is a finished run of this configuration
    kept_prov: dict = {}
    if out and Path(out).is_file() and not force:
        saved = _read(Path(out), "results")
        diff = difference(saved, agent, model, protocol)
        if diff:
            raise DomainError(out, f"a finished run with {diff}; pass --force to play it again, "
                                   "or --out another file")
        rows = saved.get("per_task")
        if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
            raise DomainError(out, "corrupt results (per_task is not a list of rows); delete it to start over")
        sequences = saved.get("sequences", [])
        if not isinstance(sequences, list):
            raise DomainError(out, "corrupt results (sequences is not a list); delete it to start over")
        table = {i: [r for r in rows if r.get("sequence") == i] for i in sequences}
        saved_runs.append((Path(out), "results", _saved_sequences(Path(out), "results", table)))
        kept_prov.update(sequence_provenance(saved))
        wall = saved.get("wall_seconds", 0.0)
        finished = saved
    if partial and partial.is_file() and not (force and not played_by_workers):
        saved = _read(partial, "partial results")
        if difference(saved, agent, model, protocol) is None:
            saved_runs.append((partial, "partial results",          # newer than OUT
                               _saved_sequences(partial, "partial results", saved.get("done"))))
            kept_prov.update({int(k): v for k, v in (saved.get("provenance_of") or {}).items()
                              if str(k).lstrip("-").isdigit()})
            wall += saved.get("wall_seconds", 0.0)
    known = {}
    for path, what, table in saved_runs:
        for i in table:
            if i not in known:
                try:
                    known[i] = load(model, [i])[0]
                except DomainError:
                    raise DomainError(path, f"corrupt {what}: sequence {i} is not a canonical sequence of "
                                            f"{model.layout}; delete it to start over") from None
    done: dict[int, list] = {}
    for path, what, table in saved_runs:
        for i, rows in table.items():
            rows = _kept_rows(path, what, known[i], rows, model)
            if _under(rows, protocol):
                done[i] = rows
            else:
                done.pop(i, None)
    if not isinstance(wall, (int, float)):
        wall = 0.0
    seqs = load(model, ids)
    todo = [s for s in seqs if s.id not in done]
    played = sorted({s.id for s in todo} | ({int(i) for i in played_by_workers} & set(done)))
    seconds = 0.0
    if finished is not None and not todo and len(saved_runs) == 1:
        result, wrote = Evaluation(finished), False   # nothing to play or merge: OUT stays as written
    else:
        bar = tqdm(total=sum(len(s.tasks) for s in todo), desc=f"{agent.name} {model.layout}",
                   unit="task", disable=not progress)
        for seq in todo:
            start = time.perf_counter()
            done[seq.id] = play_sequence(model, agent, seq, bar, protocol)
            wall += time.perf_counter() - start
            seconds += time.perf_counter() - start
            if partial:
                write_json(partial, {"agent": agent.name, **identity(model), "layout": model.layout,
                                     "config": agent.config, "failure_protocol": protocol,
                                     "wall_seconds": wall, "done": done,
                                     "provenance_of": {str(i): v for i, v in kept_prov.items()}})
        bar.close()
        seqs = load(model, sorted(set(ids) | set(done)))
        rows = [r for s in seqs for r in done[s.id]]
        result = Evaluation(summary(agent.name, model, [s.id for s in seqs], rows, wall, agent.config,
                                    reference, protocol, {s.id: s.reset_seed for s in seqs}))
        if hasattr(agent, "summary"):          # an agent's own keys (e.g. the clairvoyant's K)
            result.update(agent.summary(rows))
        _self_reference(result, out, reference)
        result["provenance"] = results_provenance(agent.config, played, kept_prov)
        wrote = bool(out)
        if out:
            write_json(out, dict(result))
            partial.unlink(missing_ok=True)
    result.asked = _asked(result, model, agent, ids, reference, protocol, out)
    result.played, result.wrote, result.out, result.seconds = played, wrote, out, round(seconds, 1)
    warning = fault_warning([r for r in result["per_task"] if r["sequence"] in set(ids)])
    if warning:
        if strict:
            raise DomainError(out or agent.name, f"--strict: {warning}")
        print(f"warning: {warning}", file=sys.stderr)
    return result


def _self_reference(result: dict, out, reference) -> None:
    """A run that is its own reference (the myopic oracle's results file) improves on itself by 0."""
    if out and reference and Path(out).resolve() == Path(reference).resolve():
        if result.get("failure_protocol") != "abandon" or result["success_rate"] == 1:
            result["improvement_vs_myopic"] = 0.0
            result.pop("improvement_note", None)


def _asked(result: dict, model, agent, ids, reference, protocol, out) -> dict:
    """The results of the sequences asked for, from their rows (the file itself when it holds no others)."""
    if sorted(result["sequences"]) == sorted(ids):
        return dict(result)
    wanted = set(ids)
    rows = [r for r in result["per_task"] if r["sequence"] in wanted]
    resets = {s["id"]: s["reset_seed"] for s in result["per_sequence"] if "reset_seed" in s}
    asked = summary(agent.name, model, list(ids), rows, 0.0, result.get("config"), reference, protocol,
                    resets or None)
    asked.pop("wall_seconds")
    _self_reference(asked, out, reference)
    return asked
