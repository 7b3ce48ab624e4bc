"""Benchmark: the Bellman–Novelty search with a learned value, played along a canonical sequence, against the reference.

Plays the first --tasks tasks of a canonical sequence (or of a seeded stream)
in the persistent world: per task the exact optimal planner gives the myopic
reference plan (timed apart, not in the search's time), the search
(`planning.search.bellman_novelty`) chooses a terminal and its plan is
executed. On the same state and task the reference implementation
(`planning.search.bellman_novelty_reference`, the search as it was before the
compiled kernel) is timed too, first or second in turn, so that both see the
same load: the speed-up is a ratio measured in one run, per expansion (wall
clock) and in CPU time, with the compiled value's memo (values kept from one
search to the next, as the agents run) and without it. Each task also checks
that both implementations chose the same plan.
Prints expansions per second of both, where the new search's time goes (value
calls, simulator, novelty tables, the rest: heaps and bookkeeping) and the
mean seconds per task.

    python -m learning.agents.bench_bn --layout three-room --checkpoint checkpoints/rl-anticipatory-three-room-seed0.pt \\
        --tasks 20 --out results/bench-bn-three-room.json
    python -m learning.agents.bench_bn --layout two-room --checkpoint checkpoints/rl-anticipatory-two-room-seed0.pt \\
        --tasks 20 --out results/bench-bn-two-room.json
    python -m learning.agents.bench_bn --layout three-room --value gnn:checkpoints/gnn-faithful-three-room-seed0.pt --tasks 10

`--value KIND:PATH` takes any value of the registry (`learning.values`;
`--checkpoint PATH` is short for `--value q-network:PATH`, and without either
the search runs on the zero value). (It lives in learning/, not planning/search/,
because it loads learned values: planning may not import from learning.) It runs torch, BLAS and OpenMP on one
thread (planning.parallel.one_thread); on a shared machine run it under
`nice` and read the ratios, not the absolute times. `--no-reference` times
the new search alone.
"""

from __future__ import annotations

import copy
import time

import numpy as np

from learning.agents.guided import search_defaults
from learning.values import HELP, load_value, parse
from planning import cli
from planning.atomic import write_json
from planning.domain.batched import BatchedModel
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.parallel import results_provenance
from planning.search.bellman_novelty import DEPTH_CAP, PREFETCH, bellman_novelty_search
from planning.search.bellman_novelty_reference import bellman_novelty_search_reference
from planning.search.optimal import optimal_plan
from planning.world.task_stream import PersistentWorld, draw_tasks

PARTS = ("seconds", "value", "simulator", "novelty", "expansions", "value_calls", "value_states", "cpu")


def _timed(search, *args, **kw):
    c0, t0 = time.process_time(), time.perf_counter()
    r = search(*args, **kw)
    s = r.stats
    return r, {
        "seconds": s.seconds,
        "wall": time.perf_counter() - t0,
        "cpu": time.process_time() - c0,
        "value": s.value_seconds,
        "simulator": s.simulator_seconds,
        "novelty": s.novelty_seconds,
        "expansions": s.expansions,
        "value_calls": s.value_calls,
        "value_states": s.value_states,
    }


def _summary(rows: list, key: str) -> dict:
    """Totals over the searched tasks of one implementation (rows[i][key])."""
    total = {k: sum(r[key][k] for r in rows) for k in PARTS}
    n = max(len(rows), 1)
    sec = max(total["seconds"], 1e-12)
    return {
        "expansions_per_s": total["expansions"] / sec,
        "seconds_per_task": total["seconds"] / n,
        "cpu_seconds_per_task": total["cpu"] / n,
        "max_seconds": max((r[key]["seconds"] for r in rows), default=0.0),
        "shares": {
            "value": total["value"] / sec,
            "simulator": total["simulator"] / sec,
            "novelty": total["novelty"] / sec,
            "rest": 1 - (total["value"] + total["simulator"] + total["novelty"]) / sec,
        },
        "value_calls_per_task": total["value_calls"] / n,
        "value_states_per_task": total["value_states"] / n,
    }


def benchmark(
    model,
    value,
    tasks: list,
    reset_seed: int,
    budget: int,
    beta: float,
    depth_cap: int = DEPTH_CAP,
    prefetch: int = PREFETCH,
    progress: bool = True,
    reference: bool = True,
) -> dict:
    """Play `tasks` from the world of `reset_seed` with the search (and time the reference on each task).

    A Q-network value keeps its compiled values from one search to the next (its memo, as the agents use
    it); the search is also timed with a copy that keeps none ("no_memo"), so that both ratios come from
    the same run."""
    bm = BatchedModel(model)
    world = PersistentWorld(model, reset_seed)
    rows = []
    kw = dict(budget=budget, beta=beta, depth_cap=depth_cap, prefetch=prefetch)
    bare = None
    if callable(getattr(value, "set_memo", None)) and getattr(value, "memo", False):
        bare = copy.copy(value)
        bare.set_memo(False)
    for v in (value, bare):  # build the compiled kernels first, outside the timing
        if tasks and v is not None:
            bellman_novelty_search(model, world.state, tasks[0], v, budget=1, beta=beta, depth_cap=depth_cap)
    for i, task in enumerate(tasks):
        if world.begin(task):
            continue  # already satisfied: no search
        t0 = time.perf_counter()
        ref = optimal_plan(bm, world.state, task)
        t_ref = time.perf_counter() - t0
        state = world.state
        runs = {}
        order = ["new"] + (["no_memo"] if bare is not None else []) + (["reference"] if reference else [])
        for which in order if len(rows) % 2 == 0 else order[::-1]:
            search = bellman_novelty_search_reference if which == "reference" else bellman_novelty_search
            runs[which] = _timed(
                search, model, state, task, bare if which == "no_memo" else value, reference_plan=ref.plan, **kw
            )
        r, new = runs["new"]
        s = r.stats
        if r.plan is None:
            world.abandon()
        else:
            world.execute(r.plan)
        row = {
            "index": i,
            "task": task.name,
            "c_myo": s.c_myo,
            "cost": s.cost,
            "source": s.source,
            "expansions": s.expansions,
            "terminals": s.terminals,
            "eligible": s.eligible,
            "nodes": s.nodes,
            "new": new,
            "reference_seconds": t_ref,
        }
        if bare is not None:
            rb, row["no_memo"] = runs["no_memo"]
            assert rb.plan == r.plan, "a value kept from an earlier search changed a choice"
        if reference:
            rr, old = runs["reference"]
            row.update(reference=old, same_plan=rr.plan == r.plan, reference_cost=rr.stats.cost)
        rows.append(row)
        if progress:
            line = (
                f"{i:3d} {task.name:34s} C_myo {s.c_myo:6} chose {s.cost:6} ({s.source:9s}) "
                f"{s.expansions:6d} exp {new['seconds']:6.3f} s (value {new['value']:5.3f})"
            )
            if reference:
                line += (
                    f"; reference {row['reference']['seconds']:6.2f} s, "
                    f"{'same plan' if row['same_plan'] else 'OTHER PLAN'}"
                )
            print(line, flush=True)
    out = {
        "searched_tasks": len(rows),
        **_summary(rows, "new"),
        "reference_seconds_per_task": sum(r["reference_seconds"] for r in rows) / max(len(rows), 1),
        "cost_per_task": float(np.mean([r["cost"] if r["cost"] is not None else np.nan for r in rows]))
        if rows
        else None,
    }
    if bare is not None:
        out["no_memo"] = _summary(rows, "no_memo")
    if reference:
        old = _summary(rows, "reference")
        out["reference_implementation"] = old

        def speedup(key):
            return {
                "per_expansion": _summary(rows, key)["expansions_per_s"] / max(old["expansions_per_s"], 1e-12),
                "cpu": sum(r["reference"]["cpu"] for r in rows) / max(sum(r[key]["cpu"] for r in rows), 1e-12),
                "min_task": min(
                    (r["reference"]["seconds"] / max(r[key]["seconds"], 1e-12) for r in rows), default=None
                ),
            }

        out["speedup"] = speedup("new")
        if bare is not None:
            out["speedup_no_memo"] = speedup("no_memo")
        out["same_plans"] = sum(r["same_plan"] for r in rows)
    memo = getattr(getattr(value, "native", None), "memo_stats", None)
    if callable(memo):
        out["value_memo"] = memo()
    out["per_task"] = rows
    return out


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True, sequence=True)
    which = p.add_mutually_exclusive_group()
    which.add_argument("--checkpoint", default=None, help="Q-network checkpoint (short for --value q-network:PATH)")
    which.add_argument("--value", default="zero", help=f"{HELP} (default: %(default)s)")
    p.add_argument("--tasks", type=int, default=20, help="tasks to play (default: %(default)s)")
    p.add_argument("--stream", action="store_true", help="a stream drawn with --seed instead of the sequence")
    p.add_argument("--budget", type=int, default=None, help="expansions per task (default: the thesis's)")
    p.add_argument("--beta", type=float, default=None, help="cost slack (default: the thesis's)")
    p.add_argument("--depth-cap", type=int, default=DEPTH_CAP)
    p.add_argument(
        "--prefetch",
        type=int,
        default=PREFETCH,
        help="most states per Python value call (0: no prefetch; a compiled value needs none)",
    )
    p.add_argument(
        "--no-reference",
        dest="reference",
        action="store_false",
        help="do not time the reference implementation (no ratio)",
    )
    p.add_argument(
        "--no-memo",
        dest="memo",
        action="store_false",
        help="the compiled value keeps no values from one search to the next (else both are timed)",
    )
    p.add_argument(
        "--device",
        default=None,
        help="evaluate a Q-network value in torch on this device (cuda; learning.device) instead of the compiled "
        "CPU engine: run once with and once without to compare",
    )
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args()
    from planning.parallel import one_thread

    one_thread()
    model = compile_domain(args.domain, args.layout)
    kind, arg = parse(args.checkpoint or args.value, "q-network")
    value = load_value(args.checkpoint or args.value, model, "q-network")
    if callable(getattr(value, "set_memo", None)):
        value.set_memo(args.memo)
    if args.device is not None:
        if not callable(getattr(value, "to_device", None)):
            raise DomainError("--device", f"the value {args.checkpoint or args.value} is evaluated on the CPU only")
        value.to_device(args.device)
    if args.stream:
        tasks, reset = draw_tasks(model, args.seed, args.tasks), args.seed
    else:
        from planning.world.sequences import load

        seq = load(model, [args.sequence])[0]
        tasks, reset = seq.tasks[: args.tasks], seq.reset_seed
    defaults = search_defaults(model)
    budget = args.budget if args.budget is not None else defaults.get("budget", 5000)
    beta = args.beta if args.beta is not None else defaults.get("beta", 1.25)
    r = benchmark(
        model, value, tasks, reset, budget, beta, args.depth_cap, args.prefetch, not args.quiet, args.reference
    )
    sh = r["shares"]
    print(f"{model.layout}: {r['searched_tasks']} searched tasks, budget {budget}, beta {beta:g}")
    print(
        f"  {r['expansions_per_s']:,.0f} expansions/s, {r['seconds_per_task']:.3f} s per task "
        f"(max {r['max_seconds']:.2f} s); reference planner {r['reference_seconds_per_task']:.3f} s per task"
    )
    print(
        f"  time: value {sh['value']:.0%}, simulator {sh['simulator']:.0%}, novelty {sh['novelty']:.0%}, "
        f"heaps and bookkeeping {sh['rest']:.0%}; {r['value_calls_per_task']:.0f} value calls and "
        f"{r['value_states_per_task']:.0f} states valued per task"
    )
    if args.reference:
        old, up = r["reference_implementation"], r["speedup"]
        print(
            f"  reference implementation: {old['expansions_per_s']:,.0f} expansions/s, "
            f"{old['seconds_per_task']:.3f} s per task"
        )
        print(
            f"  speed-up {up['per_expansion']:.1f}x per expansion ({up['cpu']:.1f}x in CPU time, "
            f"{up['min_task']:.1f}x on the least sped-up task); same plan on {r['same_plans']} of "
            f"{r['searched_tasks']} tasks"
        )
        if "speedup_no_memo" in r:
            up = r["speedup_no_memo"]
            print(
                f"  without the value memo: {r['no_memo']['expansions_per_s']:,.0f} expansions/s, "
                f"{r['no_memo']['seconds_per_task']:.3f} s per task, speed-up {up['per_expansion']:.1f}x per "
                f"expansion ({up['cpu']:.1f}x in CPU time)"
            )
    if args.out:
        config = {
            "layout": model.layout,
            **({} if kind == "q-network" else {"value": kind}),
            "checkpoint": arg,
            "budget": budget,
            "beta": beta,
            "depth_cap": args.depth_cap,
            "prefetch": args.prefetch,
            "memo": args.memo,
            "sequence": None if args.stream else args.sequence,
            "tasks": args.tasks,
            **({} if args.device is None else {"device": args.device}),
        }
        write_json(args.out, {**config, **r, "provenance": results_provenance(config)})
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)
