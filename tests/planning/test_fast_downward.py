"""Fast Downward's plans replay in our simulator, reach the goal, and cost what it reports."""

import numpy as np
import pytest

from planning.domain.batched import BatchedModel
from planning.external import fast_downward as fd
from planning.search.optimal import optimal_plan
from tests.examples import SERVE_WATER_ACTIONS, START_COSTS


def state_task_pairs(model, n: int, seed: int):
    """n (reachable state, task) pairs: states from random walks, tasks drawn from P."""
    rng = np.random.default_rng(seed)
    states = model.random_walk_states(20 * n, seed)
    return [(states[i], model.tasks.sample(rng)) for i in rng.choice(len(states), n, replace=False)]


def check_pairs(model, pairs, search):
    """FD's plans replay to the goal at FD's reported cost, which our A* also finds."""
    bm = BatchedModel(model)
    solved = 0
    for state, task in pairs:
        r = fd.solve(model, state, task, time_limit=120, search=search)
        assert r.status == fd.Status.SOLVED, (task.name, r.message)
        assert r.cost == fd.replay_cost(model, state, r.plan, task)  # reaches the goal
        assert r.optimal and optimal_plan(bm, state, task).cost == r.cost
        solved += 1
    return solved


@pytest.mark.parametrize("layout", ["two-room", "three-room"])
def test_fast_downward_plans_replay_small(layout, two_room, three_room):
    m = two_room if layout == "two-room" else three_room
    assert check_pairs(m, state_task_pairs(m, 6, seed=21), fd.OPTIMAL_CONFIG) == 6


@pytest.mark.slow
@pytest.mark.parametrize("layout", ["two-room", "three-room"])
def test_fast_downward_plans_replay_100(layout, two_room, three_room):
    m = two_room if layout == "two-room" else three_room
    assert check_pairs(m, state_task_pairs(m, 100, seed=22), fd.OPTIMAL_CONFIG) == 100


def test_start_state_serve_water_costs_as_worked_out_by_hand(restaurant):
    r = fd.solve(restaurant, restaurant.init, restaurant.tasks.get("serve-water(servingtable)"))
    assert r.cost == START_COSTS["serve-water(servingtable)"] and len(r.plan) == SERVE_WATER_ACTIONS


def test_unsolvable_task_is_reported_not_crashed(minimal):
    held = minimal.state_from_atoms(["(robot-at x1y1)", "(holding apple)"])
    r = fd.solve(minimal, held, minimal.tasks.get("deliver(a)"), time_limit=30)
    assert (r.status, r.cost) == (fd.Status.SOLVED, 3)  # two moves to a, place
    stuck = minimal.state_from_atoms(["(robot-at x1y1)"])  # the apple is gone: no plan exists
    r = fd.solve(minimal, stuck, minimal.tasks.get("deliver(a)"), time_limit=30)
    assert r.status == fd.Status.UNSOLVABLE and r.plan == []
