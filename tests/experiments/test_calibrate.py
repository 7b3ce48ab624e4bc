"""Reward calibration (thesis §5.2.4): D of a plan, R_goal = (1 + m) D_max, where the trainer finds R_goal."""

import json
import subprocess
import sys

import pytest

from experiments.calibrate import calibrate, discounted_requirement
from learning.reward import calibration_path, goal_reward
from oracles.myopic import TaskRecord
from planning.errors import DomainError


def test_d_of_a_hand_made_plan():
    costs = [100, 225, 1000, 50, 100]  # PDDL units; c_RL = c_PDDL / 100
    g = 0.95
    by_hand = 1 / g**4 + 2.25 / g**3 + 10 / g**2 + 0.5 / g + 1
    d = discounted_requirement(costs, g, cost_scale=100)
    assert d == pytest.approx(by_hand)
    assert d == pytest.approx(16.458675, abs=1e-6)
    assert discounted_requirement([300], g, 100) == 3.0  # a one-step plan is not discounted
    assert discounted_requirement(costs, 1.0, 100) == pytest.approx(14.75)
    assert discounted_requirement([], g) == 0.0


def record(model, i, task, names, success=True, auto=False):
    plan = [model.action(n) for n in names]
    return TaskRecord(i, task, None, [], plan, sum(model.action_cost[a] for a in plan), success, auto, -1)


def test_r_goal_is_1_2_d_max_of_completed_plans(two_room):
    cheap = ["pick(cup_0, countertop)"]
    dear = ["pick(cup_0, countertop)", "move(countertop, coffeemachine)", "place(cup_0, coffeemachine)"]
    records = [
        record(two_room, 0, "wash(bowls)", cheap),
        record(two_room, 1, "make-coffee(servingtable)", dear),
        record(two_room, 2, "wash(knives)", [], auto=True),
        record(two_room, 3, "clear(servingtable)", dear * 3, success=False),
    ]  # failed: no completion
    r = calibrate(two_room, records, gamma=0.95, margin=0.2)
    costs = [two_room.action_cost[two_room.action(n)] for n in dear]
    d_max = discounted_requirement(costs, 0.95, 100)
    assert r["d_max"] == pytest.approx(d_max, abs=1e-4)
    assert r["r_goal"] == pytest.approx(1.2 * d_max, abs=1e-4)
    assert (r["argmax"]["index"], r["argmax"]["plan"]) == (1, dear)
    assert (r["tasks"], r["completed_plans"], r["auto"], r["failures"]) == (4, 2, 1, 1)
    assert r["thesis"] == {"d_max": 67.56, "r_goal": 81.07}
    assert calibrate(two_room, records, 0.95, 0.5)["r_goal"] == pytest.approx(1.5 * d_max, abs=1e-4)


def test_goal_reward_lookup_order(minimal, two_room, tmp_path):
    assert goal_reward(minimal, tmp_path) == 10.0  # the domain sets it: no file needed
    with pytest.raises(DomainError, match="python -m experiments.calibrate --domain .* --layout two-room"):
        goal_reward(two_room, tmp_path)
    path = calibration_path(two_room, tmp_path)
    path.write_text(json.dumps({"domain": "restaurant", "layout": "two-room", "r_goal": 42.5}))
    assert goal_reward(two_room, tmp_path) == 42.5
    path.write_text(json.dumps({"domain": "other", "layout": "two-room", "r_goal": 42.5}))
    with pytest.raises(DomainError, match="calibrates other two-room"):
        goal_reward(two_room, tmp_path)
    path.write_text("{")
    with pytest.raises(DomainError, match="unreadable calibration"):
        goal_reward(two_room, tmp_path)


def test_command_on_a_short_rollout(tmp_path):
    out = tmp_path / "cal.json"
    cmd = [
        sys.executable,
        "-m",
        "experiments.calibrate",
        "--layout",
        "two-room",
        "--tasks",
        "4",
        "--cache-dir",
        str(tmp_path),
        "--out",
        str(out),
    ]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "thesis: 81.07" in r.stdout and "satisficing" in r.stdout
    res = json.loads(out.read_text())
    # seed 0: make-coffee 650, serve-water 1875, serve-water 1300, an already clean knife
    assert (res["tasks"], res["completed_plans"], res["auto"]) == (4, 3, 1)
    assert res["argmax"]["task"] == "serve-water(servingtable)" and res["argmax"]["cost"] == 1875
    assert res["r_goal"] == pytest.approx(1.2 * res["d_max"], abs=1e-3)
    bad = subprocess.run(cmd[:-2] + ["--gamma", "1.5"], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "--gamma" in bad.stderr


def test_committed_calibrations_are_consistent(restaurant):
    """results/calibration-<layout>.json: 2,000 tasks, R_goal = 1.2 D_max, D_max recomputed from its plan."""
    res = json.loads(calibration_path(restaurant).read_text())
    assert (res["layout"], res["tasks"], res["gamma"], res["margin"]) == (restaurant.layout, 2000, 0.95, 0.2)
    a = res["argmax"]
    assert a["costs"] == [restaurant.action_cost[restaurant.action(n)] for n in a["plan"]]
    assert discounted_requirement(a["costs"], 0.95, 100) == pytest.approx(res["d_max"], abs=1e-3)
    assert res["r_goal"] == pytest.approx(1.2 * res["d_max"], abs=1e-3)
    assert goal_reward(restaurant) == res["r_goal"]
    assert max(res["d_max_by_type"].values()) == res["d_max"]
