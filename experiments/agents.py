"""The agent protocol: what every agent implements, and the table the command line looks agents up in.

Two kinds, as in the thesis: a *planner* returns a whole plan for the current
task (the oracles, the GNN baseline, the value-guided search) and a *policy*
acts one primitive action at a time (the greedy RL agents). Both may look at
the tasks still to come in the sequence, which only the clairvoyant oracle does.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Reply:
    """A planner's answer for one task: the plan (None if it found none) and what to record."""

    plan: list | None
    info: dict = field(default_factory=dict)     # e.g. {"status": "solved", "expansions": 1234}


class Planner:
    """Returns a plan per task."""

    name = "planner"
    config: dict = {}

    def start(self, model, sequence) -> None:
        """Called before each sequence (the world has just been reset)."""

    def plan(self, state: int, task, upcoming: list) -> Reply:
        raise NotImplementedError


class Policy:
    """Acts step by step."""

    name = "policy"
    config: dict = {}

    def start(self, model, sequence) -> None:
        """Called before each sequence."""

    def act(self, state: int, task) -> int:
        raise NotImplementedError


class RandomPolicy(Policy):
    """Uniformly random applicable actions: the floor every learned agent must beat."""

    name = "random"

    def __init__(self, seed: int = 0):
        self.rng = np.random.default_rng(seed)
        self.config = {"seed": seed}

    def start(self, model, sequence) -> None:
        self.model = model

    def act(self, state: int, task) -> int:
        actions = self.model.applicable(state)
        return int(actions[self.rng.integers(len(actions))])


class GreedyValuePolicy(Policy):
    """The greedy deployment of a learned Q (thesis's Myopic / Anticipatory RL (greedy) rows): argmax_a Q(s, τ, a)."""

    name = "rl-greedy"

    def __init__(self, checkpoint):
        from learning.qnet import read_checkpoint
        from planning.errors import DomainError

        if not checkpoint:
            raise DomainError("--checkpoint", "the rl-greedy agent needs --checkpoint PATH")
        self.checkpoint = str(checkpoint)
        # Read now: a bad checkpoint fails before any output, and the config is
        # complete before the runner compares it with a partial run's to resume.
        payload = read_checkpoint(self.checkpoint)
        cfg = payload.get("config", {})
        self.config = {"checkpoint": self.checkpoint,
                       **{k: payload[k] for k in ("step", "eval") if k in payload},
                       **{k: cfg[k] for k in ("horizon", "seed", "gamma", "goal_reward") if k in cfg}}
        self._model = None

    def start(self, model, sequence) -> None:
        if model is not self._model:
            from learning.qnet import load_value_function

            self._model, self.value = model, load_value_function(self.checkpoint, model)

    def act(self, state: int, task) -> int:
        return int(self.value.greedy([state], task.index)[0])


def make_agent(name: str, args) -> Planner | Policy:
    """The agent registered under a name, built from command-line arguments."""
    from oracles.clairvoyant import ClairvoyantOracle
    from oracles.myopic import MyopicOracle

    table = {
        "myopic-oracle": lambda: MyopicOracle(getattr(args, "planner", "fast-downward"),
                                              getattr(args, "time_limit", 600.0)),
        "clairvoyant": lambda: ClairvoyantOracle(getattr(args, "K", 3), getattr(args, "time_limit", 600.0)),
        "random": lambda: RandomPolicy(getattr(args, "seed", 0)),
        "rl-greedy": lambda: GreedyValuePolicy(getattr(args, "checkpoint", None)),
    }
    if name not in table:
        from planning.errors import DomainError
        raise DomainError("--agent", f"unknown agent '{name}' (known: {', '.join(table)})")
    return table[name]()


AGENTS = ("myopic-oracle", "clairvoyant", "random", "rl-greedy")
