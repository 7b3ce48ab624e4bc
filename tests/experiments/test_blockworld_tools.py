"""Every tool on the second real domain, the persistent blockworld (issue 37), with tiny settings: a copy of
domains/blockworld whose one canonical sequence has four tasks, each command run as a user runs it
(`python -m ...`, exit status 0), one after another as their inputs need: the checker, the oracles, the
labelling, the GNN datasets, training and export of both values, every agent, the Gymnasium checker and the
benchmarks. No Python file mentions the domain; this test runs it only through its folder."""

import json
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.world.sequences import generate

ROOT = Path(__file__).resolve().parents[2]
LAYOUT = "grid7x7"


@pytest.fixture(scope="module")
def bw(tmp_path_factory):
    """(work folder, domain folder): a copy of the blockworld folder with one canonical sequence of four tasks."""
    work = tmp_path_factory.mktemp("bw")
    folder = work / "blockworld"
    shutil.copytree(ROOT / "domains" / "blockworld", folder, ignore=shutil.ignore_patterns("sequences"))
    for rec in generate(compile_domain(folder, LAYOUT), count=1, length=4):
        write_json(folder / "sequences" / LAYOUT / f"seq-{rec['id']:02d}.json", rec)
    return work, folder


def run(work, *args, timeout=300):
    """`python -m ARGS` in the work folder (progress bars off), which must exit 0; its stdout."""
    r = subprocess.run(
        [sys.executable, "-m", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=work,
        timeout=timeout,
        env={**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "TQDM_DISABLE": "1"},
    )
    assert r.returncode == 0, (args, r.stderr[-1500:])
    return r.stdout


def results(work, name) -> dict:
    return json.loads((work / "results" / name).read_text())


def test_every_tool_runs_on_the_blockworld(bw):
    work, d = bw
    common = ("--domain", d, "--layout", LAYOUT)
    play = (*common, "--sequences", "0")  # the tiny canonical sequence
    run(work, "planning.world.domain_check", d, "--no-costs")
    run(work, "planning.world.sequences", "--domain", ROOT / "domains" / "blockworld", "--layout", LAYOUT, "--check")
    # the oracles: myopic (ours, optimal), clairvoyant K = 2, the labelling oracle's C_AP of the start state
    run(work, "oracles.myopic", *play, "--planner", "internal", "--out", "results/myopic.json")
    myopic = results(work, "myopic.json")
    assert myopic["success_rate"] == 1.0 and len(myopic["per_task"]) == 4
    run(work, "oracles.clairvoyant", *play, "--K", "2", "--out", "results/k2.json")
    assert results(work, "k2.json")["cost_per_task"] <= myopic["cost_per_task"]
    run(work, "oracles.labelling", *common, "--out", "results/label.json")
    # the GNN: faithful and augmented datasets, a model, native selection and the GNN value in the search
    run(work, "learning.gnn_dataset", *common, "--n-states", 6, "--out", "runs/gnn-data")
    run(
        work,
        "learning.gnn_dataset",
        *common,
        "--augmented",
        "--n-states",
        4,
        "--n-prepared",
        4,
        "--out",
        "runs/gnn-aug",
    )
    run(work, "learning.gnn_train", *common, "--data", "runs/gnn-aug", "--epochs", 1, "--out", "runs/gnn")
    run(work, "learning.export", "runs/gnn", "--out", "checkpoints/gnn.pt", "--figures", "results/gnn-training.json")
    run(work, "experiments.evaluate", *play, "--agent", "gnn-native", "--model", "checkpoints/gnn.pt")
    run(work, "experiments.evaluate", *play, "--agent", "gnn-guided", "--model", "checkpoints/gnn.pt", "--budget", 30)
    # the Double-DQN, both horizons, exported and deployed greedily and guided
    tiny = (
        "--steps",
        80,
        "--learning-starts",
        20,
        "--demo-tasks",
        3,
        "--eval-every",
        80,
        "--eval-tasks",
        2,
        "--log-every",
        40,
        "--goal-reward",
        30,
    )
    for h in ("myopic", "anticipatory"):
        run(work, "learning.dqn", *common, "--horizon", h, *tiny, "--hidden", 16, "--out", f"runs/dqn-{h}")
        run(
            work,
            "learning.export",
            f"runs/dqn-{h}",
            "--out",
            f"checkpoints/q-{h}.pt",
            "--figures",
            f"results/t-{h}.json",
        )
    run(work, "experiments.evaluate", *play, "--agent", "rl-greedy", "--checkpoint", "checkpoints/q-myopic.pt")
    run(
        work,
        "experiments.evaluate",
        *play,
        "--agent",
        "rl-guided",
        "--checkpoint",
        "checkpoints/q-anticipatory.pt",
        "--budget",
        30,
        "--beta",
        1.5,
    )
    played = sorted(p.name for p in (work / "results").glob("blockworld-*.json"))
    assert len(played) == 4, played  # gnn-native, gnn-guided, rl-greedy, rl-guided, named after the domain
    for name in played:
        r = results(work, name)
        assert r["domain"] == "blockworld" and len(r["per_task"]) == 4
        if "rl-greedy" not in name:  # planners complete every task; an 80-step greedy policy need not
            assert r["success_rate"] == 1.0, name
    # the benchmarks
    run(
        work,
        "planning.external.simulator_bench",
        *common,
        "--states",
        20,
        "--seconds",
        0.05,
        "--out",
        "results/sim.json",
    )
    run(work, "oracles.planner_bench", *common, "--calls", 2, "--out", "results/planner.json", "--time-limit", 60)


def test_the_gymnasium_checker_passes_on_the_blockworld():
    import gymnasium as gym
    from gymnasium.utils.env_checker import check_env

    import learning.gym_env  # noqa: F401  (registers the bundled domains' ids)

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(f"AnticipatoryBlockworld-{LAYOUT}-v0").unwrapped)
