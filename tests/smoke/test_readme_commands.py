"""Every command line of the README and of the spec's command table, run as written in a fresh copy of the
checkout (CI's smoke test: `make smoke`, not the default suite).

A command whose results are committed keeps them and must finish at once with exit 0; a long one
(training, a dataset, a benchmark, a 2,000-task rollout) must start: still running after
`START_SECONDS` with nothing on stderr that says `error:`, or finished with exit 0. Placeholders take
real values (DIR a fresh folder, CKPT a committed checkpoint); `[optional parts]` are run both without
and, where they need no placeholder, with them. A README command that this table does not classify
fails the test, so a new command cannot go unchecked.
"""

import os
import re
import shlex
import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.smoke

ROOT = Path(__file__).resolve().parents[2]
START_SECONDS = 25

QUICK = {  # committed results are kept, or the command is cheap: must finish with exit 0
    "planning.world.sequences",
    "oracles.myopic",
    "oracles.clairvoyant",
    "oracles.labelling",
    "experiments.evaluate",
    "experiments.reproduce",
    "planning.world.domain_check",
}
LONG = {  # must start cleanly
    "experiments.demo",
    "oracles.rollouts",
    "experiments.calibrate",
    "learning.gnn_dataset",
    "learning.dqn",
    "experiments.minimal_example",
    "planning.external.simulator_bench",
    "oracles.planner_bench",
    "oracles.labelling_bench",
    "learning.q.bench",
    "learning.agents.bench_bn",
    "experiments.select_beta",
    "experiments.sweep",
    "learning.capacity",
    "planning.world.validate",
}
NEEDS_A_RUN = {  # their input is what another command makes over hours: checked on a missing input instead
    "learning.export": "a finished training run (python -m learning.dqn makes one in about two hours)",
    "learning.gnn_train": "a labelled dataset (python -m learning.gnn_dataset)",
    "learning.gnn.bench": "a labelled dataset (python -m learning.gnn_dataset)",
    "learning.values.rank": "a labelled dataset (python -m learning.gnn_dataset)",
}
NOT_HERE = ("--ray",)  # a Ray cluster's commands (`ray start --head` first): not run on a CI machine
QUICK_ONLY_WITH = {"experiments.reproduce": "--report-only"}  # without it, it plays whatever is missing first
SPEC_COMMANDS = [
    "python -m oracles.myopic",
    "python -m oracles.clairvoyant --K 3",
    "python -m oracles.labelling",
    "python -m learning.gnn_dataset",
    "python -m learning.gnn_dataset --augmented",
    "python -m learning.dqn --horizon myopic",
    "python -m learning.dqn --horizon anticipatory",
    "python -m experiments.evaluate --agent rl-greedy --checkpoint checkpoints/rl-anticipatory-two-room-seed0.pt",
]


def readme_commands() -> list[str]:
    """The `python -m …` command lines of README.md (tables and code blocks), optional parts expanded."""
    text = (ROOT / "README.md").read_text()
    found = [" ".join(c.split()) for c in re.findall(r"`(python -m [^`]+)`", text)]
    found += [line.strip() for line in text.splitlines() if line.strip().startswith("python -m ")]
    lines = []
    for cmd in found:
        cmd = cmd.split("#")[0].strip()
        optional = re.findall(r"\[([^\[\]]+)\]", cmd)
        bare = re.sub(r"\s*\[[^\[\]]+\]", "", cmd)
        lines.append(bare)
        for opt in optional:
            if "|" not in opt and "FILE" not in opt and "..." not in opt:
                lines.append(f"{bare} {opt}")
    return sorted(set(lines))


def concrete(cmd: str, tmp: Path) -> list[str]:
    """The command's argv with its placeholders made real."""
    cmd = cmd.replace("--agent NAME", "--agent rl-greedy --checkpoint checkpoints/rl-anticipatory-two-room-seed0.pt")
    cmd = cmd.replace("--checkpoint CKPT", "--checkpoint checkpoints/rl-anticipatory-three-room-seed0.pt")
    cmd = cmd.replace("--value CKPT", "--value checkpoints/rl-anticipatory-three-room-seed0.pt")
    cmd = cmd.replace("--model CKPT", "--model checkpoints/gnn-augmented-two-room-seed0.pt")
    argv = shlex.split(cmd)
    out, k = [], 0
    for a in argv:
        if a == "DIR":
            k += 1
            a = str(tmp / f"dir{k}")
        out.append(a)
    return [sys.executable, *out[1:]]


@pytest.fixture(scope="module")
def fresh(tmp_path_factory) -> Path:
    """The checkout's tracked and unignored files, copied as a fresh clone has them."""
    dst = tmp_path_factory.mktemp("clone") / "checkout"
    files = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        check=True,
    ).stdout.split(b"\0")
    for name in filter(None, files):
        src = ROOT / name.decode()
        if src.is_file():
            target = dst / name.decode()
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(src.read_bytes())
    return dst


def all_commands() -> list[str]:
    every = set(readme_commands()) | set(SPEC_COMMANDS)
    return sorted(c for c in every if not any(flag in c.split() for flag in NOT_HERE))


def module_of(cmd: str) -> str:
    return shlex.split(cmd)[2]


def test_every_readme_command_is_classified():
    unknown = sorted({module_of(c) for c in all_commands()} - QUICK - LONG - set(NEEDS_A_RUN))
    assert not unknown, f"README commands this smoke test does not know: {unknown}"


@pytest.mark.parametrize("cmd", all_commands())
def test_command_as_written(cmd, fresh, tmp_path):
    module = module_of(cmd)
    argv = concrete(cmd, tmp_path)
    env = {**os.environ, "PYTHONPATH": str(fresh), "OMP_NUM_THREADS": "1"}
    if module in NEEDS_A_RUN:
        r = subprocess.run(argv, cwd=fresh, capture_output=True, text=True, timeout=120, env=env)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("error:"), r.stderr[-800:]
        return
    quick = module in QUICK and QUICK_ONLY_WITH.get(module, "") in cmd
    proc = subprocess.Popen(
        argv, cwd=fresh, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, start_new_session=True
    )
    try:
        out, err = proc.communicate(timeout=600 if quick else START_SECONDS)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        assert not quick, f"{cmd}: still running after 600 s"
        assert "error:" not in err and "Traceback" not in err, err[-1500:]
        return
    assert proc.returncode == 0, f"{cmd}: exit {proc.returncode}\n{err[-1500:]}"
    assert "Traceback" not in err, err[-1500:]
