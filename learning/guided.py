"""The value-guided agents (thesis §4.2): a learned value as the terminal heuristic of the Bellman–Novelty search.

Per task: the myopic reference plan (our exact optimal planner by default, or
Fast Downward with a time limit) is seeded as the first terminal and sets
C_myo; the search (`planning.search.bellman_novelty`) then collects other ways
of completing the task; the terminal whose post-consumption state has the
highest V_AP among those costing at most β·C_myo is executed in full. With the
myopic checkpoint this is the thesis's Myopic RL (guided) row, with the
anticipatory one Anticipatory RL (guided).

The authors' reference planner was satisficing (LAMA); ours is optimal, so
C_myo is the true myopic cost and the bound β·C_myo is never looser than
theirs. β, the budget and the depth cap default to domain.toml [search] for
the layout; where it gives no β, β = 1.0 (a one-line warning on stderr, once):
only plans as cheap as the myopic one are eligible, so the agent plays exactly
the myopic plan.
"""
from __future__ import annotations

import sys
from dataclasses import asdict

from learning.greedy import checkpoint_config, checkpoint_run_name
from oracles.myopic import PLANNERS, MyopicOracle
from planning.errors import DomainError
from planning.search.bellman_novelty import bellman_novelty_search
from planning.world.agents import Planner, Reply


def search_defaults(model) -> dict:
    """domain.toml [search] for the model's layout: beta, budget, depth_cap (per-layout tables resolved)."""
    out = {}
    for key, value in model.config.get("search", {}).items():
        if isinstance(value, dict):
            if model.layout not in value:
                raise DomainError(model.files["config"], f"[search] {key} has no entry for layout '{model.layout}'")
            value = value[model.layout]
        out[key] = value
    return out


_warned: set = set()


def default_beta_warning(model) -> None:
    """One line on stderr, once per domain file and layout: no β in domain.toml [search], so β = 1.0."""
    key = (str(model.files["config"]), model.layout)
    if key in _warned:
        return
    _warned.add(key)
    print(f"warning: {model.files['config']}: no [search] beta for layout {model.layout}: beta = 1.0, so the "
          "value-guided search plays exactly the myopic plan (set [search] beta, or pass --beta)", file=sys.stderr)


class ValueGuidedPlanner(Planner):
    """A value checkpoint deployed through the cost-bounded Bellman–Novelty search."""

    name = "rl-guided"
    checkpoint_prefix = "rl-"         # dropped from the checkpoint's name in the default results name
    keys = ("c_myo", "terminals", "eligible", "expansions", "source", "v_ap", "cost", "depth")

    @classmethod
    def options(cls, p) -> None:
        p.add_argument("--checkpoint", required=True, help="Q-network checkpoint whose value guides the search")
        cls.search_options(p)

    @staticmethod
    def search_options(p) -> None:
        """The search's own flags, shared by every value-guided agent."""
        p.add_argument("--beta", type=float, default=None, help="cost slack β ≥ 1 (default: domain.toml [search])")
        p.add_argument("--budget", type=int, default=None, help="expansions per task (default: domain.toml [search])")
        p.add_argument("--depth-cap", type=int, default=None, help="depth of open nodes (default: domain.toml [search])")
        p.add_argument("--reference", default="internal", choices=PLANNERS,
                       help="planner of the myopic reference plan (default: %(default)s, exact)")
        p.add_argument("--time-limit", type=float, default=60.0,
                       help="reference planner seconds per task (default: %(default)s)")

    @classmethod
    def from_args(cls, args, model) -> "ValueGuidedPlanner":
        return cls(model, args.checkpoint, args.beta, args.budget, args.depth_cap, args.reference, args.time_limit)

    def __init__(self, model, checkpoint, beta=None, budget=None, depth_cap=None, reference="internal",
                 time_limit=60.0, value=None):
        """`value`: any value of the protocol instead of the checkpoint's (then `checkpoint` only names it)."""
        d = search_defaults(model)
        if beta is None and "beta" not in d:
            default_beta_warning(model)
        self.beta = float(beta if beta is not None else d.get("beta", 1.0))
        self.budget = int(budget if budget is not None else d.get("budget", 5000))
        self.depth_cap = int(depth_cap if depth_cap is not None else d.get("depth_cap", 20))
        if self.beta < 1:
            raise DomainError("--beta", f"must be at least 1 (the reference must stay eligible), not {self.beta}")
        if self.budget < 0 or self.depth_cap < 1:
            raise DomainError("--budget", f"budget {self.budget} and depth cap {self.depth_cap} must be positive")
        self.model, self.checkpoint, self.value = model, str(checkpoint), value
        self.reference = MyopicOracle(reference, time_limit)
        self.config = {**self.describe_value(self.checkpoint, value),
                       "beta": self.beta, "budget": self.budget, "depth_cap": self.depth_cap,
                       "reference": {**self.reference.config,
                                     "note": "exact optimal: C_myo is the true myopic cost (the authors' was LAMA)"
                                     if reference == "internal" else "Fast Downward blind A*, optimal within its time limit"}}
        name = checkpoint_run_name(self.name, self.checkpoint, self.checkpoint_prefix)
        if (self.beta, self.budget, self.depth_cap) != (d.get("beta"), d.get("budget"), d.get("depth_cap")):
            name += f"-beta{self.beta:g}-budget{self.budget}-depth{self.depth_cap}"
        self.run_name = name if reference == "internal" else f"{name}-{reference}"

    def describe_value(self, checkpoint: str, value) -> dict:
        """What the results config records of the value: the Q-network checkpoint's settings, or its name."""
        return checkpoint_config(checkpoint) if value is None else {"value": checkpoint}

    def start(self, model, sequence) -> None:
        if model is not self.model:
            raise DomainError(model.layout, f"this agent was built for {self.model.name} {self.model.layout}")
        if self.value is None:
            from learning.qnet import load_value_function

            self.value = load_value_function(self.checkpoint, model)
        self.reference.start(model, sequence)

    def plan(self, state: int, task, upcoming: list) -> Reply:
        ref = self.reference.plan(state, task, upcoming)
        r = bellman_novelty_search(self.model, state, task, self.value, budget=self.budget, beta=self.beta,
                                   depth_cap=self.depth_cap, reference_plan=ref.plan)
        stats = asdict(r.stats)
        info = {"status": "solved" if r.plan is not None else "no-eligible-terminal",
                "reference_status": ref.info.get("status"),
                **{k: stats[k] for k in self.keys}, "search_seconds": round(stats["seconds"], 4)}
        return Reply(r.plan, info)
