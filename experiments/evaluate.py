"""Play an agent on the canonical sequences under the persistent-world rules; write the results JSON.

Rules (thesis Chapter 3, §5.2.3): the world is reset once per sequence and
persists across its tasks; a task already satisfied completes at zero cost; a
task not completed within the action budget (64) is abandoned, its cost
charged; a planner that finds no plan fails the task. Finished sequences are
kept in OUT.partial.json, so an interrupted run resumes where it stopped.

    python -m experiments.evaluate --agent myopic-oracle --layout two-room --out results/x.json
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from tqdm import tqdm

from planning import cli
from planning.atomic import write_json
from planning.compiler import compile_domain
from planning.errors import DomainError
from planning.sequences import load
from planning.task_stream import PersistentWorld

from .agents import AGENTS, Planner, make_agent


def play_sequence(model, agent, seq, bar=None) -> list[dict]:
    """Per-task rows of one sequence."""
    world = PersistentWorld(model, reset_seed=seq.reset_seed)
    agent.start(model, seq)
    rows = []
    for i, task in enumerate(seq.tasks):
        start = time.perf_counter()
        info = {}
        if not world.begin(task):
            if isinstance(agent, Planner):
                reply = agent.plan(world.state, task, seq.tasks[i + 1:])
                info = dict(reply.info)
                if reply.plan is None:
                    world.abandon()
                else:
                    executed = world.execute(reply.plan)
                    info["plan"] = [model.actions[a] for a in executed]
            else:
                while world.task is not None:
                    world.act(agent.act(world.state, task))
        o = world.outcomes[-1]
        rows.append({"sequence": seq.id, "index": i, "task": o.task, "cost": o.cost,
                     "actions": o.actions, "success": o.success, "auto": o.auto,
                     "seconds": round(time.perf_counter() - start, 4), **info})
        if bar is not None:
            bar.update(1)
    return rows


def summary(agent_name, model, ids, rows, wall, config, reference=None) -> dict:
    """The results JSON of SPEC.md."""
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
    """(C_oracle - C) / C_oracle against the myopic oracle's results on the same sequences."""
    path = Path(reference) if reference else Path("results") / f"myopic-oracle-{model.layout}.json"
    if not path.is_file():
        return None
    ref = json.loads(path.read_text())
    seqs = {s["id"]: s for s in ref["per_sequence"]}
    if ref.get("domain") != model.name or not set(ids) <= set(seqs):
        return None
    c_ref = sum(seqs[i]["cost"] for i in ids) / sum(seqs[i]["tasks"] for i in ids)
    return round((c_ref - cost) / c_ref, 4)


def evaluate(model, agent, ids, out=None, progress=True, reference=None) -> dict:
    """Play the sequences (resuming from OUT.partial.json), then write and return the results.

    Sequences already in a finished OUT of the same agent, configuration and
    layout are kept, not replayed: `--sequences 0-9` extends a 0-3 run.
    """
    partial = Path(f"{out}.partial.json") if out else None
    done: dict[int, list] = {}
    wall = 0.0
    if out and Path(out).is_file():
        try:
            saved = json.loads(Path(out).read_text())
        except json.JSONDecodeError as e:
            raise DomainError(out, f"corrupt results ({e}); delete it to start over") from None
        if saved.get("agent") == agent.name and saved.get("config") == agent.config \
                and saved.get("layout") == model.layout:
            for i in saved.get("sequences", []):
                done[int(i)] = [r for r in saved["per_task"] if r["sequence"] == i]
            wall = saved.get("wall_seconds", 0.0)
    if partial and partial.is_file():
        try:
            saved = json.loads(partial.read_text())
        except json.JSONDecodeError as e:
            raise DomainError(partial, f"corrupt partial results ({e}); delete it to start over") from None
        if saved.get("agent") == agent.name and saved.get("config") == agent.config \
                and saved.get("layout") == model.layout:
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


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], sequences=True)
    p.add_argument("--agent", required=True, help=f"one of: {', '.join(AGENTS)}")
    p.add_argument("--planner", default="fast-downward", choices=["fast-downward", "internal"])
    p.add_argument("--time-limit", type=float, default=600.0, help="planner seconds per task")
    p.add_argument("--K", type=int, default=3, help="window of the clairvoyant oracle")
    p.add_argument("--checkpoint", default=None, help="Q-network checkpoint of the rl-greedy agent")
    args = p.parse_args()
    model = compile_domain(args.domain, args.layout)
    agent = make_agent(args.agent, args)
    out = args.out or f"results/{agent.name}-{model.layout}.json"
    r = evaluate(model, agent, cli.parse_ids(args.sequences), out)
    print(f"{r['agent']} {r['layout']}: cost per task {r['cost_per_task']}, actions per task "
          f"{r['actions_per_task']}, success rate {r['success_rate']}, "
          f"improvement vs myopic {r['improvement_vs_myopic']}; wrote {out}")


if __name__ == "__main__":
    cli.run(main)
