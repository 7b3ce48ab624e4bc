"""The exact searches agree with each other and with hand-checked optimal costs."""

import numpy as np
import pytest

from planning.domain.batched import BatchedModel
from planning.external.fast_downward import replay_cost
from planning.heuristics.hmax import HMax, goal_literals
from planning.search.optimal import optimal_plan, optimal_plans, uniform_cost_search
from tests.examples import START_COSTS


@pytest.mark.parametrize("name,cost", START_COSTS.items())
def test_hand_checked_costs_from_the_start_state(restaurant, name, cost):
    r = optimal_plan(BatchedModel(restaurant), restaurant.init, restaurant.tasks.get(name))
    assert r.cost == cost
    assert replay_cost(restaurant, restaurant.init, r.plan, restaurant.tasks.get(name)) == r.cost


def test_astar_equals_uniform_cost_search(two_room):
    bm = BatchedModel(two_room)
    rng = np.random.default_rng(3)
    states = two_room.random_walk_states(400, seed=3)
    cheap = [t for t in two_room.tasks if t.type in ("make-coffee", "clear", "wash", "pick-place")]
    for i in rng.choice(len(states), 12, replace=False):
        task = cheap[rng.integers(len(cheap))]
        exact = uniform_cost_search(two_room, states[i], task, max_expansions=200_000)
        if exact.plan is None:
            continue
        assert optimal_plan(bm, states[i], task).cost == exact.cost


def test_one_search_for_many_goals_gives_each_its_optimal_plan(two_room):
    """optimal_plans: a task with each of several clauses, one A*: every cost is the single search's, every
    plan reaches its goal at that cost, and a goal that is never reached has no plan."""
    from learning.gnn.dataset import ClauseLibrary, JointGoal

    bm = BatchedModel(two_room)
    library = ClauseLibrary(two_room, 0)
    task = two_room.tasks.get("make-coffee(servingtable)")
    goals = [JointGoal(task, *library.masks[k]) for k in range(0, len(library), max(1, len(library) // 4))][:4]
    together = optimal_plans(bm, two_room.init, goals)
    alone = [optimal_plan(bm, two_room.init, g) for g in goals]
    assert [r.cost for r in together] == [r.cost for r in alone] and all(r.cost is not None for r in alone)
    assert len({r.cost for r in alone}) > 1  # goals at different depths: the rescoring path
    for g, r in zip(goals, together):
        assert replay_cost(two_room, two_room.init, r.plan, g) == r.cost
    tried = []
    picky = optimal_plans(bm, two_room.init, goals[:2], prefer=lambda k, plan: tried.append(k) or False)
    assert [r.cost for r in picky] == [r.cost for r in alone[:2]] and set(tried) == {0, 1}
    assert [r.cost for r in optimal_plans(bm, two_room.init, goals, heuristic="pdb+lmcut")] == [r.cost for r in alone]
    assert optimal_plans(bm, two_room.init, []) == []


def test_hmax_is_admissible_on_the_start_state(three_room):
    bm = BatchedModel(three_room)
    h = HMax(three_room, bm)
    task = three_room.tasks.get("serve-water(servingtable)")
    assert h(bm.pack([three_room.init]), goal_literals(three_room, task))[0] == 1225  # pick 100 | move 225, fill 1000


def test_unreachable_goal_has_no_plan(minimal):
    stuck = minimal.state_from_atoms(["(robot-at x1y1)"])
    r = optimal_plan(BatchedModel(minimal), stuck, minimal.tasks.get("deliver(a)"))
    assert r.plan is None and r.complete
