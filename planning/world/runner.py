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

`evaluate` plays the sequences a results file does not hold yet: what OUT and
OUT.partial.json already hold, checked against this run's agent, configuration,
failure protocol and domain content, and where each finished sequence goes, are
`planning.world.results`'s (an interrupted run resumes where it stopped, a
finished OUT is extended, never replaced, by a run of the same settings; one
that differs stops with an error naming the difference unless `force` is given,
which replays every sequence asked for). One process writes an OUT at a time
(`planning.atomic.OutputLock`).
"""

from __future__ import annotations

import sys
import time
from contextlib import nullcontext
from pathlib import Path

from tqdm import tqdm

from planning.atomic import OutputLock
from planning.domain.batched import BatchedModel
from planning.domain.identity import identity, mismatch
from planning.errors import DomainError
from planning.parallel import results_provenance
from planning.search.optimal import optimal_plan
from planning.world import results, sequences
from planning.world.agents import Planner
from planning.world.results import COMPLETED_BY, DEFAULT_PROTOCOL, FAILURE_PROTOCOLS, check_protocol
from planning.world.task_stream import PersistentWorld


def play_task(world: PersistentWorld, agent, task, upcoming=()) -> dict:
    """Play one task to its end: begin it; a planner's plan is executed (no plan: abandoned), a policy
    acts until the task completes or is abandoned. Returns what the agent said about it (Reply.info) and
    the actions executed ("executed"; none where the task held already)."""
    if world.begin(task):
        return {}
    if not isinstance(agent, Planner):
        executed = []
        while world.task is not None:
            executed.append(agent.act(world.state, task))
            world.act(executed[-1])
        return {"executed": executed}
    reply = agent.plan(world.state, task, list(upcoming))
    info = dict(reply.info)
    if reply.plan is None:
        world.abandon()
    else:
        info["executed"] = world.execute(reply.plan)
    return info


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
    row.update(
        completion_cost=rest,
        charged_cost=executed + rest,
        cost=executed + rest,
        completion_plan=[world.model.actions[a] for a in plan],
    )
    return row


def play_sequence(model, agent, seq, bar=None, protocol: str = DEFAULT_PROTOCOL) -> list[dict]:
    """Per-task rows of one sequence (failed tasks under `protocol`, see the module's docstring)."""
    check_protocol(protocol)
    world = PersistentWorld(model, reset_seed=seq.reset_seed)
    agent.start(model, seq)
    rows = []
    for i, task in enumerate(seq.tasks):
        start = time.perf_counter()
        info = play_task(world, agent, task, seq.tasks[i + 1 :])
        if "executed" in info:
            info["plan"] = [model.actions[a] for a in info.pop("executed")]
        o = world.outcomes[-1]
        row = {
            "sequence": seq.id,
            "index": i,
            "task": o.task,
            "cost": o.cost,
            "actions": o.actions,
            "success": o.success,
            "auto": o.auto,
            "seconds": round(time.perf_counter() - start, 4),
            **info,
        }
        if not o.success:
            complete_failed(row, world, task, protocol)
        rows.append(row)
        if bar is not None:
            bar.update(1)
    return rows


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
    how = (
        "abandoned where they were left, their executed cost charged"
        if r.get("completed_by") == "nothing"
        else "each completed by the fallback and charged its executed cost plus the optimal completion"
    )
    return (
        f"{len(faults)} of {len(rows)} tasks ended in a planner timeout or crash, the first "
        f"sequence {r['sequence']} task {r['index']} {r['task']}: {r['status']}{msg}; {how}"
    )


def summary(
    agent_name,
    model,
    ids,
    rows,
    wall,
    config,
    reference=None,
    protocol: str = DEFAULT_PROTOCOL,
    resets: dict | None = None,
) -> dict:
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
        raise DomainError(
            f"sequence {r['sequence']} task {r['index']}",
            f"{r['task']} failed and cannot be completed from where it was left, so it has no charged cost",
        )
    cost = sum(r["cost"] for r in rows) / n
    per_seq = []
    for i in ids:
        mine = [r for r in rows if r["sequence"] == i]
        per_seq.append(
            {
                "id": i,
                "cost": sum(r["cost"] for r in mine),
                "tasks": len(mine),
                "successes": sum(r["success"] for r in mine),
                "actions": sum(r["actions"] for r in mine),
            }
        )
        if resets and i in resets:
            per_seq[-1]["reset_seed"] = resets[i]
        if any(not r["success"] for r in mine):
            per_seq[-1]["executed_cost"] = sum(r.get("executed_cost", r["cost"]) for r in mine)
    success = sum(r["success"] for r in rows) / n
    if protocol == "abandon" and success < 1:
        gain, note = (
            None,
            (
                "not comparable: under the thesis's abandon protocol a failed task leaves the "
                f"world unfinished, and {n - sum(r['success'] for r in rows)} of {n} tasks failed"
            ),
        )
    else:
        gain, note = improvement(cost, model, ids, reference, rows, resets)
    out = {
        "agent": agent_name,
        **identity(model),
        "layout": model.layout,
        "sequences": list(ids),
        "tasks": n,
        "cost_per_task": round(cost, 2),
        "actions_per_task": round(sum(r["actions"] for r in rows) / n, 3),
        "success_rate": round(success, 4),
        "improvement_vs_myopic": gain,
    }
    if note:
        out["improvement_note"] = note
    out.update(
        {
            "failure_protocol": protocol,
            "per_sequence": per_seq,
            "per_task": rows,
            "wall_seconds": round(wall, 1),
            "config": config,
        }
    )
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
    ref = results.read(path, "myopic oracle results")
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
                    k = next(
                        (k for k, (a, b) in enumerate(zip(theirs.get(i, []), mine)) if a != b),
                        min(len(theirs.get(i, [])), len(mine)),
                    )
                    return None, f"the reference {path} played other tasks in sequence {i} (from task {k} on)"
                if resets and i in resets and seqs[i].get("reset_seed") not in (None, resets[i]):
                    return None, f"the reference {path} played sequence {i} from another world reset"
                if resets and i in resets and "reset_seed" not in seqs[i]:
                    return None, f"the reference {path} does not record the world reset of sequence {i}"
        c_ref = sum(seqs[i]["cost"] for i in ids) / sum(seqs[i]["tasks"] for i in ids)
    except (KeyError, TypeError, ZeroDivisionError) as e:
        raise DomainError(path, f"corrupt myopic oracle results ({type(e).__name__}: {e})") from None
    return round((c_ref - cost) / c_ref, 4), None


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


def evaluate(
    model,
    agent,
    ids,
    out=None,
    progress=True,
    reference=None,
    force=False,
    strict=False,
    protocol: str = DEFAULT_PROTOCOL,
    played_by_workers=(),
    stream: str | None = None,
) -> Evaluation:
    """Play the sequences (resuming from OUT.partial.json), then write and return the results.

    `stream`: whose canonical sequences (`planning.world.sequences`; None: the i.i.d. ones); the agent's
    config names it (`Agent.on_stream`), so a results file of one stream never extends another's.

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
        return _evaluate(
            model, agent, ids, out, partial, progress, reference, force, strict, protocol, played_by_workers, stream
        )


def _evaluate(
    model, agent, ids, out, partial, progress, reference, force, strict, protocol, played_by_workers, stream=None
) -> Evaluation:
    if stream not in (None, "iid") and agent.config.get("stream") != stream:
        raise DomainError("--stream", f"the agent's config does not name stream {stream} (call its on_stream)")
    kept = results.resume(model, agent, out, partial, protocol, force, played_by_workers)
    done, wall, kept_prov = kept.done, kept.wall, kept.provenance
    seqs = sequences.load(model, ids, stream)
    todo = [s for s in seqs if s.id not in done]
    played = sorted({s.id for s in todo} | ({int(i) for i in played_by_workers} & set(done)))
    seconds = 0.0
    if kept.finished is not None and not todo and kept.files == 1:
        result, wrote = Evaluation(kept.finished), False  # nothing to play or merge: OUT stays as written
    else:
        bar = tqdm(
            total=sum(len(s.tasks) for s in todo),
            desc=f"{agent.name} {model.layout}",
            unit="task",
            disable=not progress,
        )
        for seq in todo:
            start = time.perf_counter()
            done[seq.id] = play_sequence(model, agent, seq, bar, protocol)
            wall += time.perf_counter() - start
            seconds += time.perf_counter() - start
            if partial:
                results.write_partial(partial, agent, model, protocol, wall, done, kept_prov)
        bar.close()
        seqs = sequences.load(model, sorted(set(ids) | set(done)), stream)
        rows = [r for s in seqs for r in done[s.id]]
        result = Evaluation(
            summary(
                agent.name,
                model,
                [s.id for s in seqs],
                rows,
                wall,
                agent.config,
                reference,
                protocol,
                {s.id: s.reset_seed for s in seqs},
            )
        )
        result.update(agent.summary(rows))  # an agent's own keys (e.g. the clairvoyant's K)
        _self_reference(result, out, reference)
        result["provenance"] = results_provenance(agent.config, played, kept_prov)
        wrote = bool(out)
        if out:
            results.write(out, partial, dict(result))
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
    asked = summary(agent.name, model, list(ids), rows, 0.0, result.get("config"), reference, protocol, resets or None)
    asked.pop("wall_seconds")
    _self_reference(asked, out, reference)
    return asked
