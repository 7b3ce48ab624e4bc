"""Uniformly random applicable actions: the floor every learned agent must beat."""

from __future__ import annotations

import numpy as np

from planning.world.agents import Policy


class RandomPolicy(Policy):
    """Picks one applicable ground action uniformly at random, seeded per sequence."""

    name = "random"

    @classmethod
    def options(cls, p) -> None:
        p.add_argument("--seed", type=int, default=0, help="seed of the random choices (default: %(default)s)")

    @classmethod
    def from_args(cls, args, model=None) -> "RandomPolicy":
        return cls(args.seed)

    def __init__(self, seed: int = 0):
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.config = {"seed": seed}
        self.run_name = f"random-seed{seed}"

    def start(self, model, sequence) -> None:
        """Reseed from (seed, sequence id): a sequence's choices do not depend on the ones played
        before it, so sequences played apart (experiments.workers) give the serial run's results."""
        self.model = model
        if sequence is not None:
            self.rng = np.random.default_rng((self.seed, sequence.id))

    def act(self, state: int, task) -> int:
        actions = self.model.applicable(state)
        return int(actions[self.rng.integers(len(actions))])
