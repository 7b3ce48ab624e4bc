"""`python -m experiments.reproduce --domain DIR` on a domain other than the restaurant: the folder's layouts, the
tables that apply, what does not, every missing run's command naming the domain; into a tmp output, with the
committed docs/results.md untouched."""

import json
import shutil
import sys
from pathlib import Path

import pytest
import torch

from experiments import reproduce
from experiments.report import domain
from experiments.report.data import Context, load_rows
from experiments.report.specs import LEAST_SEEDS
from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.world.sequences import generate, sequence_dir

ROOT = Path(__file__).resolve().parents[2]


def run_reproduce(monkeypatch, *argv) -> int:
    monkeypatch.setattr(sys, "argv", ["reproduce", *argv])
    try:
        cli.run(reproduce.main)
    except SystemExit as e:
        return e.code
    return 0


@pytest.fixture
def minimal_copy(tmp_path, monkeypatch):
    """The minimal domain copied into an empty working folder (no results, no checkpoints, no sequences)."""
    shutil.copytree(ROOT / "domains" / "minimal", tmp_path / "minimal", ignore=shutil.ignore_patterns("sequences"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_report_only_on_the_minimal_domain(minimal_copy, monkeypatch, capsys):
    committed = (ROOT / "docs" / "results.md").read_bytes()
    assert run_reproduce(monkeypatch, "--domain", "minimal", "--report-only", "--out", "out/report.md") == 0
    text = (minimal_copy / "out" / "report.md").read_text()
    assert (ROOT / "docs" / "results.md").read_bytes() == committed
    assert not (minimal_copy / "out" / "figures").exists() and not (minimal_copy / "docs").exists()
    assert text.startswith("# Measured results: minimal\n")
    assert "- grid: 30 atoms, 86 ground actions, 3 task instances of 2 types (`grid.pddl`)" in text
    assert (
        "- grid: no canonical sequences in `minimal/sequences/grid`: `python -m planning.world.sequences "
        "--domain minimal --layout grid` writes them"
    ) in text
    for heading in (
        "## Methods (Table 5.2's columns)",
        "## The learned values, greedy and guided",
        "## Held-out seven against development three",
        "## Share of the clairvoyant saving",
        "## Statistics",
        "## Not applicable to this domain",
        "## Runs not yet made",
        "## Provenance",
    ):
        assert heading in text
    for thesis_only in ("## Table 5.3", "## Table A.5", "## Figures", "thesis cost/task", "Reward calibration"):
        assert thesis_only not in text
    assert (
        "`python -m experiments.evaluate --agent myopic-oracle --layout grid --domain minimal "
        "--out results/minimal-myopic-oracle-grid.json`"
    ) in text
    assert (
        "`for N in 0 4 8; do python -m learning.dqn --domain minimal --layout grid --horizon anticipatory --seed $N && "
        "python -m learning.export runs/dqn/minimal-grid-anticipatory-seed$N && "
    ) in text
    assert "| Myopic oracle (Fast Downward) | not run" in text
    # a learned value is expected with three seeds before any is trained
    assert "| Anticipatory RL (guided) | not run ([commands](#runs-not-yet-made)) | — | — | 0 of 3 | — |" in text
    assert "hand-kept notes (not generated)" not in text
    # the domain's hand-kept notes, where it has some, close its report verbatim
    (minimal_copy / "docs").mkdir()
    (minimal_copy / "docs" / "results-minimal-notes.md").write_text("**A note** (`results/x.json`): read by hand.\n")
    assert run_reproduce(monkeypatch, "--domain", "minimal", "--report-only", "--out", "out/report.md") == 0
    text = (minimal_copy / "out" / "report.md").read_text()
    assert "## Appendix: hand-kept notes (not generated)" in text
    assert "Included verbatim from `docs/results-minimal-notes.md`" in text
    assert "**A note** (`results/x.json`): read by hand.\n" in text.split("## Provenance")[1]


def test_a_played_row_is_reported(minimal_copy, monkeypatch):
    """With the canonical sequences written and our myopic oracle played on two of them, its row has its
    figures; the default output is docs/results-<domain>.md of the working folder."""
    model = compile_domain(str(minimal_copy / "minimal"), "grid")
    for rec in generate(model):
        write_json(sequence_dir(model) / f"seq-{rec['id']:02d}.json", rec)
    ctx = Context("minimal")
    row = next(r for r in domain.rows(ctx, "grid") if r.key == "myopic-oracle-internal")
    assert reproduce.run_missing([row], ctx, ids=[0, 1], progress=False) == [
        "results/minimal-myopic-oracle-internal-grid.json"
    ]
    data = json.loads(Path("results/minimal-myopic-oracle-internal-grid.json").read_text())
    assert load_rows([row], ctx)["myopic-oracle-internal"].figures()["sequences"] == [0, 1]
    assert run_reproduce(monkeypatch, "--domain", "minimal", "--report-only") == 0
    text = (minimal_copy / "docs" / "results-minimal.md").read_text()
    line = next(x for x in text.splitlines() if x.startswith("| Myopic oracle (ours) |"))
    assert line.startswith(f"| Myopic oracle (ours) | {data['cost_per_task']:,.1f}")
    assert "`minimal-myopic-oracle-internal-grid.json`" in line
    assert "no canonical sequences" not in text


def test_layouts_are_the_folders(minimal_copy, monkeypatch, capsys):
    assert run_reproduce(monkeypatch, "--domain", "minimal", "--layouts", "two-room", "--report-only") == 2
    assert capsys.readouterr().err.strip() == "error: --layouts: 'two-room' names no known layout (known: grid)"
    assert run_reproduce(monkeypatch, "--domain", "minimal", "--discount-sweep", "--report-only") == 2
    assert "trains the restaurant's Table A.5 runs" in capsys.readouterr().err


def test_rl_rows_follow_the_domains_task_encoding(minimal_copy):
    """A domain whose [training] names another task encoding than the thesis's reports the runs its commands
    make: their folders, checkpoints and results files end with the encoding's mark."""
    toml = minimal_copy / "minimal" / "domain.toml"
    toml.write_text(toml.read_text().replace("[training]\n", '[training]\ntask_features = "arguments+objects"\n', 1))
    ctx = Context("minimal")
    (row,) = [r for r in domain.rows(ctx, "grid") if r.key == "myopic-rl-greedy"]
    assert [run.seed for run in row.runs] == list(LEAST_SEEDS)  # expected before any is trained
    run = row.runs[0]
    assert run.out == "results/minimal-rl-greedy-myopic-grid-seed0-features-objects.json"
    assert run.checkpoint == "checkpoints/minimal-rl-myopic-grid-seed0-features-objects.pt"
    assert run.train.endswith("python -m learning.export runs/dqn/minimal-grid-myopic-seed0-features-objects")
    from learning.encoding import Encoding
    from learning.q.checkpoints import network_payload
    from learning.q.network import build_network

    (minimal_copy / "checkpoints").mkdir()
    for name, features in (
        ("minimal-rl-myopic-grid-seed4-features-objects", "arguments+objects"),
        ("minimal-rl-myopic-grid-seed8", "arguments"),
    ):
        enc = Encoding(ctx.model("grid"), features)
        torch.save(network_payload(build_network(enc, 8), enc), minimal_copy / "checkpoints" / f"{name}.pt")
    assert domain.rl_seeds("minimal", "grid", "myopic", "-features-objects") == [4]
    assert domain.rl_seeds("minimal", "grid", "myopic") == [8]


PUBLISHED = """
[[published]]
source = "A paper"
what = "planning ahead against planning each task alone"
reduction = 0.05
layout = "grid"
ours = [["clairvoyant-2", "myopic-oracle-internal"], ["anticipatory-rl-guided", "myopic-oracle"]]
protocol = "theirs: other grids"

[[published]]
source = "Another"
what = "preparing between tasks"
reduction = 0.11
layout = "grid"
ours = []
protocol = "no counterpart"
"""


def test_published_figures_are_set_beside_ours(minimal_copy, monkeypatch):
    """domain.toml [[published]]: each figure beside the reduction 1 − A/B of the rows it names, computed from
    their results files ("not run" where a row has none); a malformed entry is a one-line error naming the file."""
    toml = minimal_copy / "minimal" / "domain.toml"
    toml.write_text(toml.read_text() + PUBLISHED)
    model = compile_domain(str(minimal_copy / "minimal"), "grid")
    for rec in generate(model):
        write_json(sequence_dir(model) / f"seq-{rec['id']:02d}.json", rec)
    ctx = Context("minimal")
    rows = [r for r in domain.rows(ctx, "grid") if r.key in ("myopic-oracle-internal", "clairvoyant-2")]
    reproduce.run_missing(rows, ctx, ids=[0, 1], progress=False)
    costs = {
        k: json.loads(Path(f"results/minimal-{k}-grid.json").read_text())["cost_per_task"]
        for k in ("myopic-oracle-internal", "clairvoyant-2")
    }
    saving = 1 - costs["clairvoyant-2"] / costs["myopic-oracle-internal"]  # 0 here: nothing to prepare
    assert {r.key for r in domain.rows(ctx, "grid")} <= set(domain.ROW_KEYS)  # the keys [[published]] may name
    lines = domain.published(ctx, {"grid": load_rows(domain.rows(ctx, "grid"), ctx)})
    first = next(x for x in lines if x.startswith("| A paper |"))
    assert "| −5.0% | grid |" in first
    assert f"Clairvoyant oracle (K = 2) vs Myopic oracle (ours): {100 * saving:+.1f}%" in first
    assert "Anticipatory RL (guided) vs Myopic oracle (Fast Downward): not run" in first
    assert "| −11.0% | grid | no counterpart | no counterpart |" in next(x for x in lines if x.startswith("| Another"))

    toml.write_text(toml.read_text().replace('protocol = "no counterpart"\n', ""))
    with pytest.raises(DomainError, match=r"domain\.toml.*\[\[published\]\] entry 2 lacks protocol"):
        domain.published(ctx, {"grid": load_rows(domain.rows(ctx, "grid"), ctx)})
    toml.write_text(toml.read_text().replace('"myopic-oracle"]]', '"myopic"]]'))
    with pytest.raises(DomainError, match=r"entry 1: \['anticipatory-rl-guided', 'myopic'\] is not a pair of row keys"):
        domain.published(ctx, {"grid": load_rows(domain.rows(ctx, "grid"), ctx)})


def test_benchmarks_and_calibration_are_reported(minimal_copy):
    """The simulator and planner benchmarks and the reward calibration, read from their default files; the
    command of each one missing."""
    ctx = Context("minimal")
    write_json("results/minimal-bench-simulator-grid.json", {"ratio_single": 812.4, "ratio_batched": 4021.0})
    write_json("results/minimal-bench-planner-grid.json", {"ratio_total": 12.34, "calls": 20, "equal_costs": True})
    (line,) = [x for x in domain.tools(ctx, ["grid"]) if x.startswith("| grid |")]
    assert line.startswith("| grid | 812× / 4,021× | 12.3× over 20 calls, equal costs | not run | not run |")
    assert line.endswith(
        "| `python -m oracles.labelling_bench --domain minimal --layout grid --states 5 --out "
        "results/minimal-bench-labelling-grid.json`; `python -m experiments.calibrate --domain minimal --layout grid` |"
    )
    write_json(
        "results/minimal-bench-labelling-grid.json",
        {
            "states": 5,
            "tasks": 3,
            "equal_costs": True,
            "ours": {"pdb": {"seconds": 0.5}},
            "fast_downward": {"seconds": 14.0},
        },
    )
    (line,) = [x for x in domain.tools(ctx, ["grid"]) if x.startswith("| grid |")]
    assert "| 28.0× over 5 states × 3 tasks, equal costs | not run |" in line


def test_capacity_checks_are_reported_this_domains_first(minimal_copy):
    """Every capacity check under results/ is a row, this domain's before the other domains' (the reference);
    the command of the layout without its default file."""
    ctx = Context("minimal")
    assert domain.capacity(ctx, ["grid"]) == ["- not run: `python -m learning.capacity --domain minimal --layout grid`"]

    def check(domain_name, layout, held, success):
        return {
            "domain": domain_name,
            "layout": layout,
            "settings": {"states": 3000, "epochs": 150, "hidden": 256, "task_features": "arguments"},
            "fit": [{"epoch": 150, "train_best_optimal": 0.9, "held_out_best_optimal": held, "held_out_l1": 1.234}],
            "greedy": {"success_rate": success},
        }

    write_json("results/capacity-two-room.json", check("restaurant", "two-room", 0.875, 0.45))
    write_json("results/minimal-capacity-grid.json", check("minimal", "grid", 0.345, 0.03))
    lines = domain.capacity(ctx, ["grid"])
    rows = [x for x in lines if x.startswith("| minimal") or x.startswith("| restaurant")]
    assert rows == [
        "| minimal | grid | 3000 / 150 / 256 / arguments | 90.0 / 34.5 | 1.23 | 3 | `results/minimal-capacity-grid.json` |",
        "| restaurant | two-room | 3000 / 150 / 256 / arguments | 90.0 / 87.5 | 1.23 | 45 | `results/capacity-two-room.json` |",
    ]
    assert not any(x.startswith("- not run") for x in lines)


def test_an_exported_checkpoint_plays_into_the_file_the_report_reads(minimal_copy):
    """The checkpoints learning.export names for a domain other than the restaurant (its name first) give the
    agents' default results names the report's rows read, the domain's name once."""
    from learning.agents.greedy import checkpoint_run_name
    from planning.world.results import results_file

    ctx = Context("minimal")
    assert (
        checkpoint_run_name("rl-greedy", "checkpoints/minimal-rl-myopic-grid-seed0.pt") == "rl-greedy-myopic-grid-seed0"
    )
    assert (
        checkpoint_run_name("rl-greedy", "checkpoints/rl-myopic-two-room-seed0.pt") == "rl-greedy-myopic-two-room-seed0"
    )
    assert checkpoint_run_name("rl-greedy", "q.pt") == "rl-greedy-q"
    for agent in ("rl-greedy", "rl-guided"):
        run = next(
            r for row in domain.rows(ctx, "grid") for r in row.runs if r.agent == agent and "anticipatory" in r.out
        )
        name = checkpoint_run_name(agent, run.checkpoint)
        assert (
            results_file(name, "minimal", "grid") == run.out == f"results/minimal-{agent}-anticipatory-grid-seed0.json"
        )
    assert checkpoint_run_name("gnn-native", "checkpoints/my-domain-gnn-augmented-grid-seed4.pt", "gnn-") == (
        "gnn-native-augmented-grid-seed4"
    )


def test_training_runs_are_reported_with_their_learning_curves(minimal_copy):
    """Each exported Q-learning run of this domain is a row with its encoding, steps trained of those configured
    and every greedy check; a results file made with the checkpoint of an unfinished run is flagged."""
    from learning.encoding import Encoding
    from learning.q.checkpoints import network_payload
    from learning.q.network import build_network

    ctx = Context("minimal")
    assert domain.training(ctx, ["grid"]) == [
        "No Q-learning run of minimal exported yet (`python -m learning.export runs/dqn/<run>`)."
    ]
    ckpt = "checkpoints/minimal-rl-myopic-grid-seed0.pt"
    figures = {
        "run": "runs/dqn/minimal-grid-myopic-seed0",
        "checkpoint": ckpt,
        "domain": "minimal",
        "layout": "grid",
        "horizon": "myopic",
        "seed": 0,
        "steps": 50_000,
        "config": {"steps": 500_000},
        "at": {"50000": {"step": 50_000, "success_last_100": 0.15}},
        "greedy_checks": [{"step": 25_000, "success_rate": 0.04}, {"step": 50_000, "success_rate": 0.07}],
        "best_greedy": {"step": 50_000, "success_rate": 0.07},
        "train_hours": 1.234,
    }
    write_json("results/minimal-training-myopic-grid-seed0.json", figures)
    write_json(
        "results/training-myopic-two-room-seed0.json",
        {
            **figures,
            "domain": "restaurant",
            "layout": "two-room",
            "checkpoint": "checkpoints/rl-myopic-two-room-seed0.pt",
        },
    )
    write_json("results/minimal-training-gnn-faithful-grid-seed0.json", {"checkpoint": "g.pt", "domain": "minimal"})
    ctx = Context("minimal")  # a context reads the training files once
    rows = [x for x in domain.training(ctx, ["grid"]) if x.startswith("| `")]
    assert rows == [
        "| `minimal-training-myopic-grid-seed0.json` | grid | myopic | 0 | arguments | 50,000 of 500,000 (unfinished) "
        "| 25k 0.04, 50k 0.07 | 0.15 / — / — / — | 0.07 at 50,000 | 1.23 |"
    ]
    Path("checkpoints").mkdir()
    enc = Encoding(ctx.model("grid"))
    torch.save(network_payload(build_network(enc, 8), enc), ckpt)
    model = ctx.model("grid")
    for rec in generate(model):
        write_json(sequence_dir(model) / f"seq-{rec['id']:02d}.json", rec)
    (row,) = [r for r in domain.rows(ctx, "grid") if r.key == "myopic-rl-greedy"]
    reproduce.run_missing([row], ctx, ids=[0], progress=False)
    loaded, *others = load_rows([row], ctx)["myopic-rl-greedy"].loaded
    assert loaded.used and [x.status for x in others] == ["no checkpoint", "no checkpoint"]  # seeds 4 and 8
    assert "its checkpoint comes from an unfinished run (50,000 of 500,000 steps trained)" in loaded.flags
    write_json("results/minimal-training-myopic-grid-seed0.json", {**figures, "steps": 500_000})
    loaded = load_rows([row], Context("minimal"))["myopic-rl-greedy"].loaded[0]
    assert not any("unfinished" in f for f in loaded.flags), loaded.flags


def test_the_beta_selection_is_reported_with_every_candidate(minimal_copy):
    """Each β selection of this domain is a row: every candidate's development cost and success, the chosen one
    in bold; another domain's selection is left out."""
    ctx = Context("minimal")
    assert domain.beta_selection(ctx, ["grid"])[0].startswith("No β selection of minimal yet")
    sel = {
        "domain": "minimal",
        "layout": "grid",
        "checkpoint": "checkpoints/minimal-rl-anticipatory-grid-seed0.pt",
        "development": [1, 3, 6],
        "candidates": [
            {"beta": 1.25, "cost_per_task": 812.345, "success_rate": 1.0},
            {"beta": 3.0, "cost_per_task": 799.0, "success_rate": 0.98},
        ],
        "chosen_beta": 3.0,
    }
    write_json("results/beta-selection-minimal-rl-anticipatory-grid-seed0.json", sel)
    write_json("results/beta-selection-rl-anticipatory-two-room-seed0.json", {**sel, "domain": "restaurant"})
    rows = [x for x in domain.beta_selection(ctx, ["grid"]) if x.startswith("| grid")]
    assert rows == [
        "| grid | `minimal-rl-anticipatory-grid-seed0.pt` | β 1.25: 812.3 (100%); **β 3: 799.0 (98%)** | 3 "
        "| `results/beta-selection-minimal-rl-anticipatory-grid-seed0.json` |"
    ]


def test_a_domain_that_declares_streams_gets_their_section(minimal_copy, monkeypatch):
    """A domain folder with a Markov and a drifting stream (the grid's `alternate` and `shift`) is reported as
    the restaurant's streams are: a table per layout and stream whose runs and commands name the domain, our
    myopic oracle played on the Markov stream's sequences, and the command that writes the drifting stream's
    sequences where they are not written yet."""
    from experiments.report import streams
    from tests.conftest import declare_grid_streams

    declare_grid_streams(minimal_copy / "minimal")
    model = compile_domain(str(minimal_copy / "minimal"), "grid")
    for name in (None, "alternate"):
        for rec in generate(model, stream_name=name):
            write_json(sequence_dir(model, name) / f"seq-{rec['id']:02d}.json", rec)
    ctx = Context("minimal")
    rows = {r.key: r for r in streams.rows(streams.names(ctx, "grid"), "alternate", "markov")}
    assert list(rows) == [
        "myopic-oracle",
        "clairvoyant-2",
        "clairvoyant-3",
        "iid-agent",
        "dep-markov",
        "dep-markov-empirical",
        "est-markov",
        "est-markov-empirical",
    ]
    assert [run.seed for run in rows["iid-agent"].runs] == list(LEAST_SEEDS)  # none trained yet
    run = rows["est-markov"].runs[0]
    assert run.checkpoint == "checkpoints/minimal-rl-anticipatory-grid-seed0-stream-alternate-est-markov.pt"
    assert run.command == (
        "python -m experiments.evaluate --agent rl-guided --layout grid --domain minimal --checkpoint "
        f"{run.checkpoint} --estimator markov --stream alternate --out "
        "results/minimal-rl-guided-anticipatory-grid-seed0-stream-alternate-est-markov.json"
    )
    assert run.train == (
        "python -m learning.dqn --domain minimal --layout grid --horizon anticipatory --seed 0 --stream alternate "
        "--estimator markov && python -m learning.export "
        "runs/dqn/minimal-grid-anticipatory-seed0-stream-alternate-est-markov"
    )
    out = "results/minimal-myopic-oracle-internal-grid-stream-alternate.json"
    assert reproduce.run_missing([rows["myopic-oracle"]], ctx, ids=[0, 1], progress=False) == [out]
    data = json.loads(Path(out).read_text())
    assert data["config"]["stream"] == "alternate"

    assert run_reproduce(monkeypatch, "--domain", "minimal", "--report-only") == 0
    text = (minimal_copy / "docs" / "results-minimal.md").read_text()
    section = text.split("## Task streams: unknown, drifting and correlated\n")[1].split("## Not applicable")[0]
    blocks = dict(b.split("\n", 1) for b in section.split("### grid, stream ")[1:])
    assert list(blocks) == ["iid (iid)", "alternate (markov)", "shift (drift)"]
    line = next(x for x in blocks["alternate (markov)"].splitlines() if x.startswith("| Myopic oracle"))
    assert line.startswith(f"| Myopic oracle (optimal, internal A*) | {data['cost_per_task']:,.1f} | (reference)")
    assert "How far each estimate is from the stream's own next-task distribution" in blocks["alternate (markov)"]
    assert (
        "`python -m planning.world.sequences --domain minimal --layout grid --stream shift` writes them"
        in blocks["shift (drift)"]
    )
    missing = section.split("### Stream runs not yet made")[1]
    assert "--domain minimal --checkpoint checkpoints/minimal-rl-anticipatory-grid-seed$N-stream-shift" in missing
    assert "declares no stream" not in text
    assert f"`{Path(out).name}`" in text.split("## Provenance of the results files")[1]
