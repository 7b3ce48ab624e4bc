"""The committed myopic-oracle results replay exactly, and our planner matches FD's cost at every state.

The Fast Downward oracle's results record each executed plan; replaying them
from the sequence's reset seed rebuilds every (state, task) it met, where our
exact planner must find the same optimal cost. A sample runs by default; all
500 tasks per layout under -m slow.
"""

import json
from pathlib import Path

import pytest

from planning.domain.batched import BatchedModel
from planning.search.optimal import optimal_plan
from planning.world.sequences import load
from planning.world.task_stream import PersistentWorld

RESULTS = Path("results")


def replay(model, limit_per_sequence=None, sequences=None):
    path = RESULTS / f"myopic-oracle-{model.layout}.json"
    assert path.is_file(), f"{path} is committed; regenerate with python -m oracles.myopic --layout {model.layout}"
    data = json.loads(path.read_text())
    rows = {(r["sequence"], r["index"]): r for r in data["per_task"]}
    bm = BatchedModel(model)
    checked = 0
    for seq in load(model, sequences):
        world = PersistentWorld(model, seq.reset_seed)
        planned = 0
        for i, task in enumerate(seq.tasks):
            row = rows[(seq.id, i)]
            if world.begin(task):
                assert row["auto"] and row["cost"] == 0
                continue
            if limit_per_sequence is None or planned < limit_per_sequence:
                assert optimal_plan(bm, world.state, task).cost == row["planner_cost"], row["task"]
                checked += 1
            planned += 1
            for name in row["plan"]:
                world.act(model.action(name))
            assert world.outcomes[-1].cost == row["cost"] and world.outcomes[-1].success == row["success"]
    return checked, data


@pytest.mark.parametrize("layout", ["two-room", "three-room"])
def test_committed_results_replay_and_match_a_sample(layout, two_room, three_room):
    model = two_room if layout == "two-room" else three_room
    checked, data = replay(model, limit_per_sequence=2, sequences=[0, 1])
    assert checked == 4
    assert data["config"]["search"] == "astar(blind())" and data["success_rate"] == 1.0


@pytest.mark.slow
@pytest.mark.parametrize("layout", ["two-room", "three-room"])
def test_internal_planner_matches_fast_downward_on_every_canonical_task(layout, two_room, three_room):
    model = two_room if layout == "two-room" else three_room
    checked, data = replay(model)
    assert checked == sum(1 for r in data["per_task"] if not r["auto"])
