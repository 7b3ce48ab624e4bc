"""The helpers of the blockworld tool tests (tests/experiments/test_blockworld_*.py, issue 37): a copy of
domains/blockworld whose one canonical sequence has four tasks, and its commands run as a user runs them
(`python -m ...`, exit status 0). No Python file mentions the domain; the tests run it only through its folder."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.world.sequences import generate

ROOT = Path(__file__).resolve().parents[1]
LAYOUT = "grid7x7"


def copy_blockworld(work: Path) -> Path:
    """The blockworld folder copied into `work`, its canonical sequences replaced by one of four tasks."""
    folder = work / "blockworld"
    shutil.copytree(ROOT / "domains" / "blockworld", folder, ignore=shutil.ignore_patterns("sequences"))
    for rec in generate(compile_domain(folder, LAYOUT), count=1, length=4):
        write_json(folder / "sequences" / LAYOUT / f"seq-{rec['id']:02d}.json", rec)
    return folder


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


def played(work, agents) -> None:
    """Each agent's results file of the sequence: named after the domain, four tasks, every task completed
    by a planner-backed agent (an 80-step greedy policy need not complete them)."""
    files = sorted(p.name for p in (work / "results").glob("blockworld-*.json"))
    assert [next((a for a in agents if a in f), None) for f in files] == sorted(agents), files
    for name in files:
        r = results(work, name)
        assert r["domain"] == "blockworld" and len(r["per_task"]) == 4
        if "rl-greedy" not in name:
            assert r["success_rate"] == 1.0, name
