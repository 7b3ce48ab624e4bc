"""Timeouts and unsolvable tasks are reported as such, never as crashes."""

from oracles.myopic import MyopicOracle
from planning.domain.batched import BatchedModel
from planning.external import fast_downward as fd
from planning.search.optimal import optimal_plan

HARD = [
    "(robot-at servingtable)",
    "(hand-free)",
    "(at cup_0 servingtable)",
    "(dirty cup_0)",
    "(at cup_1 fountain)",
    "(dirty cup_1)",
    "(at water_fountain fountain)",
    "(at apple_0 countertop)",
    "(at bowl_0 countertop)",
    "(at knife_0 countertop)",
    "(at jar_0 shelf)",
    "(at plate_0 servingtable)",
]


def test_fast_downward_time_limit_is_out_of_time(two_room):
    s = two_room.state_from_atoms(HARD)  # make-coffee needs wash, fill, pour, brew: 11M states blind
    r = fd.solve(two_room, s, two_room.tasks.get("make-coffee(servingtable)"), time_limit=1)
    assert r.status == fd.Status.OUT_OF_TIME and r.plan == []


def test_internal_planner_limits_and_unsolvable(two_room, minimal):
    s = two_room.state_from_atoms(HARD)
    task = two_room.tasks.get("make-coffee(servingtable)")
    r = optimal_plan(BatchedModel(two_room), s, task, time_limit=0.05, heuristic="hmax")
    assert r.plan is None and not r.complete  # h_max needs thousands of states here
    r = optimal_plan(BatchedModel(two_room), s, task)  # the pattern databases see it at once
    assert r.cost == 2850 and r.expansions < 100
    oracle = MyopicOracle("internal", time_limit=30)
    oracle.start(minimal, None)
    reply = oracle.plan(minimal.state_from_atoms(["(robot-at x1y1)"]), minimal.tasks.get("deliver(a)"), [])
    assert reply.plan is None and reply.info["status"] == "unsolvable"


def test_oracle_planners_agree_on_a_canonical_sample(two_room):
    from oracles.planner_bench import planner_pairs

    fd_oracle, ours = MyopicOracle("fast-downward", 120), MyopicOracle("internal", 120)
    for o in (fd_oracle, ours):
        o.start(two_room, None)
    for state, task in planner_pairs(two_room, 1, 6):
        a, b = fd_oracle.plan(state, task, []), ours.plan(state, task, [])
        assert a.info["planner_cost"] == b.info["planner_cost"] is not None
