"""The sequence runner: an agent plays tasks in a persistent world; the results JSON of SPEC.md.

Rules (thesis Chapter 3, §5.2.3): the world is reset once per sequence and
persists across its tasks; a task already satisfied completes at zero cost; a
task not completed within the action budget (64) is abandoned; a planner that
finds no plan (no plan exists, it ran out of time, it crashed) fails the task.

A failed task never makes an agent look cheaper: it is charged the cost it
executed plus the optimal cost of completing it from where it was left (our
exact A*, `planning.search.optimal`). Its row keeps `executed_cost`,
`completion_cost` and `charged_cost`; its `cost` is the charged cost, so every
figure built on `cost` (cost per task, per sequence, improvement) charges it.
Rows of completed tasks are unchanged. Finished sequences are
kept in OUT.partial.json, so an interrupted run resumes where it stopped, and a
finished OUT is extended, never replaced, by a run of the same agent and
configuration; a run with another configuration stops with an error naming
the differing setting unless `force` is given.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from tqdm import tqdm

from planning.atomic import write_json
from planning.domain.batched import BatchedModel
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


FAILURE_ACCOUNTING = ("charged: a failed task costs what it executed plus the optimal cost of completing "
                      "it from where it was left (planning.search.optimal)")
"""What a results file with failed tasks says of their cost (the key `failure_accounting`)."""

PLANNER_FAULTS = ("out-of-time", "out-of-memory", "crashed", "crash")
"""Row statuses of a planner that gave up or died (an unsolvable verdict is not a fault)."""


class Completions:
    """The optimal cost of completing a task from a state, memoized per model and (state, task)."""

    def __init__(self):
        self._models: dict = {}

    def cost(self, model, state: int, task) -> int | None:
        """C*_task(state), None if the task cannot be completed from there."""
        key = id(model)
        if key not in self._models or self._models[key][0] is not model:
            self._models[key] = (model, BatchedModel(model), {})
        _, bm, memo = self._models[key]
        if (state, task.index) not in memo:
            memo[(state, task.index)] = optimal_plan(bm, state, task).cost
        return memo[(state, task.index)]


COMPLETIONS = Completions()


def charge(row: dict, model, state: int, task) -> dict:
    """A failed task's row with its charged cost: executed + the optimal completion from `state`."""
    rest = COMPLETIONS.cost(model, state, task)
    executed = row["cost"]
    charged = executed + rest if rest is not None else None
    row.update(executed_cost=executed, completion_cost=rest, charged_cost=charged)
    if charged is None:          # a dead end: nothing completes it, so no finite charge exists
        row["completion"] = "impossible from where it was left"
    else:
        row["cost"] = charged
    return row


def play_sequence(model, agent, seq, bar=None) -> list[dict]:
    """Per-task rows of one sequence (failed tasks charged, see the module's docstring)."""
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
            charge(row, model, world.state, task)
        rows.append(row)
        if bar is not None:
            bar.update(1)
    return rows


def results_provenance(config: dict, played=()) -> dict:
    """A results file's `provenance` (SPEC.md): commit, command and date (`planning.parallel.provenance`),
    whether tracked code differed from the commit, the UTC date, the machine, the sha256 of the
    checkpoint the configuration names, and the sequences this process played (the others were kept)."""
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
    return (f"{len(faults)} of {len(rows)} tasks ended in a planner timeout or crash, the first "
            f"sequence {r['sequence']} task {r['index']} {r['task']}: {r['status']}{msg}; "
            "each is charged its executed cost plus the optimal completion")


def summary(agent_name, model, ids, rows, wall, config, reference=None) -> dict:
    """The results JSON of SPEC.md; `reference`: the myopic oracle's results file for the improvement.

    Every cost figure sums the rows' `cost`, the charged cost of a failed task. A
    run with failed tasks says so in `failure_accounting` (and how many could not
    be charged, where no completion exists); a run without them has the keys it always had.
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
        if any(not r["success"] for r in mine):
            per_seq[-1]["executed_cost"] = sum(r.get("executed_cost", r["cost"]) for r in mine)
    out = {"agent": agent_name, "domain": model.name, "layout": model.layout, "sequences": list(ids),
           "tasks": n, "cost_per_task": round(cost, 2),
           "actions_per_task": round(sum(r["actions"] for r in rows) / n, 3),
           "success_rate": round(sum(r["success"] for r in rows) / n, 4),
           "improvement_vs_myopic": improvement(cost, model, ids, reference),
           "per_sequence": per_seq, "per_task": rows, "wall_seconds": round(wall, 1),
           "config": config}
    failed = [r for r in rows if not r["success"]]
    if failed:
        out["failure_accounting"] = FAILURE_ACCOUNTING
        out["executed_cost_per_task"] = round(sum(r.get("executed_cost", r["cost"]) for r in rows) / n, 2)
        out["planner_faults"] = len(planner_faults(rows))
    return out


def improvement(cost: float, model, ids, reference=None) -> float | None:
    """(C_oracle - C) / C_oracle against the myopic oracle's results file on the same sequences (None without one)."""
    path = Path(reference) if reference else None
    if path is None or not path.is_file():
        return None
    ref = _read(path, "myopic oracle results")
    try:
        seqs = {s["id"]: s for s in ref["per_sequence"]}
        if ref.get("domain") != model.name or ref.get("layout") != model.layout or not set(ids) <= set(seqs):
            return None
        c_ref = sum(seqs[i]["cost"] for i in ids) / sum(seqs[i]["tasks"] for i in ids)
    except (KeyError, TypeError, ZeroDivisionError) as e:
        raise DomainError(path, f"corrupt myopic oracle results ({type(e).__name__}: {e})") from None
    return round((c_ref - cost) / c_ref, 4)


def default_out(agent, model, results_dir="results") -> str:
    """results/<run name>-<layout>.json (the layout once, where the run name already holds it)."""
    name = agent.run_name
    return f"{results_dir}/{name}.json" if model.layout in name else f"{results_dir}/{name}-{model.layout}.json"


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


def _kept_rows(path: Path, what: str, seq, rows) -> list:
    """A saved sequence's rows, checked against the sequence itself: one well-formed row per task,
    in order, naming its task. A sequence cut short or hand-edited is a one-line error."""
    where = f"{what}, sequence {seq.id}"
    if not isinstance(rows, list):
        raise DomainError(path, f"corrupt {where} (its rows are not a list); delete it to start over")
    if len(rows) != len(seq.tasks):
        raise DomainError(path, f"corrupt {where}: {len(rows)} rows for its {len(seq.tasks)} tasks "
                                "(cut short or edited by hand); delete it to start over")
    for k, (row, task) in enumerate(zip(rows, seq.tasks)):
        bad = not isinstance(row, dict) or any(not isinstance(row.get(key), kind) for key, kind in ROW_KEYS.items())
        if bad or row["sequence"] != seq.id or row["index"] != k or row["task"] != task.name:
            raise DomainError(path, f"corrupt {where}: row {k} is not task {k} ({task.name}) of the "
                                    "sequence; delete it to start over")
    return rows


def _charged(rows) -> bool:
    """True if every failed task of the rows carries its charged cost (rows written before failures
    were charged are played again rather than mixed in)."""
    return all(r["success"] or "charged_cost" in r for r in rows)


def _saved_sequences(path: Path, what: str, table) -> dict:
    """{id: rows} of a saved run's finished sequences (ids checked as numbers)."""
    if not isinstance(table, dict):
        raise DomainError(path, f"corrupt {what} (its finished sequences are not a table); delete it to start over")
    try:
        return {int(k): v for k, v in table.items()}
    except (TypeError, ValueError):
        raise DomainError(path, f"corrupt {what} (a sequence id is not a number); delete it to start over") from None


def difference(saved: dict, agent, model) -> str | None:
    """The first setting in which a saved run differs from this one ('agent', 'layout' or a config key), or None."""
    if saved.get("agent") != agent.name:
        return f"agent {saved.get('agent')!r}, not {agent.name!r}"
    if saved.get("layout") != model.layout:
        return f"layout {saved.get('layout')!r}, not {model.layout!r}"
    old, new = saved.get("config") or {}, agent.config
    for key in sorted(set(old) | set(new)):
        if old.get(key) != new.get(key):
            return f"{key} {old.get(key)!r}, not {new.get(key)!r}"
    return None


def evaluate(model, agent, ids, out=None, progress=True, reference=None, force=False, strict=False) -> dict:
    """Play the sequences (resuming from OUT.partial.json), then write and return the results.

    Sequences already in a finished OUT of the same agent, configuration and
    layout are kept, not replayed: `--sequences 0-9` extends a 0-3 run. A
    finished OUT made otherwise is an error naming the difference, unless
    `force` (then it is replaced). A saved sequence that does not match the
    canonical one (cut short, edited) is an error; one whose failed tasks were
    not yet charged is played again. OUT is checked writable before anything is
    played. A finished OUT that already holds every sequence asked for is
    returned as it is, not rewritten, so its provenance still names the run
    that played it. Planner timeouts and crashes print one warning line; with
    `strict` they are an error (exit 2) once the results are written.
    """
    from planning.cli import check_writable

    if not ids:
        raise DomainError("--sequences", "no sequences given")
    partial = Path(f"{out}.partial.json") if out else None
    if out:
        check_writable(out)
        check_writable(partial)
    saved_runs: list = []
    wall = 0.0
    finished = None                        # OUT as it is, when it is a finished run of this configuration
    if out and Path(out).is_file():
        saved = _read(Path(out), "results")
        diff = difference(saved, agent, model)
        if diff and not force:
            raise DomainError(out, f"a finished run with {diff}; pass --force to replace it, "
                                   "or --out another file")
        if not diff:
            rows = saved.get("per_task")
            if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
                raise DomainError(out, "corrupt results (per_task is not a list of rows); delete it to start over")
            sequences = saved.get("sequences", [])
            if not isinstance(sequences, list):
                raise DomainError(out, "corrupt results (sequences is not a list); delete it to start over")
            table = {i: [r for r in rows if r.get("sequence") == i] for i in sequences}
            saved_runs.append((Path(out), "results", _saved_sequences(Path(out), "results", table)))
            wall = saved.get("wall_seconds", 0.0)
            finished = saved
    if partial and partial.is_file():
        saved = _read(partial, "partial results")
        if difference(saved, agent, model) is None:
            saved_runs.append((partial, "partial results",          # newer than OUT
                               _saved_sequences(partial, "partial results", saved.get("done"))))
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
            rows = _kept_rows(path, what, known[i], rows)
            if _charged(rows):
                done[i] = rows
            else:
                done.pop(i, None)
    if not isinstance(wall, (int, float)):
        wall = 0.0
    seqs = load(model, ids)
    todo = [s for s in seqs if s.id not in done]
    if finished is not None and not todo and len(saved_runs) == 1:
        result, rows = finished, finished["per_task"]   # nothing to play or merge: OUT stays as written
    else:
        bar = tqdm(total=sum(len(s.tasks) for s in todo), desc=f"{agent.name} {model.layout}",
                   unit="task", disable=not progress)
        for seq in todo:
            start = time.perf_counter()
            done[seq.id] = play_sequence(model, agent, seq, bar)
            wall += time.perf_counter() - start
            if partial:
                write_json(partial, {"agent": agent.name, "layout": model.layout, "config": agent.config,
                                     "wall_seconds": wall, "done": done})
        bar.close()
        seqs = load(model, sorted(set(ids or []) | set(done))) if ids else seqs
        rows = [r for s in seqs for r in done[s.id]]
        result = summary(agent.name, model, [s.id for s in seqs], rows, wall, agent.config, reference)
        if hasattr(agent, "summary"):          # an agent's own keys (e.g. the clairvoyant's K)
            result.update(agent.summary(rows))
        result["provenance"] = results_provenance(agent.config, [s.id for s in todo])
        if out:
            write_json(out, result)
            partial.unlink(missing_ok=True)
    warning = fault_warning(rows)
    if warning:
        if strict:
            raise DomainError(out or agent.name, f"--strict: {warning}")
        print(f"warning: {warning}", file=sys.stderr)
    return result
