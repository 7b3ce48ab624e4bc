"""The agent protocol: what every agent implements for the sequence runner (`planning.world.runner`).

Two kinds, as in the thesis: a *planner* returns a whole plan for the current
task (the oracles, the GNN baseline, the value-guided search) and a *policy*
acts one primitive action at a time (the greedy RL agents).

Contract, per sequence: `start(model, sequence)` once, after the world has been
reset; then, for every task that does not already hold when drawn, either
`plan(state, task, upcoming)` (planners) or `act(state, task)` until the task
ends (policies). `upcoming` holds the tasks still to come in the sequence, in
order, after the current one; only the clairvoyant oracle looks at it.

A planner's `Reply.plan` is a list of ground action indices (None: no plan, the
task fails). The runner executes it within the task's action budget. Every key
of `Reply.info` is copied into the task's results row; the runner itself reads
`status` ("solved", or a failure such as "out-of-time", "unsolvable",
"crash"), which says why a plan is missing.

`name` and `config` identify a run: results files record both, and a finished
results file is extended only by a run with the same name and config. The
class hooks (`options`, `from_args`) and `run_name` are what the evaluation
command and the agent registry (`experiments.registry`) need to build an agent
from its command line and name its results file; `summary` and `set_log` are
what the runner and the command call on every agent, with defaults that add
nothing. A class's docstring's first line describes it in `--list-agents`.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class Reply:
    """A planner's answer for one task: the plan (None if it found none) and what to record."""

    plan: list | None
    info: dict = field(default_factory=dict)  # e.g. {"status": "solved", "expansions": 1234}


class Agent:
    """What planners and policies share: how they are built, named and configured, and their hooks."""

    name = "agent"
    """The agent's name in results files (`agent`); with `config`, what a saved run is compared on."""
    config: dict = {}
    """Every setting that changes the agent's results, JSON-serialisable (the results file's `config`);
    complete once the agent is built, so that a saved run can be compared before anything is played."""
    run_name = "agent"
    """The default results file's name before the layout (`planning.world.results.default_out`): the
    name and every setting that changes results (planner, heuristic, K, checkpoint)."""

    @classmethod
    def options(cls, p) -> None:
        """Declare the agent's command-line flags, with their defaults, on the argparse parser (or group)
        `p`: the only place they are written. Each flag's dest is an attribute `from_args` reads."""

    @classmethod
    def from_args(cls, args, model) -> "Agent":
        """The agent built for the compiled layout `model` from `args`: any object with one attribute per
        flag `options` declares (a parsed command line, or `experiments.registry.agent_options`). A bad
        value is a one-line `DomainError`, raised here, before anything is played."""
        raise NotImplementedError

    def start(self, model, sequence) -> None:
        """Called before each sequence (the world has just been reset); resets whatever the agent carries
        from one sequence to the next, so that a sequence's results do not depend on those played
        before it (`experiments.workers` plays them apart)."""

    def summary(self, rows: list) -> dict:
        """Keys of the agent's own the results file adds (e.g. the clairvoyant's K and share of optimal
        windows), from the per-task rows of every sequence in the file; none by default."""
        return {}

    def set_log(self, path) -> None:
        """Append a JSON-lines record of the agent's own (e.g. the clairvoyant's windows) to `path`, which
        the command puts beside the results file (OUT.windows.jsonl); called only when `keeps_log`."""

    def on_stream(self, stream: str) -> None:
        """The sequences come from a declared task stream (`planning.world.streams`), not the i.i.d. one: the
        results record it in `config` and their default name ends in -stream-<name>, so that runs on other
        streams are never taken for this one's. Called by the evaluation before anything is played."""
        self.config = {**self.config, "stream": stream}
        self.run_name = f"{self.run_name}-stream-{stream}"

    @property
    def keeps_log(self) -> bool:
        """Whether the agent writes a log (its class overrides `set_log`)."""
        return type(self).set_log is not Agent.set_log


class Planner(Agent):
    """Returns a plan per task."""

    def plan(self, state: int, task, upcoming: list) -> Reply:
        """The plan for `task` from `state`; `upcoming`: the sequence's later tasks, in order."""
        raise NotImplementedError


class Policy(Agent):
    """Acts step by step."""

    def act(self, state: int, task) -> int:
        """The next ground action for `task` in `state`."""
        raise NotImplementedError


class PlanFunction(Planner):
    """A planner from a function (state, task) -> Reply: for tools that play tasks without an agent class."""

    def __init__(self, fn, name: str = "function"):
        self.fn, self.name = fn, name

    def plan(self, state: int, task, upcoming: list) -> Reply:
        return self.fn(state, task)
