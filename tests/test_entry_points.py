"""Every `python -m` entry point answers an unknown --layout with a one-line error and exit status 2."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# Entry points that need more than --layout to get as far as reading the domain.
EXTRA = {
    "experiments.evaluate": ["--agent", "random"],
    "learning.dqn": ["--horizon", "myopic"],
    "learning.gnn_dataset": ["--out", "unused"],
    "experiments.select_beta": ["--checkpoint", "unused.pt"],
    "learning.gnn_train": ["--data", "unused", "--out", "unused"],
}


def entry_points() -> list[str]:
    mods = []
    for layer in ("planning", "oracles", "learning", "experiments"):
        for p in sorted((ROOT / layer).rglob("*.py")):
            if 'if __name__ == "__main__"' in p.read_text():
                mods.append(".".join(p.relative_to(ROOT).with_suffix("").parts))
    return mods


# Entry points whose layout is their input's (a run folder, a checkpoint): a missing input instead.
FROM_INPUT = {
    "learning.export": ["attic"],
    "learning.gnn.bench": ["--model", "attic.pt", "--data", "attic"],
    "learning.values.rank": ["--value", "attic.pt", "--data", "attic"],
    "planning.world.validate": ["attic"],
}


@pytest.mark.parametrize("module", [m for m in entry_points() if m not in FROM_INPUT])
def test_unknown_layout_is_a_one_line_error(module, tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", module, "--layout", "attic", *EXTRA.get(module, [])],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert r.returncode == 2, (r.returncode, r.stderr[-500:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "attic" in lines[0], r.stderr[-500:]


@pytest.mark.parametrize("module", sorted(FROM_INPUT))
def test_missing_input_is_a_one_line_error(module):
    r = subprocess.run(
        [sys.executable, "-m", module, *FROM_INPUT[module]], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert r.returncode == 2, (r.returncode, r.stderr[-500:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "attic" in lines[0], r.stderr[-500:]
