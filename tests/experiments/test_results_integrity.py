"""Results that cannot mislead: reruns report what they ran, results are tied to their domain's content,
and an improvement is measured only against a reference that played the same tasks."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from experiments.random_policy import RandomPolicy
from oracles.command import figures, what_ran
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.world.agents import Planner, Reply
from planning.world.results import default_out
from planning.world.runner import evaluate
from planning.world.sequences import Sequence

ROOT = Path(__file__).resolve().parents[2]


def cli(*argv, timeout=600):
    return subprocess.run([sys.executable, "-m", *argv], capture_output=True, text=True, cwd=ROOT, timeout=timeout)


class Never(Planner):
    """Never plans: every task is completed by the fallback."""

    name = "never"

    def plan(self, state, task, upcoming):
        return Reply(None, {"status": "out-of-time"})


def short(monkeypatch, n):
    import planning.world.sequences as ev

    real = ev.load
    monkeypatch.setattr(
        ev,
        "load",
        lambda model, ids, stream=None: [Sequence(i, s.reset_seed, s.tasks[:n]) for i, s in zip(ids, real(model, ids))],
    )


def test_a_rerun_prints_the_figures_of_the_sequences_asked_for(two_room, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    short(monkeypatch, 4)
    out = tmp_path / "r.json"
    both = evaluate(two_room, RandomPolicy(seed=1), [0, 1], out, progress=False)
    assert both.played == [0, 1] and both.wrote and "played sequences 0-1" in what_ran(both)
    again = evaluate(two_room, RandomPolicy(seed=1), [0], out, progress=False)
    seq0 = [r["cost"] for r in both["per_task"] if r["sequence"] == 0]
    assert again.asked["cost_per_task"] == round(sum(seq0) / 4, 2) != both["cost_per_task"]
    assert again.asked["sequences"] == [0] and again.played == [] and not again.wrote
    assert what_ran(again).startswith("nothing played") and "the file's runs took" in what_ran(again)
    assert f"cost per task {again.asked['cost_per_task']}," in figures(again)


def test_committed_clairvoyant_rerun_of_one_sequence_prints_that_sequence():
    """The design card's command and a one-sequence rerun over committed files: kept, and the figure is
    sequence 0's own (930.5), not the ten-sequence mean (972.6)."""
    r = cli("oracles.clairvoyant", "--K", "3", "--layout", "three-room", "--sequences", "0", "--no-progress")
    assert r.returncode == 0, r.stderr[-1500:]
    assert "cost per task 930.5," in r.stdout and "nothing played" in r.stdout and "wrote" not in r.stdout
    card = cli("oracles.clairvoyant", "--K", "3", "--no-progress")  # two-room, the default 60 s
    assert card.returncode == 0, card.stderr[-1500:]
    assert "cost per task 850.8," in card.stdout and "nothing played" in card.stdout


def test_the_myopic_oracle_out_of_time_everywhere_costs_the_oracle(tmp_path):
    """--time-limit 0.001 times out on nearly every task: the fallback completes each one, so the run costs
    exactly what the internal myopic oracle costs on that sequence, and claims no improvement."""
    out = tmp_path / "m.json"
    r = cli(
        "oracles.myopic",
        "--planner",
        "internal",
        "--layout",
        "two-room",
        "--sequences",
        "0",
        "--time-limit",
        "0.001",
        "--out",
        str(out),
        "--no-progress",
    )
    assert r.returncode == 0, r.stderr[-1500:]
    ran = json.loads(out.read_text())
    oracle = json.loads((ROOT / "results/myopic-oracle-internal-two-room.json").read_text())
    assert [x["cost"] for x in ran["per_task"]] == [x["cost"] for x in oracle["per_task"] if x["sequence"] == 0]
    assert ran["success_rate"] < 0.5 and ran["improvement_vs_myopic"] <= 0
    assert "timeout" in r.stderr and r.stderr.count("\n") == 1


@pytest.fixture
def copy_of_restaurant(tmp_path):
    folder = tmp_path / "restaurant-copy"
    shutil.copytree(ROOT / "domains" / "restaurant", folder)
    return folder


def test_a_rerun_after_a_pddl_edit_stops_naming_the_file(copy_of_restaurant, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    short(monkeypatch, 3)
    model = compile_domain(copy_of_restaurant, "two-room")
    out = tmp_path / "r.json"
    first = evaluate(model, Never(), [0], out, progress=False)
    problem = copy_of_restaurant / "two-room.pddl"
    problem.write_text(
        problem.read_text().replace("(= (move-cost shelf fountain) 200)", "(= (move-cost shelf fountain) 300)")
    )
    edited = compile_domain(copy_of_restaurant, "two-room")
    with pytest.raises(DomainError, match=r"other content of domain 'restaurant' \(changed: two-room.pddl\)"):
        evaluate(edited, Never(), [0, 1], out, progress=False)
    replayed = evaluate(edited, Never(), [0, 1], out, progress=False, force=True)
    assert replayed.played == [0, 1] and replayed["domain_sha256"] != first["domain_sha256"]
    assert replayed["domain_files"]["two-room.pddl"] != first["domain_files"]["two-room.pddl"]
    assert replayed["domain_files"]["domain.pddl"] == first["domain_files"]["domain.pddl"]


def test_a_domain_is_named_by_its_define_and_other_domains_get_their_own_file_names(tmp_path):
    folder = tmp_path / "my-grid"
    shutil.copytree(ROOT / "domains" / "minimal", folder)
    model = compile_domain(folder, "grid")
    assert model.name == "minimal"
    agent = RandomPolicy(seed=0)
    assert default_out(agent, model) == "results/minimal-random-seed0-grid.json"
    from learning.reward import calibration_path

    assert str(calibration_path(model)) == "results/calibration-minimal-grid.json"
    restaurant = compile_domain(ROOT / "domains" / "restaurant", "two-room")
    assert default_out(agent, restaurant) == "results/random-seed0-two-room.json"  # committed names stay


def test_improvement_only_against_a_reference_that_played_the_same_tasks(copy_of_restaurant, tmp_path, monkeypatch):
    """A copy of the restaurant whose sequence 0 holds other tasks: the committed reference played
    other tasks, so no improvement is claimed, and the note says where they differ."""
    seq0 = copy_of_restaurant / "sequences" / "two-room" / "seq-00.json"
    rec = json.loads(seq0.read_text())
    rec["tasks"] = rec["tasks"][::-1]
    seq0.write_text(json.dumps(rec))
    monkeypatch.chdir(tmp_path)
    model = compile_domain(copy_of_restaurant, "two-room")
    ref = ROOT / "results" / "myopic-oracle-two-room.json"
    r = evaluate(model, RandomPolicy(seed=1), [0], tmp_path / "r.json", progress=False, reference=ref)
    assert r["improvement_vs_myopic"] is None
    first = next(k for k, (a, b) in enumerate(zip(rec["tasks"], rec["tasks"][::-1])) if a != b)
    assert r["improvement_note"] == f"the reference {ref} played other tasks in sequence 0 (from task {first} on)"
    # the same tasks from another world reset are not comparable either
    rec["tasks"] = rec["tasks"][::-1]
    rec["reset_seed"] += 1
    seq0.write_text(json.dumps(rec))
    model = compile_domain(copy_of_restaurant, "two-room")
    r = evaluate(model, RandomPolicy(seed=1), [0], tmp_path / "s.json", progress=False, reference=ref)
    assert r["improvement_note"] == f"the reference {ref} played sequence 0 from another world reset"


def test_a_tampered_saved_row_is_refused_on_resume(two_room, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    short(monkeypatch, 4)
    out = tmp_path / "r.json"
    evaluate(two_room, Never(), [0], out, progress=False)
    data = json.loads(out.read_text())
    data["per_task"][1]["cost"] = -99999
    out.write_text(json.dumps(data))
    with pytest.raises(DomainError, match=r"corrupt results, sequence 0: row 1 .*negative cost"):
        evaluate(two_room, Never(), [0, 1], out, progress=False)
    data["per_task"][1]["cost"] = data["per_task"][1]["charged_cost"] - 1
    out.write_text(json.dumps(data))
    with pytest.raises(DomainError, match=r"row 1 .*charged cost is not its executed cost plus its completion"):
        evaluate(two_room, Never(), [0, 1], out, progress=False)


def test_two_writers_of_one_results_file(two_room, tmp_path, monkeypatch):
    """While one process writes OUT, a second stops at once with one line (the file holds one run)."""
    from planning.atomic import OutputLock

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "r.json"
    script = (
        "import sys, time; sys.path.insert(0, sys.argv[1]); from planning.atomic import OutputLock\n"
        "with OutputLock(sys.argv[2]):\n    print('held', flush=True); time.sleep(30)\n"
    )
    holder = subprocess.Popen([sys.executable, "-c", script, str(ROOT), str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(DomainError, match="another process is writing this results file"):
            evaluate(two_room, Never(), [0], out, progress=False)
    finally:
        holder.kill()
        holder.wait()
    with OutputLock(out):  # the lock went with the process that held it
        pass


def test_provenance_says_which_run_played_each_sequence(two_room, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    short(monkeypatch, 3)
    out = tmp_path / "r.json"
    evaluate(two_room, Never(), [0], out, progress=False)
    data = json.loads(out.read_text())
    data["provenance"]["sequences"]["0"] = {"commit": "earlier", "date_utc": "2026-01-01T00:00:00Z"}
    out.write_text(json.dumps(data))
    both = evaluate(two_room, Never(), [0, 1], out, progress=False)
    prov = both["provenance"]
    assert prov["played_in_this_process"] == [1]
    assert prov["sequences"]["0"]["commit"] == "earlier" and prov["sequences"]["1"]["commit"] == prov["commit"]


def test_the_digest_follows_the_world_not_comments_or_tool_settings(copy_of_restaurant):
    from planning.domain.identity import identity

    def digest():
        return identity(compile_domain(copy_of_restaurant, "two-room"))

    first = digest()
    toml = copy_of_restaurant / "domain.toml"
    toml.write_text("# a comment\n" + toml.read_text().replace("depth_cap = 20", "depth_cap = 30"))
    assert digest() == first  # a comment and a [search] default: the same world
    (copy_of_restaurant / "three-room.pddl").write_text("; another layout's problem is not part of two-room\n")
    assert digest() == first
    toml.write_text(toml.read_text().replace("[tasks.wash]\nprobability = 0.30", "[tasks.wash]\nprobability = 0.31"))
    changed = digest()
    assert changed["domain_sha256"] != first["domain_sha256"]
    assert [n for n in changed["domain_files"] if changed["domain_files"][n] != first["domain_files"][n]] == [
        "domain.toml"
    ]


def test_a_run_under_the_thesis_protocol_gets_its_own_default_file(two_room):
    agent = RandomPolicy(seed=0)
    assert default_out(agent, two_room) == "results/random-seed0-two-room.json"
    assert default_out(agent, two_room, protocol="abandon") == "results/random-seed0-two-room-abandon.json"
