"""The on-disk cache of persistent myopic rollouts (oracles.rollouts)."""

import json
import subprocess
import sys

import pytest

from oracles import rollouts
from oracles.myopic import MyopicOracle, rollout
from oracles.rollouts import RememberingOracle, cache_path, cached_rollout
from planning.errors import DomainError
from planning.world.agents import Planner, Reply


def fields(records):
    return [(r.index, r.task, r.reset_seed, r.states, r.plan, r.cost, r.success, r.auto, r.after) for r in records]


@pytest.fixture(scope="module")
def direct(two_room):
    """The first four tasks of seed 0 rolled out without a cache."""
    oracle = MyopicOracle("internal", 60.0)
    oracle.start(two_room, None)
    return list(rollout(two_room, oracle, seed=0, n_tasks=4))


def test_round_trip_gives_identical_records(two_room, direct, tmp_path):
    first = cached_rollout(two_room, 0, 4, cache_dir=tmp_path, progress=False)
    path = cache_path(two_room, 0, "internal", tmp_path)
    assert path.name == "restaurant-two-room-internal-seed0.json"
    again = cached_rollout(two_room, 0, 4, cache_dir=tmp_path, progress=False)
    assert fields(first) == fields(again) == fields(direct)
    assert [r.info for r in again] == [r.info for r in first]
    # a shorter request is served from the longer cache
    assert fields(cached_rollout(two_room, 0, 2, cache_dir=tmp_path, progress=False)) == fields(direct[:2])
    saved = json.loads(path.read_text())
    assert saved["records"][0]["plan"][0] == "pick(cup_0, countertop)"
    assert [r["cost"] for r in saved["records"]] == [650, 1875, 1300, 0]
    assert saved["records"][3]["auto"] is True


def test_extension_plans_only_the_new_tasks(two_room, direct, tmp_path, monkeypatch):
    cached_rollout(two_room, 0, 2, cache_dir=tmp_path, progress=False)
    calls = []
    plan = MyopicOracle.plan
    monkeypatch.setattr(MyopicOracle, "plan", lambda self, s, t, u: calls.append(t.name) or plan(self, s, t, u))
    extended = cached_rollout(two_room, 0, 4, cache_dir=tmp_path, progress=False)
    assert calls == ["serve-water(servingtable)"]  # task 2; task 3 is already satisfied
    assert fields(extended) == fields(direct)
    assert json.loads(cache_path(two_room, 0, "internal", tmp_path).read_text())["tasks"] == 4


def test_cache_is_saved_while_running(two_room, tmp_path, monkeypatch):
    monkeypatch.setattr(rollouts, "SAVE_EVERY_TASKS", 1)
    seen = []
    plan = MyopicOracle.plan

    def interrupted(self, s, t, u):
        if len(seen) == 2:
            raise KeyboardInterrupt
        seen.append(t.name)
        return plan(self, s, t, u)

    monkeypatch.setattr(MyopicOracle, "plan", interrupted)
    with pytest.raises(KeyboardInterrupt):
        cached_rollout(two_room, 0, 4, cache_dir=tmp_path, progress=False)
    assert json.loads(cache_path(two_room, 0, "internal", tmp_path).read_text())["tasks"] == 2


def test_corrupt_cache_is_a_one_line_error(two_room, tmp_path):
    path = cache_path(two_room, 0, "internal", tmp_path)
    path.write_text('{"format": 1, "records": [')
    with pytest.raises(DomainError, match="corrupt rollout cache") as e:
        cached_rollout(two_room, 0, 2, cache_dir=tmp_path, progress=False)
    assert str(path) in str(e.value) and "\n" not in str(e.value)


def test_mismatching_cache_names_the_record(two_room, tmp_path):
    cached_rollout(two_room, 0, 2, cache_dir=tmp_path, progress=False)
    path = cache_path(two_room, 0, "internal", tmp_path)
    data = json.loads(path.read_text())
    data["records"][1]["cost"] += 1
    path.write_text(json.dumps(data))
    with pytest.raises(DomainError, match=r"record 1 \(serve-water\(servingtable\)\) does not replay: cost"):
        cached_rollout(two_room, 0, 2, cache_dir=tmp_path, progress=False)
    data["records"][1]["cost"] -= 1
    data["records"][0]["plan"][0] = "pick(cup_0, shelf)"  # not applicable where the cup is
    path.write_text(json.dumps(data))
    with pytest.raises(DomainError, match="does not replay") as e:
        cached_rollout(two_room, 0, 2, cache_dir=tmp_path, progress=False)
    assert str(path) in str(e.value)
    data["seed"] = 1
    path.write_text(json.dumps(data))
    with pytest.raises(DomainError, match="seed 1, expected 0"):
        cached_rollout(two_room, 0, 2, cache_dir=tmp_path, progress=False)


def test_command_fails_in_one_line_on_a_corrupt_cache(tmp_path):
    (tmp_path / "restaurant-two-room-internal-seed0.json").write_text("not json")
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "oracles.rollouts",
            "--layout",
            "two-room",
            "--tasks",
            "2",
            "--cache-dir",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "corrupt rollout cache" in r.stderr


def test_a_solved_state_and_task_is_answered_from_memory(two_room, direct):
    class Counting(Planner):
        calls = 0

        def plan(self, state, task, upcoming):
            Counting.calls += 1
            return Reply(None, {"status": "unsolvable"})

    oracle = RememberingOracle(Counting())
    for r in direct:
        oracle.remember(r)
    first = direct[0]
    reply = oracle.plan(first.states[0], two_room.tasks.get(first.task), [])
    assert reply.plan == first.plan and reply.info["remembered"] and Counting.calls == 0
    assert oracle.plan(first.after, two_room.tasks.get(first.task), []).plan is None  # another world
    assert Counting.calls == 1 and len(oracle.plans) == 3  # the auto record gives no plan


class Recording(Planner):
    """The myopic oracle, noting the upcoming tasks it is shown."""

    name, config = "recording", {}

    def __init__(self):
        self.inner, self.seen = MyopicOracle("internal", 60.0), []

    def start(self, model, sequence) -> None:
        self.inner.start(model, sequence)

    def plan(self, state, task, upcoming):
        self.seen.append([t.name for t in upcoming])
        return self.inner.plan(state, task, upcoming)


def test_lookahead_shows_the_next_tasks_up_to_the_world_reset(minimal):
    from planning.world.task_stream import TaskStream

    stream = TaskStream(minimal, 3)
    drawn = [stream.next() for _ in range(8)]  # the minimal world resets every 2 tasks
    planner = Recording()
    planner.start(minimal, None)
    records = list(rollout(minimal, planner, seed=3, n_tasks=6, lookahead=2))
    planned = [r.index for r in records if not r.auto]
    want = {i: [drawn[i + 1][0].name] if drawn[i + 1][1] is None else [] for i in range(6)}
    assert planner.seen == [want[i] for i in planned] and [] in planner.seen and [want[0][0]] in planner.seen
    # and none without lookahead: the same tasks, the same plans
    again = Recording()
    again.start(minimal, None)
    plain = list(rollout(minimal, again, seed=3, n_tasks=6))
    assert all(s == [] for s in again.seen) and [r.task for r in plain] == [r.task for r in records]


def test_clairvoyant_rollout_is_cached_under_its_planner(minimal, tmp_path):
    first = cached_rollout(minimal, 0, 6, planner="clairvoyant-2", cache_dir=tmp_path, progress=False)
    path = cache_path(minimal, 0, "clairvoyant-2", tmp_path)
    assert path.is_file() and json.loads(path.read_text())["config"]["K"] == 2
    planned = [r for r in first if not r.auto]
    assert planned and all(r.info["window"][0] == r.task and len(r.info["window"]) <= 2 for r in planned)
    again = cached_rollout(minimal, 0, 6, planner="clairvoyant-2", cache_dir=tmp_path, progress=False)
    assert fields(again) == fields(first)
    with pytest.raises(DomainError, match="clairvoyant-K"):
        cached_rollout(minimal, 0, 2, planner="clairvoyant-x", cache_dir=tmp_path, progress=False)
