"""Benchmark: our simulator against unified-planning's SequentialSimulator, in one run.

On one set of reachable states (seeded random walks from world resets) it times
(a) successors(state) of our simulator, (b) the batched numpy step expanding the
same states, tiled into one large batch, and (c) unified-planning's
SequentialSimulator enumerating applicable actions and applying each. All three
must produce the same successors (checked); the ratios are what matter, since
absolute times on a shared machine are noisy.

    python -m planning.bench --domain domains/restaurant --layout three-room --out FILE

With --planner it times our exact planner against Fast Downward instead, on the
(state, task) pairs the myopic oracle meets along a canonical sequence.

With --labelling it times the labelling oracle (oracles.labelling: every task's
optimal cost from a state by one multi-goal search) against Fast Downward making
|T| blind-A* calls per state, on the same states (every 10th of the first distinct
states of the cached myopic rollout, seed --seed), checks that every cost agrees, and
prints states per second of both and the ratio:

    python -m planning.bench --labelling --layout three-room --states 20 [--heuristic pdb,lmcut]
"""
from __future__ import annotations

import platform
import time

import numpy as np

from . import cli
from .atomic import write_json
from .batched import BatchedModel
from .compiler import compile_domain


def reachable_states(model, n: int, seed: int, walk: int = 64) -> list[int]:
    """Up to n distinct states from seeded random walks, each walk starting at a world reset."""
    rng = np.random.default_rng(seed)
    states, seen = [], set()
    for _ in range(max(100, 10 * n // walk)):   # small domains have fewer than n states
        if len(states) >= n:
            break
        s = model.reset_state(rng)
        for _ in range(walk):
            if s not in seen:
                seen.add(s)
                states.append(s)
            succ = model.successors(s)
            s = succ[rng.integers(len(succ))][1]
    return states[:n]


def _timed(fn, min_seconds: float) -> tuple[float, int]:
    """(seconds per call, calls) over repeated calls lasting at least min_seconds."""
    calls, start = 0, time.perf_counter()
    while True:
        fn()
        calls += 1
        elapsed = time.perf_counter() - start
        if elapsed >= min_seconds:
            return elapsed / calls, calls


def benchmark(model, n_states: int = 300, seed: int = 0, batch: int = 8192,
              min_seconds: float = 2.0) -> dict:
    """Successors per second of the three simulators on the same states, and their ratios."""
    from unified_planning.shortcuts import SequentialSimulator

    from .up_bridge import UPStates, up_problem

    states = reachable_states(model, n_states, seed)
    ours = [model.successors(s) for s in states]
    n_succ = sum(map(len, ours))

    t_single, _ = _timed(lambda: [model.successors(s) for s in states], min_seconds)

    bm = BatchedModel(model)
    packed = bm.pack(states)
    tiled = np.tile(packed, (max(1, batch // len(states)), 1))
    parent, _, _, _ = bm.successors(tiled)
    assert len(parent) == n_succ * (len(tiled) // len(states)), "batched successors disagree"
    t_batch, _ = _timed(lambda: bm.successors(tiled), min_seconds)

    problem = up_problem(model)
    with SequentialSimulator(problem=problem) as sim:
        conv = UPStates(model, problem, sim)
        up_states = [conv.to_up(s) for s in states]

        def reference():
            count = 0
            for st in up_states:
                for action, params in sim.get_applicable_actions(st):
                    sim.apply(st, action, params)
                    count += 1
            return count

        assert reference() == n_succ, "unified-planning's successors disagree with ours"
        t_ref, _ = _timed(reference, min_seconds)

    single = n_succ / t_single
    batched = len(parent) / t_batch
    ref = n_succ / t_ref
    return {
        "domain": model.name, "layout": model.layout, "states": len(states),
        "successors": n_succ, "mean_branching": round(n_succ / len(states), 2),
        "batch_size": len(tiled),
        "successors_per_s": round(single), "batched_transitions_per_s": round(batched),
        "reference_successors_per_s": round(ref, 1),
        "ratio_single": round(single / ref, 1), "ratio_batched": round(batched / ref, 1),
        "machine": f"{platform.machine()} {platform.python_implementation()} {platform.python_version()}",
    }


def planner_pairs(model, sequence_id: int, n: int) -> list:
    """(state, task) pairs met by the myopic oracle along a canonical sequence, auto-completions skipped."""
    from .heuristics import HMax
    from .search import optimal_plan
    from .sequences import load
    from .task_stream import PersistentWorld

    seq = load(model, [sequence_id])[0]
    bm = BatchedModel(model)
    hmax = HMax(model, bm)
    world = PersistentWorld(model, seq.reset_seed)
    pairs = []
    for task in seq.tasks:
        if world.begin(task):
            continue
        pairs.append((world.state, task))
        for a in optimal_plan(bm, world.state, task).plan:
            world.act(a)
        if len(pairs) >= n:
            break
    return pairs


def benchmark_planner(model, sequence_id: int = 0, n: int = 20, time_limit: float = 600.0) -> dict:
    """Our exact A* against Fast Downward's blind A* on the same (state, task) pairs, with equal costs."""
    from . import fast_downward as fd
    from .heuristics import HMax
    from .search import optimal_plan

    pairs = planner_pairs(model, sequence_id, n)
    bm = BatchedModel(model)
    hmax = HMax(model, bm)
    rows = []
    for state, task in pairs:
        t0 = time.perf_counter()
        ours = optimal_plan(bm, state, task)
        t_ours = time.perf_counter() - t0
        theirs = fd.solve(model, state, task, time_limit)
        if ours.cost != theirs.cost:
            raise AssertionError(f"{task.name}: our cost {ours.cost}, Fast Downward's {theirs.cost}")
        rows.append({"task": task.name, "cost": ours.cost, "ours_s": round(t_ours, 4),
                     "fast_downward_s": round(theirs.seconds, 4), "ours_expansions": ours.expansions,
                     "fast_downward_expansions": theirs.expansions})
    ours_total = sum(r["ours_s"] for r in rows)
    fd_total = sum(r["fast_downward_s"] for r in rows)
    per_call = sorted(r["fast_downward_s"] / max(r["ours_s"], 1e-6) for r in rows)
    return {"domain": model.name, "layout": model.layout, "sequence": sequence_id, "calls": len(rows),
            "ours_seconds": round(ours_total, 3), "fast_downward_seconds": round(fd_total, 3),
            "ratio_total": round(fd_total / ours_total, 2),
            "ratio_per_call_median": round(per_call[len(per_call) // 2], 2),
            "ratio_per_call_min": round(per_call[0], 2), "equal_costs": True, "calls_detail": rows}


def labelling_states(model, n: int, seed: int = 0, spread: int = 10) -> list[int]:
    """n faithful-dataset states (myopic rollout, oracles.rollouts): every `spread`-th of the first n x spread,
    so the sample reaches past the fresh world into states where the machine water is used up."""
    from learning.gnn_dataset import faithful_states
    return faithful_states(model, n * spread, seed, progress=False)[::spread][:n]


def benchmark_labelling(model, states: list[int], heuristics=("pdb",), fd_time_limit: float = 600.0,
                        fast_downward: bool = True, progress: bool = True) -> dict:
    """Labelling states/s of our multi-goal search (per heuristic) against |T| Fast Downward calls per state."""
    from tqdm import tqdm

    from oracles.labelling import Labeller
    from . import fast_downward as fd

    out = {"domain": model.name, "layout": model.layout, "states": len(states), "tasks": len(model.tasks),
           "ours": {}, "machine": f"{platform.machine()} {platform.python_implementation()} {platform.python_version()}"}
    reference = None
    for name in heuristics:
        t0 = time.perf_counter()
        lab = Labeller(model, name)
        setup = time.perf_counter() - t0          # once per layout and process (pattern databases)
        rows, t0 = [], time.perf_counter()
        for s in tqdm(states, desc=f"labelling ({lab.heuristic})", disable=not progress):
            r = lab.label(s)
            rows.append({"c_ap": r.c_ap, "seconds": round(r.seconds, 3), "closed": r.closed,
                         "costs": [int(c) for c in r.costs]})
        total = time.perf_counter() - t0
        if reference is not None and [r["costs"] for r in rows] != reference:
            raise AssertionError(f"heuristic {name} gives other costs than {heuristics[0]}")
        reference = [r["costs"] for r in rows]
        out["ours"][lab.heuristic] = {"setup_seconds": round(setup, 2), "seconds": round(total, 2),
                                      "states_per_s": round(len(states) / total, 4),
                                      "max_state_seconds": max(r["seconds"] for r in rows), "per_state": rows}
    if fast_downward:
        t0, calls, fd_rows = time.perf_counter(), 0, []
        for i, s in enumerate(tqdm(states, desc="Fast Downward, |T| calls per state", disable=not progress)):
            costs, t_state = [], time.perf_counter()
            for j, task in enumerate(model.tasks):
                if task.satisfied(s):
                    costs.append(0)                  # already satisfied: no call needed, as in the stream
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
        out["fast_downward"] = {"seconds": round(total, 2), "calls": calls,
                                "states_per_s": round(len(states) / total, 4), "per_state": fd_rows}
        for name, r in out["ours"].items():
            r["ratio_vs_fast_downward"] = round(r["states_per_s"] / out["fast_downward"]["states_per_s"], 2)
        out["equal_costs"] = True
    return out


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0])
    p.add_argument("--planner", action="store_true",
                   help="benchmark our exact planner against Fast Downward instead of the simulators")
    p.add_argument("--calls", type=int, default=20, help="planner calls for --planner (default: %(default)s)")
    p.add_argument("--sequence", type=int, default=0, help="canonical sequence for --planner")
    p.add_argument("--labelling", action="store_true",
                   help="benchmark the labelling oracle against |T| Fast Downward calls per state")
    p.add_argument("--heuristic", default="pdb",
                   help="labelling heuristics to time, comma-separated: pdb, lmcut, lmcut-pc, hmax, blind "
                        "(default: %(default)s)")
    p.add_argument("--no-fast-downward", action="store_true", help="--labelling: time ours only")
    p.add_argument("--states", type=int, default=300, help="distinct reachable states (default: %(default)s)")
    p.add_argument("--batch", type=int, default=8192, help="batched-step batch size (default: %(default)s)")
    p.add_argument("--seconds", type=float, default=2.0, help="minimum timing per simulator")
    args = p.parse_args()
    model = compile_domain(args.domain, args.layout)
    if args.labelling:
        states = labelling_states(model, args.states, args.seed)
        r = benchmark_labelling(model, states, args.heuristic.split(","), fast_downward=not args.no_fast_downward)
        print(f"{r['domain']} {r['layout']}: {r['states']} states x {r['tasks']} tasks")
        for name, o in r["ours"].items():
            ratio = f", {o['ratio_vs_fast_downward']}x Fast Downward" if "ratio_vs_fast_downward" in o else ""
            print(f"  ours ({name:5s}) {o['seconds']:9.1f}s  {o['states_per_s']:8.4f} states/s"
                  f"  (slowest state {o['max_state_seconds']}s; set-up {o['setup_seconds']}s){ratio}")
        if "fast_downward" in r:
            f = r["fast_downward"]
            print(f"  Fast Downward {f['seconds']:9.1f}s  {f['states_per_s']:8.4f} states/s  ({f['calls']} calls; "
                  f"equal costs)")
        if args.out:
            write_json(args.out, r)
            print(f"wrote {args.out}")
        return
    if args.planner:
        r = benchmark_planner(model, args.sequence, args.calls)
        for c in r["calls_detail"]:
            print(f"  {c['task']:34s} cost {c['cost']:5d}  ours {c['ours_s']:8.3f}s "
                  f"({c['ours_expansions']} states)  Fast Downward {c['fast_downward_s']:8.3f}s "
                  f"({c['fast_downward_expansions']} expanded)")
        print(f"{r['calls']} calls, equal costs: ours {r['ours_seconds']}s, Fast Downward "
              f"{r['fast_downward_seconds']}s; ratio total {r['ratio_total']}, per call median "
              f"{r['ratio_per_call_median']} (min {r['ratio_per_call_min']})")
        if args.out:
            write_json(args.out, r)
        return
    r = benchmark(model, args.states, args.seed, args.batch, args.seconds)
    print(f"{r['domain']} {r['layout']}: {r['states']} states, {r['successors']} successors "
          f"(mean branching {r['mean_branching']})")
    print(f"  successors(state)      {r['successors_per_s']:>12,} successors/s")
    print(f"  batched step (N={r['batch_size']}) {r['batched_transitions_per_s']:>12,} transitions/s")
    print(f"  unified-planning       {r['reference_successors_per_s']:>12,.1f} successors/s")
    print(f"  ratio single  {r['ratio_single']:>8.1f}  (target >= 300)")
    print(f"  ratio batched {r['ratio_batched']:>8.1f}  (target >= 3000)")
    if args.out:
        write_json(args.out, r)
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)
