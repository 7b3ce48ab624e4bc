"""planning.world.validate: results files replayed by unified-planning, on a domain other than the restaurant
and on the restaurant; every kind of row (a plan, an already satisfied task, a failed task under each protocol)
and every kind of disagreement it must catch."""

import copy
import json
import subprocess
import sys

import pytest

from experiments.random_policy import RandomPolicy
from planning.domain.identity import identity
from planning.world.runner import play_sequence
from planning.world.sequences import load
from planning.world.validate import validate

COMMITTED = "results/blockworld-clairvoyant-2-grid7x7.json"


@pytest.fixture(scope="module")
def grid7():
    from planning.domain.compiler import compile_domain

    return compile_domain("domains/blockworld", "grid7x7")


def results_of(model, rows, seq) -> dict:
    """The parts of a results file the validator reads."""
    return {
        **identity(model),
        "layout": model.layout,
        "config": {},
        "per_task": rows,
        "per_sequence": [{"id": seq.id, "reset_seed": seq.reset_seed, "cost": sum(r["cost"] for r in rows)}],
    }


@pytest.fixture(scope="module")
def committed():
    return json.loads(open(COMMITTED).read())


def check(tmp_path, data, name="r.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return validate(path)


def test_committed_files_replay_under_unified_planning():
    assert validate(COMMITTED)[:2] == ("ok", 500)
    verdict, tasks, why = validate("results/myopic-oracle-two-room.json")
    assert (verdict, tasks) == ("ok", 500) and why.endswith("actions, costs and goals agree")


@pytest.mark.parametrize("protocol", ["fallback", "abandon"])
def test_failed_tasks_replay_under_either_protocol(grid7, tmp_path, protocol):
    """A random policy fails most blockworld tasks: each failure's executed actions, and under the fallback its
    completion, are replayed."""
    (seq,) = load(grid7, [0])
    seq = type(seq)(seq.id, seq.reset_seed, seq.tasks[:6])
    rows = play_sequence(grid7, RandomPolicy(0), seq, protocol=protocol)
    assert sum(not r["success"] for r in rows) >= 3
    assert check(tmp_path, results_of(grid7, rows, seq))[:2] == ("ok", 6)
    failed = next(r for r in rows if not r["success"])
    if protocol == "fallback":
        failed["completion_cost"] += 25
        assert check(tmp_path, results_of(grid7, rows, seq))[2].endswith(
            f"the completion costs {failed['completion_cost'] - 25} and reaches the goal True"
        )
    else:
        failed["success"] = True
        assert "the row says success True, the goal holds never" in check(tmp_path, results_of(grid7, rows, seq))[2]


def test_every_disagreement_is_caught(committed, tmp_path):
    rows = committed["per_task"]
    k = next(i for i, r in enumerate(rows) if not r["auto"] and len(r["plan"]) > 2)
    row = rows[k]
    where = f"sequence {row['sequence']} task {row['index']} {row['task']}"

    def tampered(change):
        data = copy.deepcopy(committed)
        change(data["per_task"][k], data)
        return check(tmp_path, data)

    def swap(r, d):  # the first two actions in the other order: the second is not applicable first
        r["plan"][0], r["plan"][1] = r["plan"][1], r["plan"][0]

    verdict, _, why = tampered(swap)
    assert verdict == "disagrees" and why.startswith(
        f"{where}: {row['plan'][1]}: not applicable under unified-planning"
    )
    why = tampered(lambda r, d: r.update(cost=r["cost"] - 100))[2]
    assert (
        why
        == f"{where}: the plan costs {row['cost']} in {row['actions']} actions, the row says {row['cost'] - 100} in {row['actions']}"
    )
    why = tampered(lambda r, d: r["plan"].pop())[2]
    assert why.startswith(f"{where}: the plan costs")
    why = tampered(lambda r, d: d["per_sequence"][row["sequence"]].update(cost=1))[2]
    assert why.startswith(f"sequence {row['sequence']}: the rows cost") and why.endswith("the sequence records 1")
    why = tampered(lambda r, d: d["per_sequence"][row["sequence"]].update(reset_seed=7))[2]
    assert why.startswith("reset seed 7, the sequence's is")
    why = tampered(lambda r, d: r.update(auto=True))[2]
    assert why == f"{where}: recorded as already satisfied, but its goal does not hold when drawn"
    assert tampered(lambda r, d: r.pop("plan")) == (
        "skipped",
        0,
        "records no plans (written before results kept them): rerun its command with --force",
    )
    verdict, _, why = tampered(lambda r, d: d.update(domain_sha256="0" * 64))
    assert verdict == "skipped" and why.startswith("made with other content of domain 'blockworld'")


def test_the_command_exits_1_on_a_disagreement(committed, tmp_path):
    data = copy.deepcopy(committed)
    data["per_sequence"][0]["cost"] += 1
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    r = subprocess.run(
        [sys.executable, "-m", "planning.world.validate", COMMITTED, str(bad)], capture_output=True, text=True
    )
    assert r.returncode == 1
    lines = r.stdout.splitlines()
    assert lines[0] == f"{COMMITTED}: ok: 500 tasks of 10 sequences replayed: actions, costs and goals agree"
    assert lines[1].startswith(f"{bad}: disagrees: sequence 0: the rows cost")


@pytest.mark.slow
def test_every_committed_results_file_replays():
    """Every results file under results/ that records played sequences replays (about 8 minutes)."""
    from pathlib import Path

    validators, verdicts = {}, {}
    for path in sorted(Path("results").glob("*.json")):
        verdict, _, why = validate(path, validators=validators)
        if why != "not a results file of played sequences":
            verdicts[path.name] = (verdict, why)
    assert len(verdicts) >= 200
    assert {name: v for name, v in verdicts.items() if v[0] != "ok"} == {}
