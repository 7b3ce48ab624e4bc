"""Benchmark: our simulator against unified-planning's SequentialSimulator, in one run.

On one set of reachable states (seeded random walks from world resets) it times
(a) successors(state) of our simulator, (b) the batched numpy step expanding the
same states, tiled into one large batch, and (c) unified-planning's
SequentialSimulator enumerating applicable actions and applying each. All three
must produce the same successors (checked); the ratios are what matter, since
absolute times on a shared machine are noisy.

    python -m planning.external.simulator_bench --domain domains/restaurant --layout three-room --out FILE
"""

from __future__ import annotations

import platform
import time

import numpy as np

from planning import cli
from planning.atomic import write_json
from planning.domain.batched import BatchedModel
from planning.domain.compiler import compile_domain
from planning.parallel import results_provenance


def reachable_states(model, n: int, seed: int, walk: int = 64) -> list[int]:
    """Up to n distinct states from seeded random walks, each walk starting at a world reset."""
    rng = np.random.default_rng(seed)
    states, seen = [], set()
    for _ in range(max(100, 10 * n // walk)):  # small domains have fewer than n states
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


def benchmark(model, n_states: int = 300, seed: int = 0, batch: int = 8192, min_seconds: float = 2.0) -> dict:
    """Successors per second of the three simulators on the same states, and their ratios."""
    from unified_planning.shortcuts import SequentialSimulator

    from planning.external.up_bridge import UPStates, up_problem

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
        "domain": model.name,
        "layout": model.layout,
        "states": len(states),
        "successors": n_succ,
        "mean_branching": round(n_succ / len(states), 2),
        "batch_size": len(tiled),
        "successors_per_s": round(single),
        "batched_transitions_per_s": round(batched),
        "reference_successors_per_s": round(ref, 1),
        "ratio_single": round(single / ref, 1),
        "ratio_batched": round(batched / ref, 1),
        "machine": f"{platform.machine()} {platform.python_implementation()} {platform.python_version()}",
    }


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True)
    p.add_argument("--states", type=int, default=300, help="distinct reachable states (default: %(default)s)")
    p.add_argument("--batch", type=int, default=8192, help="batched-step batch size (default: %(default)s)")
    p.add_argument("--seconds", type=float, default=2.0, help="minimum timing per simulator")
    args = p.parse_args()
    model = compile_domain(args.domain, args.layout)
    r = benchmark(model, args.states, args.seed, args.batch, args.seconds)
    print(
        f"{r['domain']} {r['layout']}: {r['states']} states, {r['successors']} successors "
        f"(mean branching {r['mean_branching']})"
    )
    print(f"  successors(state)      {r['successors_per_s']:>12,} successors/s")
    print(f"  batched step (N={r['batch_size']}) {r['batched_transitions_per_s']:>12,} transitions/s")
    print(f"  unified-planning       {r['reference_successors_per_s']:>12,.1f} successors/s")
    print(f"  ratio single  {r['ratio_single']:>8.1f}  (target >= 300)")
    print(f"  ratio batched {r['ratio_batched']:>8.1f}  (target >= 3000)")
    if args.out:
        write_json(args.out, {**r, "provenance": results_provenance(vars(args))})
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)
