"""Benchmark: the Bellman–Novelty search with a learned value, played along a canonical sequence.

Plays the first --tasks tasks of a canonical sequence (or of a seeded stream)
in the persistent world: per task the exact optimal planner gives the myopic
reference plan (timed apart, not in the search's time), the search chooses a
terminal and its plan is executed. Prints expansions per second, where the
search's time goes (value calls, simulator, novelty tables, the rest:
heaps and bookkeeping) and the mean seconds per task.

    python -m learning.bench_bn --layout three-room --checkpoint checkpoints/rl-anticipatory-three-room-seed0.pt \\
        --tasks 20 --budget 20000
    python -m learning.bench_bn --layout three-room --gnn checkpoints/gnn-faithful-three-room-seed0.pt --tasks 10

(It lives in learning/, not planning/search/, because it loads a Q-network:
planning may not import from learning.) Run torch single-threaded
(OMP_NUM_THREADS=1) on a shared machine; the value runs in numpy anyway.
"""
from __future__ import annotations

import time

import numpy as np

from learning.qnet import load_value_function
from planning import cli
from planning.atomic import write_json
from planning.world.runner import results_provenance
from planning.domain.batched import BatchedModel
from planning.domain.compiler import compile_domain
from learning.guided import search_defaults
from planning.search.bellman_novelty import DEPTH_CAP, PREFETCH, bellman_novelty_search
from planning.search.optimal import optimal_plan
from planning.value import ZeroValue
from planning.world.task_stream import PersistentWorld, draw_tasks


def benchmark(model, value, tasks: list, reset_seed: int, budget: int, beta: float, depth_cap: int = DEPTH_CAP,
              prefetch: int = PREFETCH, progress: bool = True) -> dict:
    """Play `tasks` from the world of `reset_seed` with the search; per-task rows and time totals."""
    bm = BatchedModel(model)
    world = PersistentWorld(model, reset_seed)
    rows = []
    for i, task in enumerate(tasks):
        if world.begin(task):
            continue                                   # already satisfied: no search
        t0 = time.perf_counter()
        ref = optimal_plan(bm, world.state, task)
        t_ref = time.perf_counter() - t0
        r = bellman_novelty_search(model, world.state, task, value, budget=budget, beta=beta,
                                   depth_cap=depth_cap, reference_plan=ref.plan, prefetch=prefetch)
        s = r.stats
        if r.plan is None:
            world.abandon()
        else:
            world.execute(r.plan)
        rows.append({"index": i, "task": task.name, "c_myo": s.c_myo, "cost": s.cost, "source": s.source,
                     "expansions": s.expansions, "terminals": s.terminals, "eligible": s.eligible,
                     "nodes": s.nodes, "seconds": s.seconds, "value": s.value_seconds,
                     "simulator": s.simulator_seconds, "novelty": s.novelty_seconds,
                     "value_calls": s.value_calls, "value_states": s.value_states, "reference_seconds": t_ref})
        if progress:
            print(f"{i:3d} {task.name:34s} C_myo {s.c_myo:6} chose {s.cost:6} ({s.source:9s}) "
                  f"{s.expansions:6d} exp {s.seconds:6.2f} s (value {s.value_seconds:5.2f}, "
                  f"{s.value_calls} calls / {s.value_states} states)", flush=True)
    total = {k: sum(r[k] for r in rows) for k in ("seconds", "value", "simulator", "novelty", "expansions",
                                                   "value_calls", "value_states", "reference_seconds")}
    n = max(len(rows), 1)
    sec = max(total["seconds"], 1e-12)
    return {"searched_tasks": len(rows), "expansions_per_s": total["expansions"] / sec,
            "seconds_per_task": total["seconds"] / n, "max_seconds": max((r["seconds"] for r in rows), default=0.0),
            "shares": {"value": total["value"] / sec, "simulator": total["simulator"] / sec,
                       "novelty": total["novelty"] / sec,
                       "rest": 1 - (total["value"] + total["simulator"] + total["novelty"]) / sec},
            "value_calls_per_task": total["value_calls"] / n, "value_states_per_task": total["value_states"] / n,
            "reference_seconds_per_task": total["reference_seconds"] / n,
            "cost_per_task": float(np.mean([r["cost"] if r["cost"] is not None else np.nan for r in rows]))
            if rows else None, "per_task": rows}


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True)
    which = p.add_mutually_exclusive_group()
    which.add_argument("--checkpoint", default=None, help="Q-network checkpoint (default: none, the zero value)")
    which.add_argument("--gnn", default=None, help="a GNN checkpoint instead: its C_AP estimate as the value")
    p.add_argument("--tasks", type=int, default=20, help="tasks to play (default: %(default)s)")
    p.add_argument("--sequence", type=int, default=0, help="canonical sequence (default: %(default)s)")
    p.add_argument("--stream", action="store_true", help="a stream drawn with --seed instead of the sequence")
    p.add_argument("--budget", type=int, default=None, help="expansions per task (default: the thesis's)")
    p.add_argument("--beta", type=float, default=None, help="cost slack (default: the thesis's)")
    p.add_argument("--depth-cap", type=int, default=DEPTH_CAP)
    p.add_argument("--prefetch", type=int, default=PREFETCH, help="most states per value call (0: no prefetch)")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args()
    try:
        import torch
        torch.set_num_threads(1)
    except ImportError:
        pass
    model = compile_domain(args.domain, args.layout)
    if args.gnn:
        from learning.gnn_value import GNNValue
        value = GNNValue(args.gnn, model)
    elif args.checkpoint:
        value = load_value_function(args.checkpoint, model)
    else:
        value = ZeroValue(float(model.config.get("reward", {}).get("gamma", 1.0)))
    if args.stream:
        tasks, reset = draw_tasks(model, args.seed, args.tasks), args.seed
    else:
        from planning.world.sequences import load
        seq = load(model, [args.sequence])[0]
        tasks, reset = seq.tasks[:args.tasks], seq.reset_seed
    defaults = search_defaults(model)
    budget = args.budget if args.budget is not None else defaults.get("budget", 5000)
    beta = args.beta if args.beta is not None else defaults.get("beta", 1.25)
    r = benchmark(model, value, tasks, reset, budget, beta, args.depth_cap, args.prefetch, not args.quiet)
    sh = r["shares"]
    print(f"{model.layout}: {r['searched_tasks']} searched tasks, budget {budget}, beta {beta:g}, "
          f"prefetch {args.prefetch}")
    print(f"  {r['expansions_per_s']:,.0f} expansions/s, {r['seconds_per_task']:.3f} s per task "
          f"(max {r['max_seconds']:.2f} s); reference planner {r['reference_seconds_per_task']:.3f} s per task")
    print(f"  time: value {sh['value']:.0%}, simulator {sh['simulator']:.0%}, novelty {sh['novelty']:.0%}, "
          f"heaps and bookkeeping {sh['rest']:.0%}; {r['value_calls_per_task']:.0f} value calls and "
          f"{r['value_states_per_task']:.0f} states valued per task")
    if args.out:
        config = {"layout": model.layout, "checkpoint": args.gnn or args.checkpoint, "budget": budget,
                  "beta": beta, "depth_cap": args.depth_cap, "prefetch": args.prefetch}
        write_json(args.out, {**config, **r, "provenance": results_provenance(config)})
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)
