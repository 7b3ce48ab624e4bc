"""The myopic oracle (thesis §5.2.2 item 1): each task solved alone, cost-optimally, blind to the next.

The thesis's oracle is Fast Downward's A* with the blind heuristic; `--planner
internal` uses our exact in-process A* (pattern databases on the compiled model) instead.
Both return optimal plans, so a task's cost is the same from the same state;
where several plans are optimal the two may leave different worlds behind, and
the sequences then drift apart (the closing table reports both).

    python -m oracles.myopic --layout two-room [--planner internal] [--sequences 0-9]
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterator

from oracles.command import RunOptions, figures, play, run_options, what_ran
from planning import cli
from planning.domain.batched import BatchedModel
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.external import fast_downward as fd
from planning.search.optimal import optimal_plan
from planning.world.agents import PlanFunction, Planner, Reply
from planning.world.runner import play_task
from planning.world.task_stream import PersistentWorld, TaskStream

PLANNERS = ("fast-downward", "internal")


class MyopicOracle(Planner):
    """Plans the current task optimally with Fast Downward (blind A*) or our A*."""

    name = "myopic-oracle"

    @classmethod
    def options(cls, p) -> None:
        p.add_argument(
            "--planner",
            default="fast-downward",
            choices=PLANNERS,
            help="Fast Downward's blind A* (the thesis's) or our exact A* (default: %(default)s)",
        )
        p.add_argument(
            "--time-limit", type=float, default=600.0, help="planner seconds per task (default: %(default)s)"
        )

    @classmethod
    def from_args(cls, args, model=None) -> "MyopicOracle":
        return cls(args.planner, args.time_limit)

    def __init__(self, planner: str = "fast-downward", time_limit: float = 600.0):
        if planner not in PLANNERS:
            raise DomainError("--planner", f"unknown planner '{planner}' (known: {', '.join(PLANNERS)})")
        if not time_limit > 0:
            raise DomainError("--time-limit", f"must be positive, not {time_limit}")
        self.planner, self.time_limit = planner, time_limit
        self.run_name = "myopic-oracle" if planner == "fast-downward" else f"myopic-oracle-{planner}"
        self.config = {
            "planner": planner,
            "time_limit": time_limit,
            "search": fd.OPTIMAL_CONFIG if planner == "fast-downward" else "astar(pdb) by f-levels",
        }
        self._model = None

    def start(self, model, sequence) -> None:
        if model is not self._model:
            self._model, self._bm = model, BatchedModel(model)

    def plan(self, state: int, task, upcoming: list) -> Reply:
        if self.planner == "fast-downward":
            r = fd.solve(self._model, state, task, self.time_limit)
            info = {"status": r.status.value, "planner_cost": r.cost, "expansions": r.expansions}
            if r.status != fd.Status.SOLVED and r.message:
                info["message"] = r.message  # why: Fast Downward's status and the tail of its log
            return Reply(r.plan if r.status == fd.Status.SOLVED else None, info)
        r = optimal_plan(self._bm, state, task, time_limit=self.time_limit)
        status = "solved" if r.plan is not None else ("unsolvable" if r.complete else "out-of-time")
        return Reply(r.plan, {"status": status, "planner_cost": r.cost, "expansions": r.expansions})


@dataclass
class TaskRecord:
    """One task of a persistent rollout: the world before it, what was executed, how it ended."""

    index: int
    task: str
    reset_seed: int | None  # the world was re-sampled with this seed just before the task
    states: list  # world states: before the first action, then after each action
    plan: list  # ground actions executed (empty if already satisfied)
    cost: int
    success: bool
    auto: bool  # already satisfied when drawn (zero cost, no action)
    after: int  # the world left behind (consumption applied on success)
    info: dict = field(default_factory=dict)


def rollout(
    model, planner: Planner, seed: int, n_tasks: int, done: list | None = None, lookahead: int = 0
) -> Iterator[TaskRecord]:
    """A persistent rollout of a planner on a seeded task stream (TaskStream: world reset every 50 tasks).

    Yields one TaskRecord per task. `done` (records of an earlier, interrupted run
    with the same seed) are replayed without planning, so a caller can resume.
    `lookahead`: how many of the stream's next tasks the planner is shown (a
    clairvoyant oracle's window), never past the next world reset.
    """
    stream = TaskStream(model, seed)
    world = PersistentWorld(model)
    done = list(done or [])
    drawn = [stream.next() for _ in range(n_tasks + lookahead)]
    for i in range(n_tasks):
        task, reset = drawn[i]
        upcoming = []
        for later, later_reset in drawn[i + 1 : i + 1 + lookahead]:
            if later_reset is not None:
                break
            upcoming.append(later)
        if reset is not None:
            world.reset(reset)
        before = world.state
        if i < len(done) and done[i].task != task.name:
            raise ValueError(f"resumed record {i} is {done[i].task}, but seed {seed} draws {task.name}")
        agent = planner if i >= len(done) else PlanFunction(lambda s, t, r=done[i]: Reply(r.plan or None, r.info))
        info = play_task(world, agent, task, upcoming)
        plan = info.pop("executed", [])
        states = [before]
        for a in plan or []:
            states.append(model.apply(states[-1], a))
        o = world.outcomes[-1]
        yield TaskRecord(i, task.name, reset, states, list(plan or []), o.cost, o.success, o.auto, world.state, info)


def type_table(result: dict) -> str:
    """Cost per task, actions per task, success rate and seconds, by task type and overall."""
    rows = result["per_task"]
    groups: dict[str, list] = {}
    for r in rows:
        groups.setdefault(r["task"].split("(")[0], []).append(r)
    lines = [f"{'task type':14s} {'tasks':>6s} {'cost/task':>10s} {'actions/task':>13s} {'success':>8s} {'s/task':>8s}"]
    for name, rs in sorted(groups.items()) + [("all", rows)]:
        n = len(rs)
        lines.append(
            f"{name:14s} {n:6d} {sum(r['cost'] for r in rs) / n:10.1f} "
            f"{sum(r['actions'] for r in rs) / n:13.2f} {sum(r['success'] for r in rs) / n:8.3f} "
            f"{sum(r['seconds'] for r in rs) / n:8.3f}"
        )
    return "\n".join(lines)


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], sequences=True, progress=True)
    MyopicOracle.options(p)
    run_options(p)
    args = p.parse_args()
    ids = cli.parse_ids(args.sequences)
    model = compile_domain(args.domain, args.layout)
    r, out = play(model, MyopicOracle.from_args(args, model), ids, RunOptions.from_args(args))
    print(
        f"\nmyopic oracle ({args.planner}), {model.name} {model.layout}, sequences {cli.format_ids(ids)}: "
        f"{r.asked['tasks']} tasks; {figures(r)}"
    )
    print(type_table(r.asked))
    print(what_ran(r))


if __name__ == "__main__":
    cli.run(main)
