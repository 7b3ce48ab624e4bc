"""Training and export never lose or mix work: one resume path for learning.dqn and the
sweeps, one trainer per run folder, an export that replaces only its own run's files and checks everything first,
output names that stay in their folders, and checkpoints that name the domain they were trained on."""

import json
import os
import shutil
import subprocess
import sys
from argparse import Namespace
from pathlib import Path

import pytest

from learning.q.checkpoints import read_checkpoint, save_checkpoint
from learning.q.training import read_metrics
from learning.q.value import load_value_function
from planning import cli
from planning.atomic import sha256
from planning.domain.identity import identity

ROOT = Path(__file__).resolve().parents[2]
MINIMAL = str(ROOT / "domains" / "minimal")
COMMITTED = ROOT / "checkpoints" / "rl-myopic-two-room-seed0.pt"
COMMITTED_FIGURES = ROOT / "results" / "training-myopic-two-room-seed0.json"
# a few hundred steps of the grid, no demonstrations: seconds
SMALL = {
    "steps": 300,
    "demo_tasks": 0,
    "learning_starts": 50,
    "log_every": 100,
    "eval_every": 10**9,
    "eval_tasks": 4,
    "checkpoint_every": 10**9,
    "hidden": 32,
    "batch_size": 16,
}


def argv(settings: dict) -> list[str]:
    return [a for k, v in settings.items() for a in (f"--{k.replace('_', '-')}", str(v))]


def command(main, args: list, capsys) -> tuple[int, str]:
    """(exit status, stderr) of `main` run as its command would be (cli.run, sys.argv)."""
    before, sys.argv = sys.argv, ["prog", *map(str, args)]
    code = 0
    try:
        cli.run(main)
    except SystemExit as e:
        code = e.code
    finally:
        sys.argv = before
    return code, capsys.readouterr().err


def logged_steps(run: Path) -> list[int]:
    return [r["step"] for r in read_metrics(run / "metrics.jsonl")[0] if "eval" not in r]


def dqn_main():
    from learning.dqn import main

    return main


def export_main():
    from learning.export import main

    return main


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A finished 300-step grid run (best.pt, last.pt, metrics.jsonl)."""
    out = tmp_path_factory.mktemp("trained") / "run"
    before, sys.argv = (
        sys.argv,
        ["prog", "--domain", MINIMAL, "--horizon", "myopic", "--no-progress", "--out", str(out), *argv(SMALL)],
    )
    try:
        dqn_main()()
    finally:
        sys.argv = before
    return out


def copy_run(run: Path, where: Path) -> Path:
    shutil.copytree(run, where)
    return where


class HeldLock:
    """Another process holding a folder's OutputLock, as a trainer still running holds its run folder's."""

    def __init__(self, folder: Path):
        code = (
            "import sys; from planning.atomic import OutputLock\n"
            "with OutputLock(sys.argv[1], 'training run'):\n"
            "    print('held', flush=True); sys.stdin.read()\n"
        )
        self.p = subprocess.Popen(
            [sys.executable, "-c", code, str(folder)],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert self.p.stdout.readline().strip() == "held"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.p.stdin.close()
        self.p.wait(timeout=30)


# ---- 1. one resume path: stale metrics rows ---------------------------------------------------------
def stale_start(folder: Path) -> None:
    """What a run killed after its first two metrics rows, before its first last.pt, leaves."""
    folder.mkdir(parents=True)
    (folder / "metrics.jsonl").write_text("".join(json.dumps({"step": s, "tasks": 1}) + "\n" for s in (100, 200)))


def test_a_run_without_a_checkpoint_starts_over_through_learning_dqn(tmp_path, capsys):
    stale_start(tmp_path / "run")
    code, err = command(
        dqn_main(),
        ["--domain", MINIMAL, "--horizon", "myopic", "--no-progress", "--out", tmp_path / "run", *argv(SMALL)],
        capsys,
    )
    assert code == 0, err
    assert logged_steps(tmp_path / "run") == [100, 200, 300]
    assert "no last.pt to resume from" in err


def test_a_run_without_a_checkpoint_starts_over_through_a_sweep(tmp_path):
    """The sweep's item resumes as learning.dqn does: not 100, 200, 100, 200, 300."""
    from experiments.sweep import train_item

    stale_start(tmp_path / "run")
    item = {
        "domain": MINIMAL,
        "layout": "grid",
        "horizon": "myopic",
        "seed": 0,
        "settings": dict(SMALL),
        "out": str(tmp_path / "run"),
    }
    r = train_item(item)
    assert logged_steps(tmp_path / "run") == [100, 200, 300] and r["steps"] == 300
    # resumed from its last.pt: the rows past the checkpoint are dropped, the others kept once
    with open(tmp_path / "run" / "metrics.jsonl", "a") as f:
        f.write(json.dumps({"step": 400, "tasks": 9}) + "\n")
    train_item({**item, "settings": {**SMALL, "steps": 400}})
    assert logged_steps(tmp_path / "run") == [100, 200, 300, 400]
    assert all(r.get("tasks") != 9 for r in read_metrics(tmp_path / "run" / "metrics.jsonl")[0])


class Killed(Exception):
    """Stands for the kill of a trainer."""


def train_killed(item: dict, at: int, monkeypatch) -> None:
    """Run a sweep's item until step `at`, where the trainer dies (raising from its environment step)."""
    from experiments.sweep import train_item
    from learning.q.training import Trainer

    step = Trainer.env_step

    def dies(self, eps):
        if self.step == at:
            raise Killed
        return step(self, eps)

    with monkeypatch.context() as m:
        m.setattr(Trainer, "env_step", dies)
        with pytest.raises(Killed):
            train_item(item)


def metrics_rows(run: Path) -> list[dict]:
    """The metrics rows less their timings (steps and updates per second differ run to run)."""
    return [{k: v for k, v in r.items() if not k.endswith("_per_s")} for r in read_metrics(run / "metrics.jsonl")[0]]


@pytest.mark.parametrize("every, at", [(10**9, 250), (200, 350)], ids=["before-last.pt", "after-last.pt"])
def test_a_sweep_run_killed_and_rerun_logs_each_step_once_as_the_uninterrupted_run(tmp_path, monkeypatch, every, at):
    """Killed at step 250 before any last.pt (rows 100 and 200 written), or at 350 after the last.pt of step 200
    (row 300 written): rerun as the sweep does, its metrics file holds each step once, in order, with the rows of
    the run that was never interrupted (not 100, 200, 100, 200, 300, 400)."""
    from experiments.sweep import train_item

    # the target network synced at the checkpoints: the target values a trainer caches (learning.q.targets) are then
    # recomputed after a resume in the batches the uninterrupted run computes them in, so the rows agree exactly
    settings = {**SMALL, "steps": 400, "checkpoint_every": every, "target_every": 100}
    item = lambda out: {
        "domain": MINIMAL,
        "layout": "grid",
        "horizon": "myopic",
        "seed": 0,
        "settings": settings,
        "out": str(tmp_path / out),
    }
    whole = train_item(item("whole"))
    train_killed(item("killed"), at, monkeypatch)
    assert logged_steps(tmp_path / "killed") == [100, 200, 300][: at // 100]
    assert (tmp_path / "killed" / "last.pt").is_file() == (every == 200)
    resumed = train_item(item("killed"))
    steps = logged_steps(tmp_path / "killed")
    assert steps == [100, 200, 300, 400] and all(a < b for a, b in zip(steps, steps[1:]))
    assert metrics_rows(tmp_path / "killed") == metrics_rows(tmp_path / "whole")
    assert (resumed["steps"], resumed["tasks"], resumed["last"]) == (whole["steps"], whole["tasks"], whole["last"])


# ---- 3. one trainer per run folder ------------------------------------------------------------------
def test_a_second_trainer_of_a_run_folder_stops_at_once(tmp_path, capsys):
    folder = tmp_path / "run"
    folder.mkdir()
    with HeldLock(folder):
        code, err = command(
            dqn_main(),
            ["--domain", MINIMAL, "--horizon", "myopic", "--no-progress", "--out", folder, *argv(SMALL)],
            capsys,
        )
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith(f"error: {folder}: another process"), err
    assert not (folder / "metrics.jsonl").exists()  # nothing of the second run was written
    code, err = command(
        dqn_main(), ["--domain", MINIMAL, "--horizon", "myopic", "--no-progress", "--out", folder, *argv(SMALL)], capsys
    )
    assert code == 0 and logged_steps(folder) == [100, 200, 300]  # once the first has ended, it trains


# ---- 2. the export replaces only its own run's files, checks everything first -----------------------
def test_export_refuses_another_runs_checkpoint_and_figures(run, tmp_path, capsys):
    ck, figs = tmp_path / "rl.pt", tmp_path / "training.json"
    shutil.copy(COMMITTED, ck)
    committed = sha256(ck)
    code, err = command(export_main(), [run, "--out", ck, "--figures", figs], capsys)
    assert (
        code == 2
        and f"error: {ck}: the checkpoint of another run (run folder 'runs/dqn/restaurant-two-room-myopic-seed0', not"
        in err
    ), err
    assert sha256(ck) == committed and not figs.exists()
    shutil.copy(COMMITTED_FIGURES, figs)
    code, err = command(export_main(), [run, "--out", tmp_path / "fresh.pt", "--figures", figs], capsys)
    assert code == 2 and f"error: {figs}: the key figures of another run" in err, err
    assert not (tmp_path / "fresh.pt").exists()  # the figures are checked before the checkpoint is written
    code, err = command(export_main(), [run, "--out", ck, "--figures", figs, "--force"], capsys)
    assert code == 0, err
    assert read_checkpoint(ck)["config"]["out"] == str(run)


def test_exporting_the_same_run_again_keeps_its_checkpoint_and_another_steps_count_is_another_run(
    run, tmp_path, capsys
):
    ck, figs = tmp_path / "rl.pt", tmp_path / "training.json"
    assert command(export_main(), [run, "--out", ck, "--figures", figs], capsys)[0] == 0
    before = ck.read_bytes(), figs.read_bytes()
    code, err = command(export_main(), [run, "--out", ck, "--figures", figs], capsys)
    assert code == 0 and (ck.read_bytes(), figs.read_bytes()) == before, err  # a no-op, byte for byte
    other = copy_run(run, tmp_path / "other")
    best = read_checkpoint(other / "best.pt")
    best["config"]["out"], best["config"]["steps"] = str(run), 400  # the same folder, trained to 400
    save_checkpoint(other / "best.pt", best)
    code, err = command(export_main(), [other, "--out", ck, "--figures", figs], capsys)
    assert code == 2 and f"{ck}: the checkpoint of another run (steps 300, not 400)" in err, err
    assert ck.read_bytes() == before[0]


def test_export_checks_everything_before_writing(run, tmp_path, capsys):
    """A run without its metrics.jsonl replaced the committed checkpoint before it failed."""
    broken = copy_run(run, tmp_path / "broken")
    (broken / "metrics.jsonl").unlink()
    ck = tmp_path / "rl.pt"
    shutil.copy(COMMITTED, ck)
    code, err = command(export_main(), [broken, "--out", ck, "--figures", tmp_path / "f.json"], capsys)
    assert code == 2 and sha256(ck) == sha256(COMMITTED) and not (tmp_path / "f.json").exists(), err
    code, err = command(export_main(), [broken, "--out", tmp_path / "new.pt", "--figures", tmp_path / "f.json"], capsys)
    assert code == 2 and err.splitlines()[-1].startswith(f"error: {broken}/metrics.jsonl: cannot read"), err
    assert not (tmp_path / "new.pt").exists() and not (tmp_path / "f.json").exists()


def test_export_refuses_a_run_being_trained_and_notes_an_unfinished_one(run, tmp_path, capsys):
    busy = copy_run(run, tmp_path / "busy")
    with HeldLock(busy):
        code, err = command(export_main(), [busy, "--out", tmp_path / "a.pt", "--figures", tmp_path / "a.json"], capsys)
    assert code == 2 and f"error: {busy}: is still being written" in err, err
    assert not (tmp_path / "a.pt").exists()
    last = read_checkpoint(busy / "last.pt")  # a run stopped at 300 of the 1,000 steps it was set to
    last["config"]["steps"] = 1000
    save_checkpoint(busy / "last.pt", last)
    code, err = command(export_main(), [busy, "--out", tmp_path / "a.pt", "--figures", tmp_path / "a.json"], capsys)
    assert code == 0 and f"{busy}: unfinished, trained to step 300 of 1,000" in err, err
    assert len([line for line in err.splitlines() if "unfinished" in line]) == 1
    code, err = command(export_main(), [run, "--out", tmp_path / "b.pt", "--figures", tmp_path / "b.json"], capsys)
    assert code == 0 and "unfinished" not in err


# ---- 4. output paths stay in their folders -----------------------------------------------------------
def test_export_names_its_outputs_from_checked_values(run, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    bad = copy_run(run, tmp_path / "work" / "bad")
    best = read_checkpoint(bad / "best.pt")
    best["config"]["seed"] = "0/../../escaped"
    save_checkpoint(bad / "best.pt", best)
    code, err = command(export_main(), [bad], capsys)
    assert code == 2 and f"error: {bad}/best.pt: config.seed '0/../../escaped' cannot name an output" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["work"]  # nothing written anywhere
    # a GNN dataset's layout names its figures file
    data = tmp_path / "work" / "data"
    data.mkdir()
    (data / "meta.json").write_text(
        json.dumps(
            {
                "kinds": ["faithful"],
                "c_ap": [1.0],
                "label_seconds": [0.1],
                "n": 1,
                "layout": "../../escaped",
                "config": {"augmented": False},
            }
        )
    )
    code, err = command(export_main(), [data], capsys)
    assert code == 2 and f"error: {data}/meta.json: layout '../../escaped' cannot name an output" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["work"]
    # a GNN run's layout names its checkpoint
    from learning.gnn.model import save_gnn_checkpoint

    (data / "meta.json").write_text(json.dumps({"config": {"augmented": False}}))
    gnn = tmp_path / "work" / "gnn"
    save_gnn_checkpoint(
        gnn / "best.pt", {"model": {}, "dims": {}, "layout": "../x", "config": {"data": str(data), "seed": 0}}
    )
    code, err = command(export_main(), [gnn], capsys)
    assert code == 2 and f"error: {gnn}/best.pt: layout '../x' cannot name an output" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["work"]


@pytest.mark.parametrize("option", [["--eps-schedule", "reach,../../x"], ["--demo-planner", "internal,../../x"]])
def test_a_sweep_checks_its_values_before_writing_anything(tmp_path, option):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "experiments.sweep",
            "--domain",
            MINIMAL,
            "--horizon",
            "myopic",
            "--no-progress",
            *argv(SMALL),
            *option,
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
        env=env,
    )
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith(f"error: {option[0]}: "), r.stderr
    assert "../../x" in lines[0]
    assert list(tmp_path.iterdir()) == []  # no parts folder, no run folder, nothing


# ---- 5. checkpoints record the domain ----------------------------------------------------------------
def test_checkpoints_and_figures_record_the_domain(run, tmp_path, capsys, minimal):
    mine = identity(minimal)
    for name in ("best.pt", "last.pt"):
        payload = read_checkpoint(run / name)
        assert {k: payload[k] for k in mine} == mine, name
    ck, figs = tmp_path / "rl.pt", tmp_path / "training.json"
    assert command(export_main(), [run, "--out", ck, "--figures", figs], capsys)[0] == 0
    assert {k: read_checkpoint(ck)[k] for k in mine} == mine
    assert {k: json.loads(figs.read_text())[k] for k in mine} == mine


def test_a_checkpoint_of_another_domain_or_layout_is_refused_and_other_content_is_a_warning(
    run, tmp_path, capsys, minimal
):
    from experiments.registry import agent_class
    from planning.errors import DomainError

    payload = read_checkpoint(run / "best.pt")
    for key, value, expect in (
        ("domain", "restaurant", "trained for restaurant/grid, not minimal/grid"),
        ("layout", "attic", "trained for minimal/attic, not minimal/grid"),
    ):
        edited = (
            {**payload, "domain": value}
            if key == "domain"
            else {**payload, "config": {**payload["config"], "layout": value}}
        )
        path = save_checkpoint(tmp_path / f"{key}.pt", edited)
        agent = agent_class("rl-greedy").from_args(Namespace(checkpoint=str(path)))
        with pytest.raises(DomainError, match=expect):
            agent.start(minimal, None)
    capsys.readouterr()
    other = save_checkpoint(
        tmp_path / "edited.pt",
        {**payload, "domain_sha256": "0" * 64, "domain_files": {**payload["domain_files"], "domain.toml": "0"}},
    )
    vf = load_value_function(other, minimal)  # usable, with one line saying so
    load_value_function(other, minimal)
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 1
        and err[0]
        == f"warning: {other}: trained on other content of domain 'minimal' (changed: domain.toml); used as it is"
    ), err
    assert vf.greedy([minimal.reset_state(0)], 0).shape == (1,)
    # resuming a run under another domain's name is refused too
    last = read_checkpoint(run / "last.pt")
    moved = copy_run(run, tmp_path / "moved")
    save_checkpoint(
        moved / "last.pt", {**last, "domain": "restaurant", "config": {**last["config"], "out": str(moved)}}
    )
    code, err = command(
        dqn_main(),
        ["--domain", MINIMAL, "--horizon", "myopic", "--no-progress", "--out", moved, *argv({**SMALL, "steps": 400})],
        capsys,
    )
    assert code == 2 and f"{moved}/last.pt: trained for restaurant/grid, not minimal/grid" in err, err


def test_committed_checkpoints_load_as_before(two_room, capsys):
    """Checkpoints written before domains were recorded load unchanged (their sha256 is in results files)."""
    before = sha256(COMMITTED)
    vf = load_value_function(COMMITTED, two_room)
    assert vf.greedy([two_room.reset_state(0)], 0).shape == (1,)
    assert capsys.readouterr().err == "" and sha256(COMMITTED) == before


def test_the_minimal_example_trains_and_resumes_through_the_one_resume_path(tmp_path):
    """experiments.minimal_example trains through learning.q.training.train_run: a second run resumes each
    horizon's finished run (same steps, no metrics row twice) instead of appending to it."""
    import json

    from experiments.minimal_example import run

    first = run("domains/minimal", 0, 200, str(tmp_path), episodes=3, progress=False)
    again = run("domains/minimal", 0, 200, str(tmp_path), episodes=3, progress=False)
    assert first["myopic"]["steps"] == again["myopic"]["steps"] == 200
    for horizon in ("myopic", "anticipatory"):
        rows = [json.loads(line) for line in (tmp_path / f"{horizon}-seed0" / "metrics.jsonl").read_text().splitlines()]
        steps = [r["step"] if "step" in r else r["eval"]["step"] for r in rows]
        assert steps and steps == sorted(steps) and len(steps) == len({(s, "eval" in r) for s, r in zip(steps, rows)})


def test_another_domains_export_is_named_after_it(run, tmp_path, monkeypatch):
    """A run of the minimal domain exports to checkpoints/minimal-rl-….pt and results/minimal-training-….json,
    so a layout of the same name in another domain never lands on the restaurant's committed files."""
    from learning.export import default_names

    monkeypatch.chdir(tmp_path)
    checkpoint, figures = default_names(run, gnn=False)
    assert checkpoint == "checkpoints/minimal-rl-myopic-grid-seed0.pt"
    assert figures == "results/minimal-training-myopic-grid-seed0.json"


def test_a_run_shorter_than_its_log_interval_exports_its_figures():
    """A run that logged no row yet (steps < log_every) has key figures the export can print (it crashed on
    the missing train_hours)."""
    from learning.export import key_figures

    assert key_figures([], []) == {"steps": 0, "train_hours": 0.0}
