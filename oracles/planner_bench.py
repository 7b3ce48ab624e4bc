"""Benchmark: our exact optimal planner against Fast Downward's blind A*, in one run.

On the (state, task) pairs the myopic oracle meets along a canonical sequence it
times both planners, checks that every cost is equal, and prints the ratios.

    python -m oracles.planner_bench --layout two-room [--calls 20] [--sequence 0] [--out FILE]
"""

from __future__ import annotations

import time

from planning import cli
from planning.atomic import write_json
from planning.domain.batched import BatchedModel
from planning.domain.compiler import compile_domain
from planning.parallel import results_provenance


def planner_pairs(model, sequence_id: int, n: int) -> list:
    """(state, task) pairs met by the myopic oracle along a canonical sequence, auto-completions skipped."""
    from planning.search.optimal import optimal_plan
    from planning.world.agents import PlanFunction, Reply
    from planning.world.runner import play_task
    from planning.world.sequences import load
    from planning.world.task_stream import PersistentWorld

    seq = load(model, [sequence_id])[0]
    bm = BatchedModel(model)
    pairs = []

    def plan(state, task):
        pairs.append((state, task))
        return Reply(optimal_plan(bm, state, task).plan)

    planner = PlanFunction(plan)
    world = PersistentWorld(model, seq.reset_seed)
    for task in seq.tasks:
        if len(pairs) >= n:
            break
        play_task(world, planner, task)
    return pairs


def benchmark_planner(model, sequence_id: int = 0, n: int = 20, time_limit: float = 600.0) -> dict:
    """Our exact A* against Fast Downward's blind A* on the same (state, task) pairs, with equal costs."""
    from planning.external import fast_downward as fd
    from planning.search.optimal import optimal_plan

    pairs = planner_pairs(model, sequence_id, n)
    bm = BatchedModel(model)
    rows = []
    for state, task in pairs:
        t0 = time.perf_counter()
        ours = optimal_plan(bm, state, task)
        t_ours = time.perf_counter() - t0
        theirs = fd.solve(model, state, task, time_limit)
        if ours.cost != theirs.cost:
            raise AssertionError(f"{task.name}: our cost {ours.cost}, Fast Downward's {theirs.cost}")
        rows.append(
            {
                "task": task.name,
                "cost": ours.cost,
                "ours_s": round(t_ours, 4),
                "fast_downward_s": round(theirs.seconds, 4),
                "ours_expansions": ours.expansions,
                "fast_downward_expansions": theirs.expansions,
            }
        )
    ours_total = sum(r["ours_s"] for r in rows)
    fd_total = sum(r["fast_downward_s"] for r in rows)
    per_call = sorted(r["fast_downward_s"] / max(r["ours_s"], 1e-6) for r in rows)
    return {
        "domain": model.name,
        "layout": model.layout,
        "sequence": sequence_id,
        "calls": len(rows),
        "ours_seconds": round(ours_total, 3),
        "fast_downward_seconds": round(fd_total, 3),
        "ratio_total": round(fd_total / ours_total, 2),
        "ratio_per_call_median": round(per_call[len(per_call) // 2], 2),
        "ratio_per_call_min": round(per_call[0], 2),
        "equal_costs": True,
        "calls_detail": rows,
    }


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0], sequence=True, helps={"sequence": "canonical sequence whose tasks are planned"}
    )
    p.add_argument("--calls", type=int, default=20, help="planner calls (default: %(default)s)")
    p.add_argument("--time-limit", type=float, default=600.0, help="Fast Downward seconds per call")
    args = p.parse_args()
    model = compile_domain(args.domain, args.layout)
    r = benchmark_planner(model, args.sequence, args.calls, args.time_limit)
    for c in r["calls_detail"]:
        print(
            f"  {c['task']:34s} cost {c['cost']:5d}  ours {c['ours_s']:8.3f}s "
            f"({c['ours_expansions']} states)  Fast Downward {c['fast_downward_s']:8.3f}s "
            f"({c['fast_downward_expansions']} expanded)"
        )
    print(
        f"{r['calls']} calls, equal costs: ours {r['ours_seconds']}s, Fast Downward "
        f"{r['fast_downward_seconds']}s; ratio total {r['ratio_total']}, per call median "
        f"{r['ratio_per_call_median']} (min {r['ratio_per_call_min']})"
    )
    if args.out:
        write_json(args.out, {**r, "provenance": results_provenance(vars(args))})


if __name__ == "__main__":
    cli.run(main)
