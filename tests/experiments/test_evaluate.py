"""The evaluation runner's accounting under the persistent-world rules, and the results JSON."""

import json
from pathlib import Path

import pytest

from experiments.random_policy import RandomPolicy
from planning.errors import DomainError
from planning.world.agents import Planner, Policy, Reply
from planning.world.runner import evaluate, play_sequence
from planning.world.sequences import Sequence, generate, load


class Oscillate(Policy):
    """Walks between countertop and shelf forever: every non-trivial task is abandoned."""

    name = "oscillate"

    def start(self, model, sequence):
        self.model = model

    def act(self, state, task):
        names = [self.model.actions[a] for a in self.model.applicable(state)]
        for n in ("move(countertop, shelf)", "move(shelf, countertop)"):
            if n in names:
                return self.model.action(n)
        return self.model.action_index[names[0]]


class Scripted(Planner):
    """Returns a fixed reply per task name."""

    name = "scripted"

    def __init__(self, replies):
        self.replies = replies

    def plan(self, state, task, upcoming):
        return self.replies[task.name]


def seq(model, names, reset_seed=5):
    return Sequence(0, reset_seed, [model.tasks.get(n) for n in names])


def optimal_cost(model, state, name) -> int:
    from planning.domain.batched import BatchedModel
    from planning.search.optimal import optimal_plan

    return optimal_plan(BatchedModel(model), state, model.tasks.get(name)).cost


def test_abandonment_and_auto_completion(two_room):
    """An abandoned task is charged what it executed plus the optimal completion from where it was left."""
    s = seq(two_room, ["serve-water(servingtable)", "pick-place(plate_0, servingtable)"])
    rows = play_sequence(two_room, Oscillate(), s)
    left = two_room.reset_state(5)  # 64 moves between countertop and shelf: back where it began
    for _ in range(64):
        left = two_room.apply(left, Oscillate.act(type("O", (), {"model": two_room})(), left, None))
    rest = optimal_cost(two_room, left, "serve-water(servingtable)")
    assert [(r["success"], r["actions"], r["cost"], r["auto"]) for r in rows] == [
        (False, 64, 64 * 25 + rest, False),
        (True, 0, 0, True),
    ]
    assert (rows[0]["executed_cost"], rows[0]["completion_cost"], rows[0]["charged_cost"]) == (
        64 * 25,
        rest,
        64 * 25 + rest,
    )
    assert "executed_cost" not in rows[1]  # a completed task's row is as it always was


def test_planner_failure_and_short_plan_fail_the_task(two_room):
    """A failed task is completed by the fallback: its optimal completion is executed, its consumption
    applied, and the next task starts where a finished task would leave the world."""
    from planning.domain.batched import BatchedModel
    from planning.search.optimal import optimal_plan

    m = two_room
    s = seq(m, ["serve-water(servingtable)", "make-coffee(servingtable)"])
    start = m.reset_state(5)
    water = m.tasks.get("serve-water(servingtable)")
    completion = optimal_plan(BatchedModel(m), start, water)
    after_water = start
    for a in completion.plan:
        after_water = m.apply(after_water, a)
    after_water = water.consume(after_water)
    first = next(a for a in m.applicable(after_water))
    agent = Scripted(
        {
            "serve-water(servingtable)": Reply(None, {"status": "out-of-time"}),
            "make-coffee(servingtable)": Reply([first]),
        }
    )
    rows = play_sequence(m, agent, s, bar=None)
    coffee = optimal_cost(m, m.apply(after_water, first), "make-coffee(servingtable)")
    step = m.action_cost[first]
    assert [(r["success"], r["executed_cost"], r["actions"]) for r in rows] == [(False, 0, 0), (False, step, 1)]
    assert [r["cost"] for r in rows] == [completion.cost, step + coffee]  # a failure never costs nothing
    assert rows[0]["status"] == "out-of-time" and rows[0]["completed_by"] == "fallback"
    assert rows[0]["completion_plan"] == [m.actions[a] for a in completion.plan]


def test_the_thesis_protocol_abandons_where_the_task_stopped(two_room):
    """--failure-protocol abandon: the executed cost only, and the world stays as the failed task left it."""
    m = two_room
    s = seq(m, ["serve-water(servingtable)", "make-coffee(servingtable)"])
    agent = Scripted(
        {
            "serve-water(servingtable)": Reply(None, {"status": "out-of-time"}),
            "make-coffee(servingtable)": Reply([m.action("pick(cup_0, countertop)")]),
        }
    )
    rows = play_sequence(m, agent, s, bar=None, protocol="abandon")
    start = m.reset_state(5)
    coffee = optimal_cost(m, m.apply(start, m.action("pick(cup_0, countertop)")), "make-coffee(servingtable)")
    assert [(r["cost"], r["completed_by"], r["completion_cost"]) for r in rows] == [
        (0, "nothing", None),
        (100, "nothing", None),
    ]
    assert coffee > 0


def test_an_agent_that_never_acts_costs_exactly_the_myopic_oracle(two_room, tmp_path, monkeypatch):
    """Every task of a planner that never plans is completed by the fallback: per task, the oracle's cost,
    and against the oracle's results file its improvement is 0.0, never positive."""
    from oracles.myopic import MyopicOracle

    monkeypatch.chdir(tmp_path)
    short_sequences(monkeypatch, 8)
    ref = tmp_path / "myopic.json"
    oracle = evaluate(two_room, MyopicOracle("internal"), [0, 1], ref, progress=False, reference=ref)
    idle = evaluate(two_room, GivesUp(), [0, 1], tmp_path / "idle.json", progress=False, reference=ref)
    assert [r["cost"] for r in idle["per_task"]] == [r["cost"] for r in oracle["per_task"]]
    assert oracle["improvement_vs_myopic"] == 0.0 and idle["improvement_vs_myopic"] == 0.0
    assert idle["success_rate"] < 1 and idle["executed_cost_per_task"] == 0.0
    # under the thesis's protocol the same agent executes nothing and claims nothing
    abandon = evaluate(
        two_room, GivesUp(), [0, 1], tmp_path / "abandon.json", progress=False, reference=ref, protocol="abandon"
    )
    assert abandon["cost_per_task"] == 0.0 and abandon["improvement_vs_myopic"] is None
    assert "not comparable" in abandon["improvement_note"]


def test_a_failed_task_never_costs_less_than_finishing_it(two_room):
    """Executed plus completion is at least the task's optimal cost from where it began (what the agent's
    executed actions earned is all an agent can gain from a failed task)."""
    s = seq(two_room, ["serve-water(servingtable)", "make-coffee(servingtable)", "wash(bowls)"])
    rows = play_sequence(two_room, Oscillate(), s)
    world = two_room.reset_state(5)
    for r, task in zip(rows, s.tasks):
        assert r["cost"] >= optimal_cost(two_room, world, task.name)
        if not r["success"]:
            assert r["cost"] == r["executed_cost"] + r["completion_cost"] and r["completed_by"] == "fallback"
        for name in [*_oscillations(two_room, world, r["actions"]), *r.get("completion_plan", [])]:
            world = two_room.apply(world, two_room.action(name))
        world = task.consume(world) if task.satisfied(world) else world


def _oscillations(model, state, n):
    agent = Oscillate()
    agent.model = model
    names = []
    for _ in range(n):
        a = agent.act(state, None)
        names.append(model.actions[a])
        state = model.apply(state, a)
    return names


def test_results_json_and_resume(two_room, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no results/ here: improvement_vs_myopic is None
    out = tmp_path / "r.json"
    import planning.world.sequences as ev

    real_load = ev.load
    monkeypatch.setattr(
        ev,
        "load",
        lambda model, ids, stream=None: [Sequence(i, 100 + i, s.tasks[:6]) for i, s in zip(ids, real_load(model, ids))],
    )
    agent = RandomPolicy(seed=1)
    first = evaluate(two_room, agent, [0, 1], out, progress=False)
    data = json.loads(out.read_text())
    assert data == first
    assert set(data) >= {
        "agent",
        "domain",
        "layout",
        "sequences",
        "tasks",
        "cost_per_task",
        "actions_per_task",
        "success_rate",
        "improvement_vs_myopic",
        "per_sequence",
        "per_task",
        "wall_seconds",
        "config",
    }
    assert data["tasks"] == 12 and data["improvement_vs_myopic"] is None
    assert data["cost_per_task"] == pytest.approx(sum(r["cost"] for r in data["per_task"]) / 12, abs=0.01)
    assert [s["tasks"] for s in data["per_sequence"]] == [6, 6]
    # A partial file from an interrupted run: sequence 0 is kept, only 1 is played again.
    partial = tmp_path / "r.json.partial.json"
    kept = [dict(r, seconds=7.0) for r in data["per_task"] if r["sequence"] == 0]  # marks the kept rows
    partial.write_text(
        json.dumps(
            {
                "agent": agent.name,
                "layout": "two-room",
                "config": agent.config,
                "failure_protocol": "fallback",
                "wall_seconds": 1.0,
                "done": {"0": kept},
            }
        )
    )
    resumed = evaluate(two_room, RandomPolicy(seed=1), [0, 1], out, progress=False)
    assert [r["seconds"] for r in resumed["per_task"][:6]] == [7.0] * 6 and not partial.exists()


def test_a_finished_run_is_extended_not_replayed(two_room, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "r.json"
    import planning.world.sequences as ev

    real_load = ev.load
    monkeypatch.setattr(
        ev,
        "load",
        lambda model, ids, stream=None: [Sequence(i, 100 + i, s.tasks[:4]) for i, s in zip(ids, real_load(model, ids))],
    )
    evaluate(two_room, RandomPolicy(seed=1), [0], out, progress=False)
    data = json.loads(out.read_text())
    for r in data["per_task"]:
        r["seconds"] = 7.0  # marks the rows of the finished run
    out.write_text(json.dumps(data))
    both = evaluate(two_room, RandomPolicy(seed=1), [0, 1], out, progress=False)
    assert both["sequences"] == [0, 1] and both["tasks"] == 8
    assert [r["seconds"] for r in both["per_task"] if r["sequence"] == 0] == [7.0] * 4
    # Asking again for sequences it holds plays nothing and leaves the file, provenance included, as it was
    # (experiments.select_beta reuses the ten-sequence run for its development sequences this way).
    before = out.read_text()
    again = evaluate(two_room, RandomPolicy(seed=1), [1], out, progress=False)
    assert out.read_text() == before and again == json.loads(before)
    # Another configuration's finished results are never replaced silently ...
    before = out.read_text()
    with pytest.raises(DomainError, match=r"r\.json: a finished run with seed 1, not 2; pass --force"):
        evaluate(two_room, RandomPolicy(seed=2), [0], out, progress=False)
    assert out.read_text() == before
    # ... nor reused: with force it is played anew and replaced.
    other = evaluate(two_room, RandomPolicy(seed=2), [0], out, progress=False, force=True)
    assert [r["cost"] for r in other["per_task"]] != [7] * 4


def test_corrupt_partial_file_is_a_one_line_error(two_room, tmp_path):
    out = tmp_path / "r.json"
    (tmp_path / "r.json.partial.json").write_text("{not json")
    with pytest.raises(DomainError, match="corrupt partial results"):
        evaluate(two_room, RandomPolicy(), [0], out, progress=False)


def test_canonical_sequences_regenerate(restaurant):
    stored = load(restaurant)
    assert [s.id for s in stored] == list(range(10))
    for rec, s in zip(generate(restaurant), stored):
        assert rec["tasks"] == [t.name for t in s.tasks] and rec["reset_seed"] == s.reset_seed
        assert len(s.tasks) == 50
    on_disk = json.loads((restaurant.folder / "sequences" / restaurant.layout / "seq-03.json").read_text())
    assert on_disk == generate(restaurant)[3] and on_disk["split"] == "development"


class GivesUp(Planner):
    """Never finds a plan: every task not already satisfied fails with the given status."""

    name = "gives-up"

    def __init__(self, status="out-of-time"):
        self.status = status

    def plan(self, state, task, upcoming):
        return Reply(None, {"status": self.status})


def short_sequences(monkeypatch, n):
    import planning.world.sequences as ev

    real_load = ev.load
    monkeypatch.setattr(
        ev,
        "load",
        lambda model, ids, stream=None: [Sequence(i, 100 + i, s.tasks[:n]) for i, s in zip(ids, real_load(model, ids))],
    )


def test_failures_are_charged_and_a_planner_fault_warns(two_room, tmp_path, monkeypatch, capsys):
    """An agent that plans nothing is charged every task's optimal cost: never cheaper than doing them."""
    monkeypatch.chdir(tmp_path)
    short_sequences(monkeypatch, 5)
    out = tmp_path / "r.json"
    r = evaluate(two_room, GivesUp(), [0], out, progress=False)
    failed = [x for x in r["per_task"] if not x["success"]]
    assert failed and all(
        x["executed_cost"] == 0 and x["cost"] == x["charged_cost"] == x["completion_cost"] > 0 for x in failed
    )
    assert r["cost_per_task"] > 0
    assert r["cost_per_task"] == pytest.approx(sum(x["cost"] for x in r["per_task"]) / 5, abs=0.01)
    assert r["executed_cost_per_task"] == 0.0 and r["planner_faults"] == len(failed)
    assert "charged" in r["failure_accounting"]
    assert r["per_sequence"][0]["cost"] == sum(x["cost"] for x in r["per_task"])
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith(f"warning: {len(failed)} of 5 tasks ended in a planner timeout")
    # --strict: the results are written, then the run is an error naming the first fault
    out.unlink()
    with pytest.raises(DomainError, match=r"--strict: \d+ of 5 tasks .* sequence 0 task \d+"):
        evaluate(two_room, GivesUp("crashed"), [0], out, progress=False, strict=True)
    assert json.loads(out.read_text())["planner_faults"] == len(failed)
    # ... and so is asking again for what that finished file holds, which plays nothing and leaves it as it was
    before = out.read_text()
    with pytest.raises(DomainError, match=r"--strict: \d+ of 5 tasks .* sequence 0 task \d+"):
        evaluate(two_room, GivesUp("crashed"), [0], out, progress=False, strict=True)
    assert out.read_text() == before
    # an unsolvable verdict is a failure (charged) but not a planner fault
    out.unlink()
    r = evaluate(two_room, GivesUp("unsolvable"), [0], out, progress=False, strict=True)
    assert r["planner_faults"] == 0


def test_rows_written_under_another_failure_protocol_are_refused_then_played_again(two_room, tmp_path, monkeypatch):
    """A file whose failed tasks were charged without moving the world (written before the fallback was
    executed) is a finished run made otherwise: an error naming the protocol; --force plays it again."""
    monkeypatch.chdir(tmp_path)
    short_sequences(monkeypatch, 5)
    out = tmp_path / "r.json"
    r = evaluate(two_room, GivesUp(), [0, 1], out, progress=False)
    data = json.loads(out.read_text())
    del data["failure_protocol"]
    for x in data["per_task"]:  # as the old runner wrote them: charged, the world left as it was
        x.pop("completed_by", None)
        x.pop("completion_plan", None)
    out.write_text(json.dumps(data))
    with pytest.raises(DomainError, match=r"failure protocol 'charged .*', not 'fallback'; pass --force"):
        evaluate(two_room, GivesUp(), [0, 1], out, progress=False)
    again = evaluate(two_room, GivesUp(), [0, 1], out, progress=False, force=True)
    assert [x["cost"] for x in again["per_task"]] == [x["cost"] for x in r["per_task"]]
    assert again.played == [0, 1] and json.loads(out.read_text())["failure_protocol"] == "fallback"


def test_a_sequence_cut_short_in_a_saved_file_is_refused(two_room, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    short_sequences(monkeypatch, 5)
    out = tmp_path / "r.json"
    evaluate(two_room, GivesUp(), [0], out, progress=False)
    data = json.loads(out.read_text())
    partial = tmp_path / "r.json.partial.json"
    partial.write_text(
        json.dumps(
            {
                "agent": "gives-up",
                "layout": "two-room",
                "config": {},
                "failure_protocol": "fallback",
                "done": {"0": data["per_task"][:3]},
            }
        )
    )
    before = out.read_text()
    with pytest.raises(DomainError, match=r"partial results, sequence 0: 3 rows for its 5 tasks"):
        evaluate(two_room, GivesUp(), [0], out, progress=False)
    assert out.read_text() == before


def run_killed_and_resumed(cmd, watch, kills=2, cwd=None):
    """Run `cmd`, SIGKILL it each time `watch` (a progress file) has newly changed, `kills` times, then
    let a last run finish. Returns the last run's exit status; each killed run must have died of the kill."""
    import os
    import signal
    import subprocess
    import sys
    import time

    seen = None
    for _ in range(kills):
        p = subprocess.Popen([sys.executable, *cmd], cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        while p.poll() is None:
            stamp = watch.stat().st_mtime_ns if watch.exists() else None
            if stamp is not None and stamp != seen:
                seen = stamp  # a piece of work was saved; the next has begun
                os.kill(p.pid, signal.SIGKILL)
                break
            time.sleep(0.005)  # well within the ~25 ms a short sequence takes
        assert p.wait() == -signal.SIGKILL, "the run ended before it could be killed"
    return subprocess.run([sys.executable, *cmd], cwd=cwd, capture_output=True).returncode


def test_no_progress_leaves_the_log_without_bars(tmp_path):
    """--no-progress (every evaluation command has it, for background runs): no progress bar on stderr; without
    it the bar is there."""
    import shutil
    import subprocess
    import sys

    from planning.atomic import write_json
    from planning.domain.compiler import compile_domain
    from planning.world.sequences import generate

    domain = tmp_path / "minimal"  # the smallest domain: the test is about the bar, not the planner
    shutil.copytree("domains/minimal", domain)
    for rec in generate(compile_domain(domain, "grid"), count=1, length=3):
        write_json(domain / "sequences" / "grid" / f"seq-{rec['id']:02d}.json", rec)
    cmd = lambda out, *extra: [
        sys.executable,
        "-m",
        "experiments.evaluate",
        "--agent",
        "myopic-oracle",
        "--planner",
        "internal",
        "--domain",
        str(domain),
        "--sequences",
        "0",
        "--out",
        str(tmp_path / out),
        *extra,
    ]
    quiet = subprocess.run(cmd("quiet.json", "--no-progress"), capture_output=True, text=True)
    loud = subprocess.run(cmd("loud.json"), capture_output=True, text=True)
    assert quiet.returncode == loud.returncode == 0
    assert "task/s" not in quiet.stderr and "task/s" in loud.stderr
    assert (
        json.loads((tmp_path / "quiet.json").read_text())["cost_per_task"]
        == json.loads((tmp_path / "loud.json").read_text())["cost_per_task"]
    )


def test_a_run_killed_and_rerun_gives_the_uninterrupted_results(tmp_path):
    """SIGKILL mid-run (twice), rerun: the results are those of one uninterrupted run (timings aside).
    Ten sequences, so that a killed run has several left after the piece that triggered its kill."""
    import shutil
    import subprocess
    import sys

    domain = tmp_path / "restaurant"
    shutil.copytree("domains/restaurant", domain)
    for path in (domain / "sequences" / "two-room").glob("seq-*.json"):  # short sequences: a quick test
        rec = json.loads(path.read_text())
        path.write_text(json.dumps({**rec, "tasks": rec["tasks"][:6]}))
    cmd = lambda out: [
        "-m",
        "experiments.evaluate",
        "--agent",
        "myopic-oracle",
        "--planner",
        "internal",
        "--domain",
        str(domain),
        "--layout",
        "two-room",
        "--sequences",
        "0-9",
        "--out",
        str(out),
    ]
    whole, resumed = tmp_path / "whole.json", tmp_path / "resumed.json"
    assert subprocess.run([sys.executable, *cmd(whole)], capture_output=True).returncode == 0
    assert run_killed_and_resumed(cmd(resumed), Path(f"{resumed}.partial.json")) == 0
    timing = ("seconds", "wall_seconds", "provenance")  # provenance names the command and the date
    strip = lambda r: {
        k: ([{k2: v2 for k2, v2 in x.items() if k2 not in timing} for x in v] if k == "per_task" else v)
        for k, v in r.items()
        if k not in timing
    }
    assert strip(json.loads(resumed.read_text())) == strip(json.loads(whole.read_text()))
    assert not Path(f"{resumed}.partial.json").exists()


def test_a_fast_downward_crash_is_a_warning_line_not_only_json(two_room, tmp_path, monkeypatch, capsys):
    """A SIGSEGV of the planner child: the row keeps Fast Downward's message and the run warns in one line."""
    from oracles import myopic
    from planning.external.fast_downward import PlanResult, Status

    monkeypatch.chdir(tmp_path)
    short_sequences(monkeypatch, 3)
    monkeypatch.setattr(
        myopic.fd,
        "solve",
        lambda model, state, task, time_limit: PlanResult(
            Status.CRASHED, message="INTERNAL_ERROR planner exited with -11 (SIGSEGV)"
        ),
    )
    r = evaluate(two_room, myopic.MyopicOracle(), [0], tmp_path / "r.json", progress=False)
    crashed = [x for x in r["per_task"] if x.get("status") == "crashed"]
    assert crashed and crashed[0]["message"].endswith("(SIGSEGV)") and crashed[0]["cost"] > 0
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "crashed (INTERNAL_ERROR planner exited with -11 (SIGSEGV))" in err
