"""The value-guided agents (thesis §4.2): a learned value as the terminal heuristic of the Bellman–Novelty search.

Per task: the reference plan (of any registered planner, `--reference`; by
default the myopic oracle with our exact optimal planner) is seeded as the
first terminal and sets C_myo; the search (`planning.search.bellman_novelty`)
then collects other ways of completing the task; the terminal whose
post-consumption state has the highest V_AP among those costing at most β·C_myo
is executed in full. With the myopic checkpoint this is the thesis's Myopic RL
(guided) row, with the anticipatory one Anticipatory RL (guided); `GNNGuidedPlanner` is the
same agent with the GNN's value (gnn-guided).

The value is any of the value registry (`--value KIND:PATH`, `learning.values`;
`--checkpoint PATH` is short for `--value q-network:PATH`). The authors'
reference planner was satisficing (LAMA); ours is optimal, so C_myo is the true
myopic cost and the bound β·C_myo is never looser than theirs. β, the budget
and the depth cap default to domain.toml [search] for the layout; where it
gives no β, β = 1.0 (a one-line warning on stderr, once): only plans as cheap
as the myopic one are eligible, so the agent plays exactly the myopic plan.

On a declared task stream (`experiments.evaluate --stream NAME`) the terminal score can weigh the next
task by a distribution estimator instead of the layout's P (`--estimator`, `planning.world.estimators`):
before each search the estimator sees the tasks posed so far (those that held when drawn too) and the
value's V_AP becomes Σ_τ' P(τ' | the task) max_a
Q(s, τ', a). Each sequence starts a fresh estimate (from the prior), so sequences stay independent of
the order they are played in. The default, known, is the thesis's agent unchanged.

A reference planner other than the default myopic oracle (`--reference-agent
"NAME [OPTIONS]"`) is built by the agent registry (`experiments.registry.build`,
which knows every agent; learning/ may not import it) and handed to `from_args`;
its options default to the agent's `reference_defaults`.
"""

from __future__ import annotations

import sys
from dataclasses import asdict
from pathlib import Path

from learning.agents.greedy import checkpoint_run_name
from learning.values import HELP, load_value, parse, record
from oracles.myopic import PLANNERS, MyopicOracle
from planning.errors import DomainError
from planning.search.bellman_novelty import bellman_novelty_search
from planning.world.agents import Planner, Reply
from planning.world.estimators import ESTIMATORS
from planning.world.estimators import build as build_estimator
from planning.world.streams import stream as stream_of


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
    print(
        f"warning: {model.files['config']}: no [search] beta for layout {model.layout}: beta = 1.0, so the "
        "value-guided search plays exactly the myopic plan (set [search] beta, or pass --beta)",
        file=sys.stderr,
    )


class ValueGuidedPlanner(Planner):
    """A learned value deployed through the cost-bounded Bellman–Novelty search."""

    name = "rl-guided"
    value_kind = "q-network"  # the kind of a bare checkpoint path (--checkpoint PATH)
    checkpoint_prefix = "rl-"  # dropped from the checkpoint's name in the default results name
    keys = ("c_myo", "terminals", "eligible", "expansions", "source", "v_ap", "cost", "depth")

    @classmethod
    def options(cls, p) -> None:
        which = p.add_mutually_exclusive_group(required=True)
        which.add_argument(
            "--checkpoint", help="Q-network checkpoint whose value guides the search (short for --value q-network:PATH)"
        )
        which.add_argument("--value", help=HELP)
        cls.search_options(p)
        p.add_argument(
            "--estimator",
            default="known",
            choices=list(ESTIMATORS),
            help="the next task's distribution in V_AP (planning.world.estimators; default: %(default)s, the "
            "layout's P)",
        )
        p.add_argument("--estimator-prior", type=float, default=1.0, help="empirical estimators' pseudo-counts")
        p.add_argument("--estimator-forget", type=float, default=1.0, help="empirical estimators' decay per task")
        p.add_argument(
            "--device",
            default=None,
            help="evaluate the Q-network value in torch on this device (cuda[:N], or cpu for torch's kernels; "
            "default: the compiled CPU engine; learning.device)",
        )

    @classmethod
    def search_options(cls, p) -> None:
        """The search's own flags, shared by every value-guided agent."""
        p.add_argument("--beta", type=float, default=None, help="cost slack β ≥ 1 (default: domain.toml [search])")
        p.add_argument("--budget", type=int, default=None, help="expansions per task (default: domain.toml [search])")
        p.add_argument(
            "--depth-cap", type=int, default=None, help="depth of open nodes (default: domain.toml [search])"
        )
        p.add_argument(
            "--reference",
            default="internal",
            choices=PLANNERS,
            help="planner of the myopic reference plan (default: %(default)s, exact)",
        )
        p.add_argument(
            "--time-limit", type=float, default=60.0, help="reference planner seconds per task (default: %(default)s)"
        )
        p.add_argument(
            "--reference-agent",
            default=REFERENCE_AGENT,
            help="the registered planner that gives the reference plan, with its own options as one "
            "argument, e.g. 'clairvoyant --K 2'; its --planner and --time-limit default to "
            "--reference and --time-limit (default: %(default)s)",
        )

    @classmethod
    def reference_defaults(cls, args) -> dict:
        """The reference planner's options, unless its --reference-agent gives them: the myopic oracle's
        planner and every reference's time limit."""
        return {"planner": args.reference, "time_limit": args.time_limit}

    @classmethod
    def from_args(cls, args, model, reference_planner=None) -> "ValueGuidedPlanner":
        """`reference_planner`: the planner `args.reference_agent` names, built by the agent registry
        (`experiments.registry.build`); None for the default one, built here."""
        return cls(
            model,
            args.value or args.checkpoint,
            args.beta,
            args.budget,
            args.depth_cap,
            args.reference,
            args.time_limit,
            default_reference(args, reference_planner),
            getattr(args, "estimator", "known"),
            getattr(args, "estimator_prior", 1.0),
            getattr(args, "estimator_forget", 1.0),
            getattr(args, "device", None),
        )

    def __init__(
        self,
        model,
        value,
        beta=None,
        budget=None,
        depth_cap=None,
        reference="internal",
        time_limit=60.0,
        reference_planner=None,
        estimator="known",
        estimator_prior=1.0,
        estimator_forget=1.0,
        device=None,
    ):
        """`value`: KIND:PATH, KIND, or a checkpoint PATH of `value_kind` (`learning.values`).
        `reference_planner`: the planner of the reference plan (default: the myopic oracle with the
        `reference` planner and `time_limit`). `estimator`: the next task's distribution in V_AP
        (`planning.world.estimators`; known: the layout's P). `device`: where the value is evaluated
        (`ValueFunction.to_device`; None: its compiled CPU engine); recorded, and the default results name
        ends -device-<device>, since values computed elsewhere may break a near-tie the other way."""
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
        self.model, self.value_name = model, str(value)
        self.reference = reference_planner if reference_planner is not None else MyopicOracle(reference, time_limit)
        self.value = load_value(self.value_name, model, self.value_kind)
        if device is not None:
            if not callable(getattr(self.value, "to_device", None)):
                raise DomainError("--device", f"the value {self.value_name} is evaluated on the CPU only")
            self.value.to_device(device)
        self.config = {
            **record(self.value_name, self.value_kind),
            "beta": self.beta,
            "budget": self.budget,
            "depth_cap": self.depth_cap,
            "reference": reference_record(self.reference),
        }
        name = self.value_run_name()
        if (self.beta, self.budget, self.depth_cap) != (d.get("beta"), d.get("budget"), d.get("depth_cap")):
            name += f"-beta{self.beta:g}-budget{self.budget}-depth{self.depth_cap}"
        self.run_name = name + reference_suffix(self.reference)
        if device is not None:
            self.config["device"] = str(self.value.device)
            self.run_name += f"-device-{self.value.device.type}"
        self.estimator_spec, self.estimator = None, None
        if estimator not in (None, "known"):
            if not callable(getattr(self.value, "set_distribution", None)):
                raise DomainError("--estimator", f"the value {self.value_name} takes no task distribution")
            if estimator != "markov":  # a bad name, prior or forgetting factor stops here
                build_estimator(estimator, model, None, estimator_prior, estimator_forget)
            self.estimator_spec = (estimator, float(estimator_prior), float(estimator_forget))
            self.config["estimator"] = {"name": estimator, "prior": estimator_prior, "forget": estimator_forget}
            self.run_name += f"-est-{estimator}" + ("" if estimator_forget == 1.0 else f"-forget{estimator_forget:g}")

    def value_run_name(self) -> str:
        """The default results name's start: a checkpoint of the agent's own kind named by its file
        (less `checkpoint_prefix`), any other value by its kind, then its file name or argument."""
        kind, arg = parse(self.value_name, self.value_kind)
        if kind == self.value_kind and arg is not None:
            return checkpoint_run_name(self.name, arg, self.checkpoint_prefix)
        return f"{self.name}-{kind}" + ("" if arg is None else f"-{Path(arg).stem}")

    def start(self, model, sequence) -> None:
        if model is not self.model:
            raise DomainError(model.layout, f"this agent was built for {self.model.name} {self.model.layout}")
        self.reference.start(model, sequence)
        if self.estimator_spec is not None:  # a fresh estimate per sequence, on the sequence's stream
            name, prior, forget = self.estimator_spec
            self.estimator = build_estimator(name, model, stream_of(model, sequence.stream), prior, forget)
            self.posed, self.seen = list(sequence.tasks), 0

    def plan(self, state: int, task, upcoming: list) -> Reply:
        if self.estimator is not None:  # every task posed so far, those that held when drawn too, then this one
            now = len(self.posed) - len(upcoming)
            for seen in self.posed[self.seen : now]:
                self.estimator.observe(seen)
            self.seen = now
            self.value.set_distribution(self.estimator.probabilities(task))
        ref = self.reference.plan(state, task, upcoming)
        r = bellman_novelty_search(
            self.model,
            state,
            task,
            self.value,
            budget=self.budget,
            beta=self.beta,
            depth_cap=self.depth_cap,
            reference_plan=ref.plan,
        )
        stats = asdict(r.stats)
        info = {
            "status": "solved" if r.plan is not None else "no-eligible-terminal",
            "reference_status": ref.info.get("status"),
            **{k: stats[k] for k in self.keys},
            "search_seconds": round(stats["seconds"], 4),
        }
        return Reply(r.plan, info)


REFERENCE_AGENT = "myopic-oracle"
"""The default --reference-agent: the myopic oracle, with --reference's planner and --time-limit."""

NOTES = {
    "internal": "exact optimal: C_myo is the true myopic cost (the authors' was LAMA)",
    "fast-downward": "Fast Downward blind A*, optimal within its time limit",
}


def default_reference(args, reference_planner):
    """The reference planner handed to `from_args`; None (the myopic oracle of `args`, built in
    __init__) only where `args.reference_agent` names the default one."""
    if reference_planner is None and args.reference_agent != REFERENCE_AGENT:
        raise DomainError(
            "--reference-agent",
            f"'{args.reference_agent}' is built by the agent registry (experiments.registry.build), not here",
        )
    return reference_planner


def reference_record(reference) -> dict:
    """What the results config records of the reference planner: the myopic oracle's config and what its
    planner guarantees, any other planner's name and config."""
    if isinstance(reference, MyopicOracle):
        return {**reference.config, "note": NOTES[reference.planner]}
    return {"agent": reference.name, **reference.config}


def reference_suffix(reference) -> str:
    """What the reference adds to the default results name: nothing for the exact myopic oracle, the
    oracle's planner for another, any other planner's run name."""
    if isinstance(reference, MyopicOracle):
        return "" if reference.planner == "internal" else f"-{reference.planner}"
    return f"-{reference.run_name}"


class GNNGuidedPlanner(ValueGuidedPlanner):
    """The GNN's C_AP estimate (`learning.gnn.value.GNNValue`) as the value of the cost-bounded Bellman–Novelty
    search (thesis Table 5.3, "GNN value, BN search"): the rl-guided agent with `--model PATH`, short for
    `--value gnn:PATH`; the same search, reference plan, β, budget and depth cap."""

    name = "gnn-guided"
    value_kind = "gnn"
    checkpoint_prefix = "gnn-"

    @classmethod
    def options(cls, p) -> None:
        which = p.add_mutually_exclusive_group(required=True)
        which.add_argument("--model", help="GNN checkpoint (learning.gnn_train's best.pt; short for --value gnn:PATH)")
        which.add_argument("--value", help=HELP)
        cls.search_options(p)

    @classmethod
    def from_args(cls, args, model, reference_planner=None) -> "GNNGuidedPlanner":
        return cls(
            model,
            args.value or args.model,
            args.beta,
            args.budget,
            args.depth_cap,
            args.reference,
            args.time_limit,
            default_reference(args, reference_planner),
        )
