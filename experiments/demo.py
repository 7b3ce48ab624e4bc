"""Demonstration: a seeded task stream in the persistent restaurant, each task solved optimally alone.

This is the myopic agent of the thesis with our exact in-process planner (A*
with the layout's pattern databases on the compiled model): every plan is
optimal for its own task and blind to the next, and the world it leaves behind
is where the next task starts.

    python -m experiments.demo --layout two-room --tasks 50
"""
from __future__ import annotations

import time

from planning import cli
from planning.atomic import write_json
from oracles.myopic import MyopicOracle
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.world.runner import play_task
from planning.world.task_stream import PersistentWorld, draw_tasks


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True)
    p.add_argument("--tasks", type=int, default=50, help="tasks in the stream (default: %(default)s)")
    args = p.parse_args()
    if args.tasks < 1:
        raise DomainError("--tasks", f"must be at least 1, not {args.tasks}")
    model = compile_domain(args.domain, args.layout)
    planner = MyopicOracle("internal")
    planner.start(model, None)
    world = PersistentWorld(model, reset_seed=args.seed)
    print(f"{model.name} {model.layout}: {model.n_atoms} atoms, {model.n_actions} ground actions, "
          f"{len(model.tasks)} task instances; seed {args.seed}\n")
    print(model.describe(world.state), "\n")
    start = time.perf_counter()
    for i, task in enumerate(draw_tasks(model, args.seed, args.tasks)):
        t0 = time.perf_counter()
        info = play_task(world, planner, task)
        if not info:
            plan_text = "(already satisfied)"
        elif "executed" not in info:
            plan_text = f"(no plan: {info.get('status')})"
        else:
            plan_text = ", ".join(model.actions[a] for a in info["executed"])
        o = world.outcomes[-1]
        print(f"{i:3d} {o.task:34s} cost {o.cost:5d}  actions {o.actions:2d}  "
              f"{time.perf_counter() - t0:5.2f}s  {plan_text}")
    outcomes = world.outcomes
    total = sum(o.cost for o in outcomes)
    print(f"\n{len(outcomes)} tasks: cost per task {total / len(outcomes):.1f}, actions per task "
          f"{sum(o.actions for o in outcomes) / len(outcomes):.2f}, success rate "
          f"{sum(o.success for o in outcomes) / len(outcomes):.2f}, {time.perf_counter() - start:.1f}s")
    by_type: dict[str, list] = {}
    for o in outcomes:
        by_type.setdefault(o.task.split("(")[0], []).append(o.cost)
    for ttype, costs in sorted(by_type.items()):
        print(f"  {ttype:12s} {len(costs):3d} tasks  cost per task {sum(costs) / len(costs):8.1f}")
    if args.out:
        write_json(args.out, {"agent": "myopic-internal", "domain": model.name, "layout": model.layout,
                              "seed": args.seed, "tasks": len(outcomes),
                              "cost_per_task": total / len(outcomes),
                              "per_task": [vars(o) for o in outcomes]})


if __name__ == "__main__":
    cli.run(main)
