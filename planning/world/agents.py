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
results file is extended only by a run with the same name and config.
"""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class Reply:
    """A planner's answer for one task: the plan (None if it found none) and what to record."""

    plan: list | None
    info: dict = field(default_factory=dict)     # e.g. {"status": "solved", "expansions": 1234}


class Agent:
    """What planners and policies share: a name, a configuration, a start hook."""

    name = "agent"
    config: dict = {}

    def start(self, model, sequence) -> None:
        """Called before each sequence (the world has just been reset)."""


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
