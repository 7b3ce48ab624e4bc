"""Benchmark: the labelling oracle against |T| Fast Downward calls per state, in one run.

It times the labelling oracle (every task's optimal cost from a state by one
multi-goal search) against Fast Downward making |T| blind-A* calls per state, on
the same states (every 10th of the first distinct states of the cached myopic
rollout, seed --seed), checks that every cost agrees, and prints states per
second of both and the ratio:

    python -m oracles.labelling_bench --layout three-room --states 20 [--heuristic pdb,lmcut]
"""

from __future__ import annotations

import platform
import time

from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain


def labelling_states(model, n: int, seed: int = 0, spread: int = 10) -> list[int]:
    """n faithful-dataset states (myopic rollout, oracles.rollouts): every `spread`-th of the first n x spread,
    so the sample reaches past the fresh world into states where the machine water is used up."""
    from oracles.rollouts import faithful_states

    return faithful_states(model, n * spread, seed, progress=False)[::spread][:n]


def benchmark_labelling(
    model,
    states: list[int],
    heuristics=("pdb",),
    fd_time_limit: float = 600.0,
    fast_downward: bool = True,
    progress: bool = True,
) -> dict:
    """Labelling states/s of our multi-goal search (per heuristic) against |T| Fast Downward calls per state."""
    from tqdm import tqdm

    from oracles.labelling import Labeller
    from planning.external import fast_downward as fd

    out = {
        "domain": model.name,
        "layout": model.layout,
        "states": len(states),
        "tasks": len(model.tasks),
        "ours": {},
        "machine": f"{platform.machine()} {platform.python_implementation()} {platform.python_version()}",
    }
    reference = None
    for name in heuristics:
        t0 = time.perf_counter()
        lab = Labeller(model, name)
        setup = time.perf_counter() - t0  # once per layout and process (pattern databases)
        rows, t0 = [], time.perf_counter()
        for s in tqdm(states, desc=f"labelling ({lab.heuristic})", disable=not progress):
            r = lab.label(s)
            rows.append(
                {"c_ap": r.c_ap, "seconds": round(r.seconds, 3), "closed": r.closed, "costs": [int(c) for c in r.costs]}
            )
        total = time.perf_counter() - t0
        if reference is not None and [r["costs"] for r in rows] != reference:
            raise AssertionError(f"heuristic {name} gives other costs than {heuristics[0]}")
        reference = [r["costs"] for r in rows]
        out["ours"][lab.heuristic] = {
            "setup_seconds": round(setup, 2),
            "seconds": round(total, 2),
            "states_per_s": round(len(states) / total, 4),
            "max_state_seconds": max(r["seconds"] for r in rows),
            "per_state": rows,
        }
    if fast_downward:
        t0, calls, fd_rows = time.perf_counter(), 0, []
        for i, s in enumerate(tqdm(states, desc="Fast Downward, |T| calls per state", disable=not progress)):
            costs, t_state = [], time.perf_counter()
            for j, task in enumerate(model.tasks):
                if task.satisfied(s):
                    costs.append(0)  # already satisfied: no call needed, as in the stream
                    continue
                r = fd.solve(model, s, task, fd_time_limit)
                calls += 1
                if r.status != fd.Status.SOLVED:
                    raise AssertionError(f"Fast Downward: {task.name} from state {i}: {r.status.value}")
                costs.append(r.cost)
                if reference is not None and r.cost != reference[i][j]:
                    raise AssertionError(f"{task.name} from state {i}: ours {reference[i][j]}, Fast Downward {r.cost}")
            fd_rows.append({"seconds": round(time.perf_counter() - t_state, 3), "costs": costs})
        total = time.perf_counter() - t0
        out["fast_downward"] = {
            "seconds": round(total, 2),
            "calls": calls,
            "states_per_s": round(len(states) / total, 4),
            "per_state": fd_rows,
        }
        for r in out["ours"].values():
            r["ratio_vs_fast_downward"] = round(r["states_per_s"] / out["fast_downward"]["states_per_s"], 2)
        out["equal_costs"] = True
    return out


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0], seed=True, helps={"seed": "seed of the cached myopic rollout the states come from"}
    )
    p.add_argument("--states", type=int, default=20, help="faithful states to label (default: %(default)s)")
    p.add_argument(
        "--heuristic",
        default="pdb",
        help="labelling heuristics to time, comma-separated: pdb, lmcut, lmcut-pc, hmax, blind (default: %(default)s)",
    )
    p.add_argument("--no-fast-downward", action="store_true", help="time ours only")
    args = p.parse_args()
    model = compile_domain(args.domain, args.layout)
    states = labelling_states(model, args.states, args.seed)
    r = benchmark_labelling(model, states, args.heuristic.split(","), fast_downward=not args.no_fast_downward)
    print(f"{r['domain']} {r['layout']}: {r['states']} states x {r['tasks']} tasks")
    for name, o in r["ours"].items():
        ratio = f", {o['ratio_vs_fast_downward']}x Fast Downward" if "ratio_vs_fast_downward" in o else ""
        print(
            f"  ours ({name:5s}) {o['seconds']:9.1f}s  {o['states_per_s']:8.4f} states/s"
            f"  (slowest state {o['max_state_seconds']}s; set-up {o['setup_seconds']}s){ratio}"
        )
    if "fast_downward" in r:
        f = r["fast_downward"]
        print(
            f"  Fast Downward {f['seconds']:9.1f}s  {f['states_per_s']:8.4f} states/s  ({f['calls']} calls; "
            f"equal costs)"
        )
    if args.out:
        write_json(args.out, r)
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)
