"""The main job: one canonical sequence played by the myopic oracle and by the value-guided agent, side by side.

The myopic oracle solves each task optimally alone (our exact A* with pattern
databases); the anticipatory guided agent (thesis §4.2) completes each task in
the way its learned preparedness value V_AP ranks best among those costing at
most β times the myopic cost. Both start from the same world and see the same
tasks; each task row shows both costs, and where the guided agent chose a
terminal of its own search instead of the myopic plan, the plan it executed,
so the investments it makes (a jar filled and parked, a cup left ready) can be
read off directly.

    python -m experiments.demo --layout three-room --sequence 0 --value q-network:checkpoints/rl-anticipatory-three-room-seed0.pt [--tasks 50]

`--value KIND:PATH` is any value of the registry (`learning.values`; a bare
PATH is a Q-network checkpoint), e.g. `--value exact` on the minimal domain.

Each agent plays with a progress bar. `make run` (the three-room, 50 tasks) takes
about 20 s on one free core: 8 s to build the pattern databases of the exact
planner (the myopic oracle's, and the guided agent's reference planner's), under
a second of myopic planning, and 5 s for the guided agent's 36 searches of 20,000
expansions (the compiled Bellman–Novelty search, planning/search/_bn.c); the rest
is loading.
"""

from __future__ import annotations

import time

from tqdm import tqdm

from learning.agents.guided import ValueGuidedPlanner
from learning.values import HELP
from oracles.myopic import MyopicOracle
from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.world.runner import play_sequence
from planning.world.sequences import Sequence, load


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], sequence=True)
    p.add_argument("--tasks", type=int, default=50, help="its first N tasks (default: all 50)")
    p.add_argument(
        "--value", default=None, help=f"{HELP} (default: q-network:checkpoints/rl-anticipatory-<layout>-seed0.pt)"
    )
    p.add_argument(
        "--budget", type=int, default=None, help="search expansions per task (default: domain.toml [search])"
    )
    args = p.parse_args()
    if args.tasks < 1:
        raise DomainError("--tasks", f"must be at least 1, not {args.tasks}")
    model = compile_domain(args.domain, args.layout)
    value = args.value or f"q-network:checkpoints/rl-anticipatory-{model.layout}-seed0.pt"
    seq = load(model, [args.sequence])[0]
    seq = Sequence(seq.id, seq.reset_seed, seq.tasks[: args.tasks])
    guided = ValueGuidedPlanner(model, value, budget=args.budget)
    print(
        f"{model.name} {model.layout}, sequence {seq.id} ({len(seq.tasks)} tasks); value {value}, "
        f"β = {guided.beta:g}, budget {guided.budget} expansions\n"
    )
    _build_planner_tables(model)
    t0 = time.perf_counter()
    with tqdm(total=len(seq.tasks), desc="myopic oracle", unit="task") as bar:
        myopic = play_sequence(model, MyopicOracle("internal"), seq, bar)
    t_myopic = time.perf_counter() - t0
    t0 = time.perf_counter()
    with tqdm(total=len(seq.tasks), desc="anticipatory guided", unit="task") as bar:
        ours = play_sequence(model, guided, seq, bar)
    t_guided = time.perf_counter() - t0
    t_search = sum(r.get("search_seconds", 0.0) for r in ours)
    print(f"{'':3s} {'task':30s} {'myopic':>7s} {'guided':>7s}")
    for m, g in zip(myopic, ours):
        note = ""
        if g.get("source") == "search":
            note = "  chose: " + ", ".join(g.get("plan", []))
        print(f"{g['index']:3d} {g['task']:30s} {m['cost']:7d} {g['cost']:7d}{note}")
    n = len(seq.tasks)
    c_m, c_g = sum(r["cost"] for r in myopic) / n, sum(r["cost"] for r in ours) / n
    print(
        f"\ncost per task: myopic oracle {c_m:.1f} ({t_myopic:.0f} s), anticipatory guided {c_g:.1f} "
        f"({t_guided:.0f} s, of which {t_search:.0f} s searching; success {sum(r['success'] for r in ours)}/{n}); "
        f"saving {(c_m - c_g) / c_m:+.1%}"
    )
    if args.out:
        write_json(
            args.out,
            {
                "domain": model.name,
                "layout": model.layout,
                "sequence": seq.id,
                "value": value,
                "config": guided.config,
                "myopic_cost_per_task": c_m,
                "guided_cost_per_task": c_g,
                "myopic": myopic,
                "guided": ours,
            },
        )


def _build_planner_tables(model) -> None:
    """Build the exact planner's pattern databases up front, saying so (the first task would wait on them)."""
    from planning.domain.batched import BatchedModel
    from planning.heuristics.pdb import pattern_databases
    from planning.search.optimal import default_heuristic

    if default_heuristic(model) != "pdb":
        return
    t0 = time.perf_counter()
    print("building the exact planner's pattern databases ...", end=" ", flush=True)
    pattern_databases(model, BatchedModel(model).n_words)
    print(f"{time.perf_counter() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    cli.run(main)
