"""Evaluations and sweeps over workers give the serial run's results (local processes, and Ray when installed)."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.registry import agent_class, agent_options
from experiments.workers import Job, play_over_workers
from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.parallel import one_thread, run_items
from planning.world.runner import evaluate
from planning.world.sequences import generate

ROOT = Path(__file__).resolve().parents[2]
TIMINGS = {
    "seconds",
    "wall_seconds",
    "window_seconds",
    "fallback_seconds",
    "search_seconds",
    "item_seconds",
    "provenance",
    "ran",
}
RANDOM = ["--agent", "random", "--seed", "3"]
MYOPIC = ["--agent", "myopic-oracle", "--planner", "internal"]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """The minimal grid with two canonical sequences of 5 tasks: a real folder every worker can read."""
    folder = tmp_path_factory.mktemp("domains") / "tiny"
    shutil.copytree(ROOT / "domains" / "minimal", folder)
    model = compile_domain(folder, "grid")
    for rec in generate(model, count=2, length=5):
        write_json(folder / "sequences" / "grid" / f"seq-{rec['id']:02d}.json", rec)
    return folder


def strip(obj):
    """A results JSON less its timings and provenance."""
    if isinstance(obj, dict):
        return {k: strip(v) for k, v in obj.items() if k not in TIMINGS}
    if isinstance(obj, list):
        return [strip(v) for v in obj]
    return obj


def job(folder, out, argv, force=False) -> Job:
    """What `experiments.evaluate` builds from its command line."""
    name = argv[1]
    p = cli.parser("test", sequences=True)
    p.add_argument("--agent")
    agent_class(name).options(p)
    args = p.parse_args([*argv, "--domain", str(folder), "--layout", "grid", "--sequences", "0-1", "--out", str(out)])
    model = compile_domain(args.domain, args.layout)
    options = agent_options(name, args)
    return Job(name, options, args.domain, model, agent_class(name).from_args(options, model), [0, 1], str(out), force)


def run(j: Job, workers=1, use_ray=False) -> dict:
    one_thread()
    if workers > 1 or use_ray:
        play_over_workers([j], workers, use_ray, progress=False)
    return evaluate(j.model, j.agent, j.ids, j.out, progress=False, force=j.force)


def square(x):
    return x * x


def test_run_items_keeps_the_order_and_reports_each_item():
    seen = []
    assert run_items(
        square, [3, 1, 2], workers=2, progress=False, on_result=lambda i, r, meta: seen.append((i, r))
    ) == [9, 1, 4]
    assert sorted(seen) == [(0, 9), (1, 1), (2, 4)]


@pytest.mark.parametrize("argv", [RANDOM, MYOPIC], ids=["random", "myopic-oracle"])
def test_two_workers_give_the_serial_results(tiny, tmp_path, argv):
    serial = run(job(tiny, tmp_path / "serial.json", argv))
    two = run(job(tiny, tmp_path / "two.json", argv), workers=2)
    assert serial["tasks"] == 10 and strip(two) == strip(serial)
    assert not (tmp_path / "two.json.parts").exists() and not (tmp_path / "two.json.partial.json").exists()


def test_the_command_line_with_two_workers(tiny, tmp_path):
    serial = run(job(tiny, tmp_path / "serial.json", RANDOM))
    out = tmp_path / "cli.json"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "experiments.evaluate",
            *RANDOM,
            "--domain",
            str(tiny),
            "--layout",
            "grid",
            "--sequences",
            "0-1",
            "--out",
            str(out),
            "--workers",
            "2",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    written = json.loads(out.read_text())
    assert {k: v for k, v in strip(written).items() if k != "improvement_note"} == {
        k: v for k, v in strip(serial).items() if k != "improvement_note"
    }
    assert written["provenance"]["played_in_this_process"] == [0, 1]  # played by its workers
    assert "played sequences 0-1" in r.stdout


def test_each_sequence_has_its_own_file_and_a_rerun_reuses_it(tiny, tmp_path):
    serial = run(job(tiny, tmp_path / "serial.json", RANDOM))
    out = tmp_path / "r.json"
    # An interrupted run left sequence 0's file (marked), not sequence 1's.
    j = job(tiny, out, RANDOM)
    rows = [dict(r, seconds=7.0) for r in serial["per_task"] if r["sequence"] == 0]
    write_json(
        tmp_path / "r.json.parts" / "seq-00.json",
        {
            "agent": "random",
            "layout": "grid",
            "config": j.agent.config,
            "failure_protocol": "fallback",
            "sequence": 0,
            "rows": rows,
            "wall_seconds": 1.0,
        },
    )
    played = play_over_workers([j], workers=2, progress=False)
    assert (played["items"], played["reused"]) == (1, 1)
    resumed = evaluate(j.model, j.agent, j.ids, j.out, progress=False, played_by_workers=played["played"])
    assert [r["seconds"] for r in resumed["per_task"] if r["sequence"] == 0] == [7.0] * 5
    assert resumed.played == [1] and resumed["provenance"]["played_in_this_process"] == [1]
    assert strip(resumed["per_task"][5:]) == strip(serial["per_task"][5:])


def test_another_configuration_stops_before_any_work(tiny, tmp_path):
    out = tmp_path / "r.json"
    run(job(tiny, out, RANDOM))
    with pytest.raises(DomainError, match="a finished run with seed 3, not 4; pass --force"):
        play_over_workers([job(tiny, out, ["--agent", "random", "--seed", "4"])], workers=2, progress=False)
    assert not (tmp_path / "r.json.parts").exists()
    forced = run(job(tiny, out, ["--agent", "random", "--seed", "4"], force=True), workers=2)
    assert forced["config"] == {"seed": 4}


def test_ray_gives_the_serial_results(tiny, tmp_path):
    pytest.importorskip("ray")
    serial = run(job(tiny, tmp_path / "serial.json", RANDOM))
    with_ray = run(job(tiny, tmp_path / "ray.json", RANDOM), workers=2, use_ray=True)
    assert strip(with_ray) == strip(serial)


# ---- sweeps ----------------------------------------------------------------------------------
TRAIN = [
    "--horizon",
    "anticipatory",
    "--seed",
    "0-1",
    "--steps",
    "120",
    "--demo-tasks",
    "0",
    "--learning-starts",
    "40",
    "--eval-every",
    "120",
    "--eval-tasks",
    "4",
    "--log-every",
    "60",
    "--checkpoint-every",
    "120",
    "--hidden",
    "32",
    "--batch-size",
    "16",
]


def sweep(tiny, tmp_path, name, *extra):
    out = tmp_path / f"{name}.json"
    r = subprocess.run(
        [sys.executable, "-m", "experiments.sweep", "--domain", str(tiny), "--out", str(out), "--no-progress", *extra],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(out.read_text())


def points(result):
    return strip([{k: v for k, v in p.items() if k not in ("run", "file")} for p in result["points"]])


GUIDED = ["--kind", "guided", "--layout", "grid", "--beta", "1,2", "--budget", "50", "--sequences", "0-1"]


@pytest.fixture(scope="module")
def serial_sweeps(tiny, tmp_path_factory):
    """A training sweep (2 seeds) and an rl-guided β sweep with its first network, run serially."""
    where = tmp_path_factory.mktemp("sweeps")
    train = sweep(tiny, where, "serial", *TRAIN, "--runs", "runs/serial")
    ckpt = str(where / "runs" / "serial" / "minimal-grid-anticipatory-seed0" / "best.pt")
    guided = sweep(tiny, where, "g-serial", *GUIDED, "--checkpoint", ckpt, "--results", "r-serial")
    return where, ckpt, train, guided


# over Ray the sweep is slow to start (a local instance per sweep); test_ray_gives_the_serial_results keeps Ray in
# the default suite
@pytest.mark.parametrize("mode", ["workers", pytest.param("ray", marks=pytest.mark.slow)])
def test_a_sweep_over_workers_gives_the_serial_results(tiny, tmp_path, serial_sweeps, mode):
    if mode == "ray":
        pytest.importorskip("ray")
    how = ["--workers", "2"] if mode == "workers" else ["--ray", "--workers", "2"]
    where, ckpt, serial, g1 = serial_sweeps
    spread = sweep(tiny, tmp_path, "spread", *TRAIN, "--runs", "runs/spread", *how)
    assert [p["seed"] for p in serial["points"]] == [0, 1] and points(spread) == points(serial)
    assert len(list((tmp_path / "spread.json.parts").glob("*.json"))) == 2  # one file per run, kept
    g2 = sweep(tiny, tmp_path, "g-spread", *GUIDED, "--checkpoint", ckpt, "--results", "r-spread", *how)
    assert [(p["beta"], p["budget"]) for p in g1["points"]] == [(1.0, 50), (2.0, 50)]
    assert points(g2) == points(g1)
    for a, b in zip(g1["points"], g2["points"]):
        ra, rb = json.loads((where / a["file"]).read_text()), json.loads((tmp_path / b["file"]).read_text())
        assert strip(ra) == strip(rb)
    if mode == "workers":  # a rerun reuses every run's file
        again = sweep(tiny, tmp_path, "spread", *TRAIN, "--runs", "runs/spread", *how)
        assert again["items_reused"] == 2 and points(again) == points(serial)


def test_a_sweep_of_seeds_together_follows_the_serial_runs(tiny, tmp_path, serial_sweeps):
    """--seeds-together: the two seeds are one work item, trained with their updates batched; each run still
    has its own folder and part, the same steps and tasks, and figures equal to float32 rounding."""
    where, _, serial, _ = serial_sweeps
    together = sweep(tiny, tmp_path, "together", *TRAIN, "--runs", "runs/together", "--seeds-together")
    assert [p["seed"] for p in together["points"]] == [0, 1]
    assert len(list((tmp_path / "together.json.parts").glob("*.json"))) == 2
    for a, b in zip(serial["points"], together["points"]):
        assert (a["steps"], a["tasks"], a["best_step"]) == (b["steps"], b["tasks"], b["best_step"])
        assert a["last"]["success_rate"] == b["last"]["success_rate"]
        assert a["last"]["td_target"] == pytest.approx(b["last"]["td_target"], rel=1e-3, abs=1e-3)
    assert (tmp_path / "runs" / "together" / "minimal-grid-anticipatory-seed1" / "last.pt").is_file()


def test_a_training_sweeps_summary_is_named_after_its_grid():
    """Two sweeps of one domain keep their own summaries: the default name spells the grid."""
    from experiments.sweep import summary_name

    assert (
        summary_name("restaurant", {"layout": ["three-room"], "horizon": ["anticipatory"], "seed": [42]})
        == "train-restaurant-three-room-anticipatory-seed42"
    )
    assert (
        summary_name(
            "restaurant",
            {
                "layout": ["two-room", "three-room"],
                "horizon": ["myopic"],
                "seed": [0, 1, 2, 3, 8, 16, 17],
                "gamma": [0.95, 0.97],
            },
        )
        == "train-restaurant-two-room+three-room-myopic-seed0-3+8+16-17-gamma0.95+0.97"
    )


def test_a_discount_given_alone_is_named_as_in_a_list(tiny, tmp_path, monkeypatch):
    """`--gamma 0.9` names its run, checkpoint and results as `--gamma 0.9,0.99` names its γ = 0.9 point, so it
    never trains into the default run's folder; Table A.2's γ given alone leaves the names as they are."""
    import argparse

    from experiments.sweep import train_items

    monkeypatch.chdir(tmp_path)
    args = argparse.Namespace(
        domain=str(tiny), runs="runs/dqn", deploy=True, checkpoints="ck", results="res", sequences="0-1", force=False
    )
    grid = {"layout": ["grid"], "horizon": ["anticipatory"], "seed": [0]}

    def named(settings, **axes):
        _, names, items = train_items(args, {**grid, **axes}, settings)
        return [(n, it["deploy"]["checkpoint"], it["deploy"]["greedy"]) for n, it in zip(names, items)]

    alone = named({"gamma": 0.9})
    assert alone == [
        (
            "minimal-grid-anticipatory-seed0-gamma0.9",
            "ck/minimal-rl-anticipatory-grid-seed0-gamma0.9.pt",
            "res/minimal-rl-greedy-anticipatory-grid-seed0-gamma0.9.json",
        )
    ]
    assert named({}, gamma=[0.9, 0.99])[0] == alone[0]
    assert named({"gamma": 0.97})[0][0] == "minimal-grid-anticipatory-seed0" == named({})[0][0]


def test_a_sweep_names_its_runs_with_the_domains_training_defaults(tiny, tmp_path, monkeypatch):
    """A setting domain.toml [training] gives (here the goal-object task encoding) is in a sweep's run, checkpoint
    and results names as learning.dqn and learning.export put it there: a run of the domain's default encoding
    and one of the thesis's encoding given on the command line never share a folder or a file. Runs are named after
    the PDDL domain (here `minimal`), as learning.dqn names its default folder, not after the domain's folder."""
    import argparse

    from experiments.sweep import train_items
    from learning.q.training import make_config, run_folder
    from planning.domain.compiler import compile_domain

    folder = tmp_path / "objects"
    shutil.copytree(tiny, folder)
    toml = folder / "domain.toml"
    toml.write_text(toml.read_text().replace("[training]\n", '[training]\ntask_features = "arguments+objects"\n', 1))
    monkeypatch.chdir(tmp_path)
    args = argparse.Namespace(
        domain=str(folder), runs="runs/dqn", deploy=True, checkpoints="ck", results="res", sequences="0-1", force=False
    )
    grid = {"layout": ["grid"], "horizon": ["anticipatory"], "seed": [0]}

    def named(settings):
        _, names, items = train_items(args, grid, settings)
        return names[0], items[0]["deploy"]["checkpoint"], items[0]["out"]

    assert named({}) == (
        "minimal-grid-anticipatory-seed0-features-objects",
        "ck/minimal-rl-anticipatory-grid-seed0-features-objects.pt",
        "runs/dqn/minimal-grid-anticipatory-seed0-features-objects",
    )
    assert named({"task_features": "arguments"})[:2] == (
        "minimal-grid-anticipatory-seed0",
        "ck/minimal-rl-anticipatory-grid-seed0.pt",
    )
    own = run_folder(make_config(str(folder), "grid", "anticipatory", seed=0), compile_domain(str(folder), "grid"))
    assert str(own) == named({})[2]  # learning.dqn's default folder for the same run


def test_a_deployed_sweep_exports_each_run_and_plays_it_greedily(tiny, tmp_path):
    """--deploy: each finished run's compact checkpoint, key figures and rl-greedy results, named as
    learning.export and experiments.evaluate name them; the results file is the greedy evaluation's."""
    from learning.q.value import load_value_function

    one = [a if a != "0-1" else "1" for a in TRAIN]  # seed 1 only
    r = sweep(
        tiny,
        tmp_path,
        "deploy",
        *one,
        "--runs",
        "runs/d",
        "--deploy",
        "--sequences",
        "0-1",
        "--checkpoints",
        "ck",
        "--results",
        "res",
    )
    (point,) = r["points"]
    g = point["greedy"]
    assert g["checkpoint"] == "ck/minimal-rl-anticipatory-grid-seed1.pt" and g["sequences"] == [0, 1]
    played = json.loads((tmp_path / "res" / "minimal-rl-greedy-anticipatory-grid-seed1.json").read_text())
    assert played["agent"] == "rl-greedy" and played["cost_per_task"] == g["cost_per_task"]
    assert played["config"]["checkpoint"] == "ck/minimal-rl-anticipatory-grid-seed1.pt"
    figures = json.loads((tmp_path / "res" / "minimal-training-anticipatory-grid-seed1.json").read_text())
    assert figures["seed"] == 1 and figures["steps"] == 120
    # the compact checkpoint acts as the run's best.pt on the grid
    model = compile_domain(tiny, "grid")
    full = load_value_function(tmp_path / "runs" / "d" / "minimal-grid-anticipatory-seed1" / "best.pt", model)
    small = load_value_function(tmp_path / g["checkpoint"], model)
    states = model.random_walk_states(30, seed=4)
    for t in range(len(model.tasks)):
        assert list(full.greedy(states, t)) == list(small.greedy(states, t))
    again = sweep(
        tiny,
        tmp_path,
        "deploy",
        *one,
        "--runs",
        "runs/d",
        "--deploy",
        "--sequences",
        "0-1",
        "--checkpoints",
        "ck",
        "--results",
        "res",
    )
    assert again["items_reused"] == 1 and again["points"][0]["greedy"] == g
