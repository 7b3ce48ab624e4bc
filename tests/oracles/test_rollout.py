"""The persistent myopic rollout shared by calibration, demonstrations and dataset generation."""

from oracles.myopic import MyopicOracle, rollout
from planning.world.task_stream import TaskStream


def test_rollout_follows_the_stream_and_resumes(two_room):
    oracle = MyopicOracle("internal", 60.0)
    oracle.start(two_room, None)
    records = list(rollout(two_room, oracle, seed=0, n_tasks=6))
    stream = TaskStream(two_room, 0)
    assert [r.task for r in records] == [stream.next()[0].name for _ in range(6)]
    assert records[0].reset_seed is not None and all(r.reset_seed is None for r in records[1:])
    for prev, r in zip(records, records[1:]):
        assert r.states[0] == prev.after  # the world persists between tasks
    for r in records:
        assert len(r.states) == len(r.plan) + 1
        assert r.cost == sum(two_room.action_cost[a] for a in r.plan)
        assert r.success and two_room.tasks.get(r.task).satisfied(r.states[-1])
    # first task of seed 0: make-coffee from the reset world, optimal cost 650 (7 actions)
    assert (records[0].task, records[0].cost, len(records[0].plan)) == ("make-coffee(servingtable)", 650, 7)
    resumed = list(rollout(two_room, oracle, seed=0, n_tasks=6, done=records[:4]))
    assert [(r.plan, r.cost, r.after) for r in resumed] == [(r.plan, r.cost, r.after) for r in records]
