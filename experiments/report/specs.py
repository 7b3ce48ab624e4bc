"""What the reproduction report expects: the runs behind every table row, and the thesis's figure for it.

A `Row` is one line of a thesis table on one layout (Table 5.2, 5.3, A.4): its
runs, one per seed where the agent has seeds (each: the registered agent, its
options, the results file, the checkpoint it needs and the command that trains
that checkpoint), and the thesis's figures. This module is the one place that
names files and commands; `experiments.reproduce` runs what is missing and
reads what exists, `experiments.report.tables` renders them.

Seeds are the thesis's: 4 checkpoint seeds per learned agent on the two-room
restaurant and 5 on the three-room (Appendix A.2), GNN seeds 0, 4, 8 and 16
(Appendix A.1). The GNN rows name the agents `gnn-native` and `gnn-guided`
(SPEC.md) and models `checkpoints/gnn-<variant>-<layout>-seed<N>.pt`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

LAYOUTS = ("two-room", "three-room")
RL_SEEDS = {"two-room": (0, 4, 8, 16), "three-room": (0, 4, 8, 16, 42)}  # Appendix A.1
GNN_SEEDS = (0, 4, 8, 16)
LEAST_SEEDS = (0, 4, 8)
"""The seeds a learned row beyond the thesis's is expected with (a new domain's values, a stream estimator's):
three, the issues' least; more are reported where trained."""
HORIZONS = ("myopic", "anticipatory")
GAMMAS = (0.90, 0.95, 0.96, 0.97, 0.98, 0.99)


@dataclass(frozen=True)
class Run:
    """One evaluation: a registered agent with its options on one layout, and the file it writes."""

    agent: str
    layout: str
    options: tuple = ()
    out: str = ""
    seed: int | str | None = None  # "$N" in a row's template
    checkpoint: str | None = None
    train: str | None = None  # the command that makes `checkpoint`

    @property
    def argv(self) -> list[str]:
        """The evaluation command line's arguments (without --out)."""
        return ["--agent", self.agent, "--layout", self.layout, *self.options]

    @property
    def command(self) -> str:
        return " ".join(["python -m experiments.evaluate", *self.argv, "--out", self.out])


@dataclass(frozen=True)
class Row:
    """One table row on one layout: its runs (one per seed) and the thesis's figures."""

    key: str
    label: str
    layout: str
    runs: tuple
    thesis: dict = field(default_factory=dict)
    seeded: bool = False  # learned agents: mean ± std over seeds
    template: Run | None = None  # a seeded row's run with the seed "$N" (for shell loops)


# Thesis Table 5.2 (cost per task ± std over seeds, improvement over the myopic oracle, success)
# and Table A.4 (steps per task, success ± std) by row key; the clairvoyant K = 4 two-room row
# is not in the thesis.
THESIS = {
    "two-room": {
        "myopic-oracle": {"cost": 1340, "improvement": 0.0, "success": 1.0},
        "myopic-rl-greedy": {
            "cost": 1427,
            "cost_std": 26,
            "improvement": -0.065,
            "success": 0.976,
            "success_std": 0.010,
            "steps": 8.57,
            "steps_std": 0.54,
        },
        "myopic-rl-guided": {
            "cost": 1196,
            "cost_std": 108,
            "improvement": 0.108,
            "success": 1.0,
            "success_std": 0.0,
            "steps": 7.35,
            "steps_std": 0.17,
        },
        "gnn": {"cost": 1341, "cost_std": 12, "improvement": -0.001, "success": 1.0},
        "gnn-augmented": {"cost": 945, "cost_std": 4, "improvement": 0.295, "success": 1.0},
        "gnn-focused": {"cost": 1341, "cost_std": 12, "improvement": -0.001, "success": 1.0},
        "gnn-augmented-focused": {"cost": 945, "cost_std": 4, "improvement": 0.295, "success": 1.0},
        "anticipatory-rl-greedy": {
            "cost": 1432,
            "cost_std": 49,
            "improvement": -0.069,
            "success": 0.960,
            "success_std": 0.009,
            "steps": 9.43,
            "steps_std": 0.46,
        },
        "anticipatory-rl-guided": {
            "cost": 914,
            "cost_std": 19,
            "improvement": 0.318,
            "success": 1.0,
            "success_std": 0.0,
            "steps": 7.05,
            "steps_std": 0.06,
        },
        "clairvoyant-2": {"cost": 809, "improvement": 0.396, "success": 1.0},
        "clairvoyant-3": {"cost": 782, "improvement": 0.416, "success": 1.0},
        "clairvoyant-4": {},
    },
    "three-room": {
        "myopic-oracle": {"cost": 1349, "improvement": 0.0, "success": 1.0},
        "myopic-rl-greedy": {
            "cost": 2689,
            "cost_std": 316,
            "improvement": -0.993,
            "success": 0.638,
            "success_std": 0.088,
            "steps": 27.31,
            "steps_std": 4.98,
        },
        "myopic-rl-guided": {
            "cost": 1656,
            "cost_std": 131,
            "improvement": -0.228,
            "success": 1.0,
            "success_std": 0.0,
            "steps": 9.57,
            "steps_std": 1.14,
        },
        "gnn": {"cost": 1342, "cost_std": 6, "improvement": 0.005, "success": 1.0},
        "gnn-augmented": {"cost": 1308, "cost_std": 1, "improvement": 0.031, "success": 1.0},
        "gnn-focused": {"cost": 1342, "cost_std": 6, "improvement": 0.005, "success": 1.0},
        "gnn-augmented-focused": {"cost": 1308, "cost_std": 1, "improvement": 0.031, "success": 1.0},
        "gnn-augmented-bn": {"cost": 1187, "cost_std": 41, "improvement": 0.120},
        "anticipatory-rl-greedy": {
            "cost": 1638,
            "cost_std": 136,
            "improvement": -0.214,
            "success": 0.933,
            "success_std": 0.036,
            "steps": 11.24,
            "steps_std": 2.07,
        },
        "anticipatory-rl-guided": {
            "cost": 978,
            "cost_std": 127,
            "improvement": 0.275,
            "success": 1.0,
            "success_std": 0.0,
            "steps": 7.77,
            "steps_std": 0.38,
        },
        "clairvoyant-2": {"cost": 1229, "improvement": 0.089, "success": 1.0},
        "clairvoyant-3": {"cost": 967, "improvement": 0.283, "success": 1.0},
        "clairvoyant-4": {"cost": 943, "improvement": 0.301, "success": 1.0},
    },
}

# §5.4.3 and Appendix A.1: the held-out seven (sequences outside 01, 03, 06), three-room.
THESIS_HELD_OUT = {"three-room": {"anticipatory-rl-guided": 1038, "myopic-oracle": 1403}}

# §5.4.2 / §6.1: the share of the K = 3 clairvoyant saving the guided anticipatory agent recovers.
THESIS_SHARE_STATED = {
    ("two-room", "anticipatory-rl-guided", 3): 0.76,
    ("three-room", "anticipatory-rl-guided", 3): 0.97,
}

# §5.4.3 and Appendix A.1: the statistics of Anticipatory RL (guided) against another row, three-room.
THESIS_STATS = {
    ("three-room", "anticipatory-rl-guided", "gnn-augmented"): {
        "all": {
            "wilcoxon_p": 0.002,
            "a_cheaper": 10,
            "n": 10,
            "reduction": 0.252,
            "t": 5.78,
            "df": 4,
            "welch_p": 0.004,
            "ci": (0.131, 0.373),
        },
        "held-out": {"wilcoxon_p": 0.0156, "a_cheaper": 7, "n": 7, "reduction": 0.228},
    },
    ("three-room", "anticipatory-rl-guided", "clairvoyant-2"): {
        "all": {"reduction": 0.204},
        "held-out": {"reduction": 0.174},
    },
}

# Table 5.3: the value–search ablation on the three-room restaurant (row keys of the rows it reuses).
ABLATION = (
    ("gnn-augmented-focused", "GNN value, native selection (focused candidates, the authors' generator)"),
    ("gnn-augmented", "GNN value, native selection (clause-library candidates)"),
    ("gnn-augmented-bn", "GNN value, BN search"),
    ("anticipatory-rl-guided", "Anticipatory value, BN search"),
)

# Table A.5 (three-room anticipatory, seed 0): γ → jar share of water deliveries, training success, mean Q.
THESIS_DISCOUNT = {
    0.90: (0.046, 0.783, 36.9),
    0.95: (0.213, 0.842, 88.7),
    0.96: (0.145, 0.826, 105.5),
    0.97: (0.329, 0.815, 132.2),
    0.98: (0.652, 0.750, 195.5),
    0.99: (0.730, 0.661, 401.0),
}

# Figure 5.1b: the thesis's minimal example (Q of the task-1 placements; the anticipatory ones from
# V_A ≈ 3.5, V_B ≈ 8.6 as 9 + 0.99 V).
THESIS_MINIMAL = {
    "myopic": {"q_A": 9.0, "q_B": 9.0, "gap": -0.01, "share_B": 0.47},
    "anticipatory": {"q_A": 9 + 0.99 * 3.5, "q_B": 9 + 0.99 * 8.6, "gap": 5.0, "share_B": 0.99},
}


def rl_checkpoint(horizon: str, layout: str, seed: int) -> str:
    return f"checkpoints/rl-{horizon}-{layout}-seed{seed}.pt"


def rl_run_dir(horizon: str, layout: str, seed: int, gamma: float | None = None) -> str:
    """learning.dqn's default run folder (with a -gamma suffix for the discount sweep)."""
    tail = f"-gamma{gamma:g}" if gamma is not None else ""
    return f"runs/dqn/restaurant-{layout}-{horizon}-seed{seed}{tail}"


def rl_train(horizon: str, layout: str, seed: int) -> str:
    run = rl_run_dir(horizon, layout, seed)
    return (
        f"python -m learning.dqn --layout {layout} --horizon {horizon} --seed {seed} && python -m learning.export {run}"
    )


def results_name(domain: str, run_name: str, layout: str) -> str:
    """`planning.world.results.default_out`'s name for a run of this domain."""
    from planning.world.results import results_file

    return results_file(run_name, domain, layout)


def rl_suffix(model) -> str:
    """What the names of a domain's RL runs end with: the mark of its task encoding where domain.toml [training]
    names another than the thesis's (`learning.q.training.bound_suffix`), else ''."""
    from learning.encoding import domain_task_features
    from learning.q.training import bound_suffix

    return bound_suffix({"task_features": domain_task_features(model)})


def rl_seeds(domain: str, layout: str, horizon: str, suffix: str = "") -> list[int]:
    """The seeds of `checkpoints/<prefix>rl-<horizon>-<layout>-seed<N><suffix>.pt` trained on this domain (the
    prefix is `planning.world.results.file_prefix`'s; the domain is the PDDL name the checkpoint records, and one
    that records none is counted)."""
    from learning.q.checkpoints import read_checkpoint
    from planning.errors import DomainError
    from planning.world.results import file_prefix

    name = f"{file_prefix(domain)}rl-{horizon}-{layout}-seed"
    seeds = []
    for path in Path("checkpoints").glob(f"{name}*{suffix}.pt"):
        m = re.fullmatch(rf"{re.escape(name)}(\d+){re.escape(suffix)}", path.stem)
        if not m:
            continue
        try:
            recorded = read_checkpoint(path).get("domain")
        except DomainError:
            continue
        if recorded in (None, domain):
            seeds.append(int(m.group(1)))
    return sorted(seeds)


def gnn_model(variant: str, layout: str, seed: int) -> str:
    return f"checkpoints/gnn-{variant}-{layout}-seed{seed}.pt"


def gnn_train(variant: str, layout: str, seed: int) -> str:
    data = f"runs/gnn/{layout}-{variant}"
    flag = " --augmented" if variant == "augmented" else ""
    epochs = 12 if variant == "augmented" else 40
    return (
        f"python -m learning.gnn_dataset --layout {layout}{flag} --n-states 2000 --out {data} && "
        f"python -m learning.gnn_train --data {data} --seed {seed} --epochs {epochs} --out {data}-seed{seed} && "
        f"python -m learning.export {data}-seed{seed}"
    )


def _rl_run(agent: str, horizon: str, layout: str, s) -> Run:
    return Run(
        agent,
        layout,
        ("--checkpoint", rl_checkpoint(horizon, layout, s)),
        f"results/{agent}-{horizon}-{layout}-seed{s}.json",
        s,
        rl_checkpoint(horizon, layout, s),
        rl_train(horizon, layout, s),
    )


def _rl_run_abandon(agent: str, horizon: str, layout: str, s) -> Run:
    """A greedy run under the thesis's failure protocol (abandon: executed cost only), for Table A.4."""
    return Run(
        agent,
        layout,
        ("--checkpoint", rl_checkpoint(horizon, layout, s), "--failure-protocol", "abandon"),
        f"results/{agent}-{horizon}-{layout}-seed{s}-abandon.json",
        s,
        rl_checkpoint(horizon, layout, s),
        rl_train(horizon, layout, s),
    )


JOINT_HEURISTIC = {"three-room": "pdb"}
"""gnn-native's `--joint-heuristic` per layout where it is not the default (pdb+lmcut): the three-room runs plan
their augmented candidates with the pattern databases alone, which gives the same costs in a fraction of the
time there (the two-room runs were made with the default, before the option)."""


def _gnn_run(agent: str, variant: str, layout: str, s) -> Run:
    joint = JOINT_HEURISTIC.get(layout) if agent == "gnn-native" else None
    return Run(
        agent,
        layout,
        ("--model", gnn_model(variant, layout, s), *(() if joint is None else ("--joint-heuristic", joint))),
        f"results/{agent}-{variant}-{layout}-seed{s}.json",
        s,
        gnn_model(variant, layout, s),
        gnn_train(variant, layout, s),
    )


def _gnn_library_run(agent: str, variant: str, layout: str, s) -> Run:
    """gnn-native over the dataset's clause library (`--generator clause-library`): the runs made before
    the focused candidate generator of domain.toml [gnn.candidates]."""
    return Run(
        agent,
        layout,
        ("--model", gnn_model(variant, layout, s), "--generator", "clause-library"),
        f"results/{agent}-{variant}-{layout}-seed{s}-clause-library.json",
        s,
        gnn_model(variant, layout, s),
        gnn_train(variant, layout, s),
    )


def _seeded(key: str, label: str, layout: str, make, seeds, *args) -> Row:
    """A learned row: one run per seed, and its template with the seed "$N"."""
    return Row(
        key,
        label,
        layout,
        tuple(make(*args, layout, s) for s in seeds),
        THESIS[layout][key],
        True,
        make(*args, layout, "$N"),
    )


def rows(layout: str) -> list[Row]:
    """Table 5.2's rows on a layout, in the thesis's order, then Table 5.3's extra row (three-room)."""
    t = THESIS[layout]
    out = [
        Row(
            "myopic-oracle",
            "Myopic oracle",
            layout,
            (Run("myopic-oracle", layout, (), f"results/myopic-oracle-{layout}.json"),),
            t["myopic-oracle"],
        )
    ]
    rl, gnn = RL_SEEDS[layout], GNN_SEEDS
    out += [
        _seeded("myopic-rl-greedy", "Myopic RL (greedy)", layout, _rl_run, rl, "rl-greedy", "myopic"),
        _seeded("myopic-rl-guided", "Myopic RL (guided)", layout, _rl_run, rl, "rl-guided", "myopic"),
        _seeded(
            "gnn", "One-task GNN (clause-library candidates)", layout, _gnn_library_run, gnn, "gnn-native", "faithful"
        ),
        _seeded(
            "gnn-augmented",
            "One-task GNN (augmented, clause-library candidates)",
            layout,
            _gnn_library_run,
            gnn,
            "gnn-native",
            "augmented",
        ),
        _seeded("gnn-focused", "One-task GNN (focused candidates)", layout, _gnn_run, gnn, "gnn-native", "faithful"),
        _seeded(
            "gnn-augmented-focused",
            "One-task GNN (augmented, focused candidates)",
            layout,
            _gnn_run,
            gnn,
            "gnn-native",
            "augmented",
        ),
        _seeded("anticipatory-rl-greedy", "Anticipatory RL (greedy)", layout, _rl_run, rl, "rl-greedy", "anticipatory"),
        _seeded("anticipatory-rl-guided", "Anticipatory RL (guided)", layout, _rl_run, rl, "rl-guided", "anticipatory"),
    ]
    for horizon in HORIZONS:  # Table A.4 beside the thesis: its protocol, failed tasks abandoned
        key = f"{horizon}-rl-greedy"
        out.append(
            Row(
                f"{key}-abandon",
                f"{horizon.capitalize()} RL (greedy, thesis protocol)",
                layout,
                tuple(_rl_run_abandon("rl-greedy", horizon, layout, s) for s in rl),
                t[key],
                True,
                _rl_run_abandon("rl-greedy", horizon, layout, "$N"),
            )
        )
    for K in CLAIRVOYANT_K:
        out.append(
            Row(
                f"clairvoyant-{K}",
                f"Clairvoyant oracle (K = {K})",
                layout,
                (clairvoyant_run(K, layout),),
                t[f"clairvoyant-{K}"],
            )
        )
    if layout == "three-room":
        out.append(
            _seeded("gnn-augmented-bn", "GNN value, BN search", layout, _gnn_run, gnn, "gnn-guided", "augmented")
        )
    return out


CLAIRVOYANT_K = (2, 3, 4)
CLAIRVOYANT_HEURISTIC = {4: "pdb,pdb-grown"}
"""The joint search's heuristic per K where it is not the default pdb: at K = 4 the windows pdb leaves unproven
within the time limit are searched again with the grown patterns (oracles.clairvoyant's escalation)."""


def clairvoyant_run(K: int, layout: str) -> Run:
    """The clairvoyant oracle's run at window K on a layout, as the report reads it (its file named by the
    oracle's own rule; imported here, so that these tables stay a light import)."""
    from oracles import clairvoyant
    from planning.world.results import results_file

    heuristic = CLAIRVOYANT_HEURISTIC.get(K)
    options = ("--K", str(K), "--time-limit", "60", *(("--heuristic", heuristic) if heuristic else ()))
    return Run(
        "clairvoyant", layout, options, results_file(clairvoyant.run_name(K, heuristic or "pdb"), "restaurant", layout)
    )


TABLE_5_2 = (
    "myopic-oracle",
    "myopic-rl-greedy",
    "myopic-rl-guided",
    "gnn",
    "gnn-augmented",
    "gnn-focused",
    "gnn-augmented-focused",
    "anticipatory-rl-greedy",
    "anticipatory-rl-guided",
    "clairvoyant-2",
    "clairvoyant-3",
    "clairvoyant-4",
)
LEARNED = ("myopic-rl-greedy", "anticipatory-rl-greedy", "myopic-rl-guided", "anticipatory-rl-guided")
THESIS_PROTOCOL = ("myopic-rl-greedy-abandon", "anticipatory-rl-greedy-abandon")
"""Table A.4's greedy rows replayed under the thesis's own failure protocol (abandon), beside ours."""
AGENTS = (
    "myopic-rl-greedy",
    "myopic-rl-guided",
    "gnn",
    "gnn-augmented",
    "gnn-focused",
    "gnn-augmented-focused",
    "anticipatory-rl-greedy",
    "anticipatory-rl-guided",
)
COMPARISONS = (
    ("anticipatory-rl-guided", "gnn-augmented"),
    ("anticipatory-rl-guided", "gnn-augmented-focused"),
    ("anticipatory-rl-guided", "myopic-rl-guided"),
    ("anticipatory-rl-guided", "myopic-oracle"),
    ("anticipatory-rl-guided", "clairvoyant-2"),
)
"""The pairs the statistics section tests (A against B); the first is the thesis's."""


def training_logs(layout: str, horizon: str) -> list[tuple[int, str]]:
    """(seed, log) of the finished training runs behind a learned row (Figure A.1): those exported
    (`learning.export` wrote results/training-<horizon>-<layout>-seed<N>.json), not runs still in progress.
    The log is that results file where it keeps the run's curve, else the run's metrics.jsonl (runs exported
    before curves were kept; runs/ is not committed)."""
    from planning.atomic import read_json

    out = []
    for s in RL_SEEDS[layout]:
        figures = Path(f"results/training-{horizon}-{layout}-seed{s}.json")
        if figures.is_file():
            data = read_json(figures, "training results file")
            out.append(
                (
                    s,
                    str(figures)
                    if isinstance(data, dict) and "curve" in data
                    else f"{rl_run_dir(horizon, layout, s)}/metrics.jsonl",
                )
            )
    return out


@dataclass(frozen=True)
class DiscountRun:
    """One run of Table A.5's sweep: three-room anticipatory at discount `gamma`, one seed, trained with the
    seeds batched (`learning.q.seeds`), exported, evaluated greedily (`experiments.sweep --deploy`) and guided."""

    gamma: float
    seed: int

    @property
    def name(self) -> str:
        return f"anticipatory-three-room-seed{self.seed}-gamma{self.gamma:g}"

    @property
    def log(self) -> str:
        return f"runs/dqn/restaurant-{self.name}/metrics.jsonl"

    @property
    def training(self) -> str:
        return f"results/training-{self.name}.json"

    @property
    def checkpoint(self) -> str:
        return f"checkpoints/rl-{self.name}.pt"

    @property
    def greedy(self) -> str:
        return f"results/rl-greedy-{self.name}.json"

    @property
    def guided(self) -> str:
        return f"results/rl-guided-{self.name}.json"

    @property
    def evaluate(self) -> str:
        """The guided evaluation (the layout's β, budget and depth cap, as Table 5.2's)."""
        return (
            f"python -m experiments.evaluate --agent rl-guided --layout three-room --checkpoint {self.checkpoint} "
            f"--out {self.guided}"
        )


SWEEP_SEEDS = (0, 4)
"""Table A.5's seeds per discount (the thesis's table is seed 0 alone)."""

DISCOUNT_TRAIN = (
    "python -m experiments.sweep --layout three-room --horizon anticipatory "
    f"--seed {','.join(map(str, SWEEP_SEEDS))} --gamma {','.join(f'{g:g}' for g in GAMMAS)} "
    "--seeds-together --runs runs/dqn --deploy"
)
"""Trains, exports and greedily evaluates every run of the sweep (each discount's seeds in one process;
a rerun resumes every run from its last.pt and skips the finished ones)."""


def discount_runs() -> list[DiscountRun]:
    """Table A.5's runs: every discount of GAMMAS (0.97, the thesis's, retrained alike) × SWEEP_SEEDS."""
    return [DiscountRun(g, s) for g in GAMMAS for s in SWEEP_SEEDS]
