"""The agent registry: every agent the evaluation command can play, as a lazy (module, class) row.

An agent class implements the protocol of `planning.world.agents` and three
hooks the command line uses: `options(parser)` declares its flags with their
defaults (the only place they are written), `from_args(args, model)` builds it
for the compiled layout, and
its `run_name` names the default results file (every setting that changes
results: planner, heuristic, K, checkpoint). A new agent is one module and one
row here.
"""
from __future__ import annotations

import importlib

from planning.errors import DomainError

AGENTS = {
    "myopic-oracle": ("oracles.myopic", "MyopicOracle"),
    "clairvoyant": ("oracles.clairvoyant", "ClairvoyantOracle"),
    "random": ("experiments.random_policy", "RandomPolicy"),
    "rl-greedy": ("learning.greedy", "GreedyValuePolicy"),
    "rl-guided": ("learning.guided", "ValueGuidedPlanner"),
    "gnn-native": ("learning.gnn_native", "GNNNativePlanner"),
    "gnn-guided": ("learning.gnn_value", "GNNGuidedPlanner"),
}


def agent_class(name: str):
    """The class registered under `name` (imported on first use)."""
    if name not in AGENTS:
        raise DomainError("--agent", f"unknown agent '{name}' (known: {', '.join(AGENTS)})")
    module, cls = AGENTS[name]
    return getattr(importlib.import_module(module), cls)


def describe() -> str:
    """One line per registered agent: its name and the first line of its docstring."""
    return "\n".join(f"{name:16s} {(agent_class(name).__doc__ or '').strip().splitlines()[0]}" for name in AGENTS)
