"""`python -m experiments.reproduce --domain DIR` on a domain other than the restaurant: the folder's layouts, the
tables that apply, what does not, every missing run's command naming the domain; into a tmp output, with the
committed docs/results.md untouched."""

import json
import shutil
import sys
from pathlib import Path

import pytest

from experiments import reproduce
from experiments.report import domain
from experiments.report.data import Context, load_rows
from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
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
        "train: `python -m learning.dqn --domain minimal --layout grid --horizon anticipatory --seed 0 && "
        "python -m learning.export runs/dqn/minimal-grid-anticipatory-seed0`"
    ) in text
    assert "| Myopic oracle (Fast Downward) | not run" in text


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
