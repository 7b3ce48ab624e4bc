"""The sequence runner: an agent plays tasks in a persistent world; the results JSON of SPEC.md.

Rules (thesis Chapter 3, §5.2.3): the world is reset once per sequence and
persists across its tasks; a task already satisfied completes at zero cost; a
task not completed within the action budget (64) is abandoned, its cost
charged; a planner that finds no plan fails the task. Finished sequences are
kept in OUT.partial.json, so an interrupted run resumes where it stopped, and a
finished OUT is extended, never replaced, by a run of the same agent and
configuration; a run with another configuration stops with an error naming
the differing setting unless `force` is given.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from tqdm import tqdm

from planning.atomic import write_json
from planning.errors import DomainError
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


def play_sequence(model, agent, seq, bar=None) -> list[dict]:
    """Per-task rows of one sequence."""
    world = PersistentWorld(model, reset_seed=seq.reset_seed)
    agent.start(model, seq)
    rows = []
    for i, task in enumerate(seq.tasks):
        start = time.perf_counter()
        info = play_task(world, agent, task, seq.tasks[i + 1:])
        if "executed" in info:
            info["plan"] = [model.actions[a] for a in info.pop("executed")]
        o = world.outcomes[-1]
        rows.append({"sequence": seq.id, "index": i, "task": o.task, "cost": o.cost,
                     "actions": o.actions, "success": o.success, "auto": o.auto,
                     "seconds": round(time.perf_counter() - start, 4), **info})
        if bar is not None:
            bar.update(1)
    return rows


def summary(agent_name, model, ids, rows, wall, config, reference=None) -> dict:
    """The results JSON of SPEC.md; `reference`: the myopic oracle's results file for the improvement."""
    n = len(rows)
    cost = sum(r["cost"] for r in rows) / n
    per_seq = []
    for i in ids:
        mine = [r for r in rows if r["sequence"] == i]
        per_seq.append({"id": i, "cost": sum(r["cost"] for r in mine), "tasks": len(mine),
                        "successes": sum(r["success"] for r in mine),
                        "actions": sum(r["actions"] for r in mine)})
    return {"agent": agent_name, "domain": model.name, "layout": model.layout, "sequences": list(ids),
            "tasks": n, "cost_per_task": round(cost, 2),
            "actions_per_task": round(sum(r["actions"] for r in rows) / n, 3),
            "success_rate": round(sum(r["success"] for r in rows) / n, 4),
            "improvement_vs_myopic": improvement(cost, model, ids, reference),
            "per_sequence": per_seq, "per_task": rows, "wall_seconds": round(wall, 1),
            "config": config}


def improvement(cost: float, model, ids, reference=None) -> float | None:
    """(C_oracle - C) / C_oracle against the myopic oracle's results file on the same sequences (None without one)."""
    path = Path(reference) if reference else None
    if path is None or not path.is_file():
        return None
    ref = json.loads(path.read_text())
    seqs = {s["id"]: s for s in ref["per_sequence"]}
    if ref.get("domain") != model.name or ref.get("layout") != model.layout or not set(ids) <= set(seqs):
        return None
    c_ref = sum(seqs[i]["cost"] for i in ids) / sum(seqs[i]["tasks"] for i in ids)
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
    if not isinstance(saved, dict):
        raise DomainError(path, f"corrupt {what} (not a JSON object); delete it to start over")
    return saved


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


def evaluate(model, agent, ids, out=None, progress=True, reference=None, force=False) -> dict:
    """Play the sequences (resuming from OUT.partial.json), then write and return the results.

    Sequences already in a finished OUT of the same agent, configuration and
    layout are kept, not replayed: `--sequences 0-9` extends a 0-3 run. A
    finished OUT made otherwise is an error naming the difference, unless
    `force` (then it is replaced).
    """
    partial = Path(f"{out}.partial.json") if out else None
    done: dict[int, list] = {}
    wall = 0.0
    if out and Path(out).is_file():
        saved = _read(Path(out), "results")
        diff = difference(saved, agent, model)
        if diff and not force:
            raise DomainError(out, f"a finished run with {diff}; pass --force to replace it, "
                                   "or --out another file")
        if not diff:
            for i in saved.get("sequences", []):
                done[int(i)] = [r for r in saved["per_task"] if r["sequence"] == i]
            wall = saved.get("wall_seconds", 0.0)
    if partial and partial.is_file():
        saved = _read(partial, "partial results")
        if difference(saved, agent, model) is None:
            done.update({int(k): v for k, v in saved["done"].items()})   # newer than OUT
            wall += saved.get("wall_seconds", 0.0)
    seqs = load(model, ids)
    todo = [s for s in seqs if s.id not in done]
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
    if out:
        write_json(out, result)
        partial.unlink(missing_ok=True)
    return result
