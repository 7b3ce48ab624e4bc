"""Every heuristic of the registry, in every search it serves, gives the optimal cost: a new row is covered here."""
import pytest

from oracles.labelling import Labeller
from planning.domain.batched import BatchedModel
from planning.errors import DomainError
from planning.heuristics import HEURISTICS, choose, names
from planning.search.joint import JointSearch
from planning.search.optimal import goals_heuristic, optimal_plan
from tests.examples import START_COSTS

TASK = "make-coffee(servingtable)"


@pytest.mark.parametrize("name", names("task"))
def test_task_search_finds_the_hand_checked_cost(two_room, name):
    bm = BatchedModel(two_room)
    for task_name, cost in START_COSTS.items():
        r = optimal_plan(bm, two_room.init, two_room.tasks.get(task_name), heuristic=name)
        assert r.cost == cost, (name, task_name)


@pytest.mark.parametrize("name", names("window"))
def test_window_search_agrees_with_hmax(minimal, name):
    tasks = [minimal.tasks.get("clear(c)"), minimal.tasks.get("deliver(b)")]
    s = minimal.state_from_atoms(["(robot-at x1y2)", "(hand-free)", "(at apple c)"])
    joint = JointSearch(minimal, max_window=2)
    assert joint.plan(s, tasks, heuristic=name).cost == joint.plan(s, tasks, heuristic="hmax").cost > 0


@pytest.mark.parametrize("name", names("multi-goal"))
def test_multi_goal_labels_agree_with_blind(minimal, name):
    s = minimal.state_from_atoms(["(robot-at x1y2)", "(holding apple)"])
    assert (Labeller(minimal, name).label(s).costs == Labeller(minimal, "blind").label(s).costs).all()


@pytest.mark.parametrize("name", list(HEURISTICS))
def test_a_row_names_its_searches_and_falls_back_where_unsupported(minimal, two_room, name):
    for search in HEURISTICS[name].searches:
        assert choose(name, two_room, search) == name              # the restaurant names its rooms
        fallback = choose(name, minimal, search)
        assert fallback in names(search)
    for search in {"task", "window", "multi-goal"} - set(HEURISTICS[name].searches):
        with pytest.raises(DomainError, match="--heuristic"):
            choose(name, two_room, search)


def test_unknown_heuristic_is_a_one_line_error(two_room):
    with pytest.raises(DomainError, match="'pbd' is not one of pdb, lmcut, hmax"):
        goals_heuristic(BatchedModel(two_room), [two_room.tasks.get(TASK)], "pbd")
