"""The greedy deployment of a learned Q (the thesis's Myopic / Anticipatory RL (greedy) rows): argmax_a Q(s, τ, a)."""

from __future__ import annotations

import re
from pathlib import Path

from planning.errors import DomainError
from planning.world.agents import Policy


def checkpoint_config(path) -> dict:
    """What a results file records of a Q-network checkpoint: its path, step, evaluation and training settings."""
    from learning.q.checkpoints import read_checkpoint

    payload = read_checkpoint(path)
    cfg = payload.get("config", {})
    return {
        "checkpoint": str(path),
        **{k: payload[k] for k in ("step", "eval") if k in payload},
        **{k: cfg[k] for k in ("horizon", "seed", "gamma", "goal_reward") if k in cfg},
    }


def checkpoint_run_name(agent: str, checkpoint, prefix: str = "rl-") -> str:
    """A default results name that names the checkpoint: rl-greedy + rl-anticipatory-two-room-seed0.pt ->
    rl-greedy-anticipatory-two-room-seed0 (the checkpoint's own `prefix` dropped, and the domain's name that
    `learning.export` puts before it for a domain other than the restaurant: blockworld-rl-myopic-grid7x7-seed0.pt
    -> rl-greedy-myopic-grid7x7-seed0, to which the results file's name adds the domain once)."""
    stem = Path(checkpoint).stem
    if stem.startswith(prefix):
        return f"{agent}-{stem.removeprefix(prefix)}"
    exported = re.fullmatch(rf"(.+?)-{re.escape(prefix)}(.+)", stem)
    return f"{agent}-{exported.group(2) if exported else stem}"


class GreedyValuePolicy(Policy):
    """Acts greedily on a trained Q-network checkpoint."""

    name = "rl-greedy"

    @classmethod
    def options(cls, p) -> None:
        p.add_argument("--checkpoint", required=True, help="Q-network checkpoint (learning.dqn's best.pt)")

    @classmethod
    def from_args(cls, args, model=None) -> "GreedyValuePolicy":
        agent = cls(args.checkpoint)
        if model is not None:  # a checkpoint of another layout fails before any task is played
            agent.start(model, None)
        return agent

    def __init__(self, checkpoint):
        if not checkpoint:
            raise DomainError("--checkpoint", "the rl-greedy agent needs --checkpoint PATH")
        self.checkpoint = str(checkpoint)
        # Read now: a bad checkpoint fails before any output, and the config is
        # complete before the runner compares it with a partial run's to resume.
        self.config = checkpoint_config(self.checkpoint)
        self.run_name = checkpoint_run_name(self.name, self.checkpoint)
        self._model = None

    def start(self, model, sequence) -> None:
        if model is not self._model:
            from learning.q.value import load_value_function

            self._model, self.value = model, load_value_function(self.checkpoint, model)

    def act(self, state: int, task) -> int:
        return int(self.value.greedy([state], task.index)[0])
