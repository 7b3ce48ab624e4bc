"""Every heuristic of the registry, in every search it serves, gives the optimal cost: a new row is covered here.

The searches build their heuristic from the row (planning.heuristics.build); the tests below count the calls
of every row's built object to see that the row named is the one that ran, and nothing else."""

import dataclasses

import numpy as np
import pytest

import planning.heuristics as heuristics
from oracles.labelling import Labeller
from planning.domain.batched import BatchedModel
from planning.errors import DomainError
from planning.heuristics import HEURISTICS, SEARCHES, build, choose, names
from planning.search.joint import JointSearch
from planning.search.optimal import optimal_plan
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
        assert choose(name, two_room, search) == name  # the restaurant names its rooms
        fallback = choose(name, minimal, search)
        assert fallback in names(search)
    for search in {"task", "window", "multi-goal"} - set(HEURISTICS[name].searches):
        with pytest.raises(DomainError, match="--heuristic"):
            choose(name, two_room, search)


def test_unknown_heuristic_is_a_one_line_error(two_room):
    with pytest.raises(DomainError, match="'pbd' is not one of pdb, lmcut, hmax"):
        build("pbd", BatchedModel(two_room), "task")
    with pytest.raises(DomainError, match="'pbd' is not one of pdb, lmcut, hmax"):
        optimal_plan(BatchedModel(two_room), two_room.init, two_room.tasks.get(TASK), heuristic="pbd")


# ---- the row named is the one that runs ------------------------------------------------------
class Counted:
    """A built heuristic that counts its calls."""

    def __init__(self, h):
        self.h, self.calls = h, 0

    def __call__(self, batch, goals):
        self.calls += 1
        return self.h(batch, goals)


@pytest.fixture
def counted(monkeypatch):
    """Every row's builder wrapped: {row name: [(search, Counted or None), ...]} of what was built."""
    built: dict = {}
    for name, row in list(HEURISTICS.items()):

        def counting(bm, search, row=row):
            h = row.build(bm, search)
            built.setdefault(row.name, []).append((search, None if h is None else Counted(h)))
            return built[row.name][-1][1]

        monkeypatch.setitem(HEURISTICS, name, dataclasses.replace(row, build=counting))
    return built


def calls(built: dict, name: str) -> int:
    return sum(c.calls for _, c in built.get(name, []) if c is not None)


def minimal_state(minimal):
    return minimal.state_from_atoms(["(robot-at x1y2)", "(hand-free)", "(at apple c)"])


def run_search(search: str, model, name: str):
    """The optimal cost(s) of the minimal domain's search `search` with heuristic `name`."""
    s = minimal_state(model)
    if search == "task":
        return optimal_plan(BatchedModel(model), s, model.tasks.get("deliver(a)"), heuristic=name).cost
    if search == "window":
        return (
            JointSearch(model, max_window=2)
            .plan(s, [model.tasks.get("clear(c)"), model.tasks.get("deliver(b)")], heuristic=name)
            .cost
        )
    return [int(c) for c in Labeller(model, name).label(s).costs]


@pytest.mark.parametrize("name,search", [(n, s) for n in HEURISTICS for s in HEURISTICS[n].searches])
def test_the_row_named_is_the_heuristic_that_ran(minimal, counted, name, search):
    assert choose(name, minimal, search) == name  # the minimal grid names its rooms
    cost = run_search(search, minimal, name)
    assert cost is not None
    built = [c for s, c in counted.get(name, []) if s == search]
    assert built, f"{name}'s builder was not called for the {search} search"
    if any(c is not None for c in built):
        assert calls(counted, name) > 0, f"{name}'s heuristic was built for the {search} search but never called"
    assert {n for n in counted if calls(counted, n)} <= {name}, f"another row ran: {counted}"


@pytest.mark.parametrize(
    "name,search", [(n, s) for n in HEURISTICS for s in sorted(set(SEARCHES) - set(HEURISTICS[n].searches))]
)
def test_a_search_a_row_does_not_serve_is_refused_by_name(minimal, counted, name, search):
    with pytest.raises(DomainError, match=f"--heuristic: '{name}' is not one of"):
        run_search(search, minimal, name)
    assert not any(calls(counted, n) for n in counted)  # nothing else ran in its place


@pytest.mark.parametrize("search", SEARCHES)
def test_the_declared_stand_in_runs_where_pdb_is_unsupported_and_says_so(minimal, counted, monkeypatch, capsys, search):
    monkeypatch.setitem(HEURISTICS, "pdb", dataclasses.replace(HEURISTICS["pdb"], supports=lambda model: False))
    monkeypatch.setattr(heuristics, "_REPORTED", set())
    stand_in = HEURISTICS["pdb"].fallback[search]
    assert run_search(search, minimal, "pdb") == run_search(search, minimal, stand_in)
    err = capsys.readouterr().err
    assert "heuristic 'pdb' needs the locations" in err and f"using {stand_in} instead" in err
    assert calls(counted, stand_in) > 0 and calls(counted, "pdb") == 0


@pytest.mark.parametrize("search", SEARCHES)
def test_an_unsupported_row_without_a_stand_in_is_refused_by_name(minimal, counted, monkeypatch, search):
    monkeypatch.setitem(
        HEURISTICS, "pdb", dataclasses.replace(HEURISTICS["pdb"], supports=lambda model: False, fallback={})
    )
    with pytest.raises(DomainError, match="--heuristic: 'pdb' needs the locations"):
        run_search(search, minimal, "pdb")
    assert not any(calls(counted, n) for n in counted)


# ---- adding a heuristic: its module and its row ------------------------------------------------
def test_a_new_row_runs_in_every_search_it_declares(minimal, monkeypatch):
    """A throwaway zero heuristic registered under a new name: each search builds and runs it, with blind's costs
    (hmax's in the window search, which blind does not serve)."""
    built = []

    def zero(bm, search):
        built.append((search, Counted(lambda batch, goals: np.zeros(len(batch), dtype=np.int64))))
        return built[-1][1]

    monkeypatch.setitem(
        HEURISTICS, "zero", heuristics.Heuristic("zero", "0 everywhere, called", zero, derived=SEARCHES)
    )
    assert "zero" in names("task") and "zero" in names("window") and "zero" in names("multi-goal")
    for search, reference in (("task", "blind"), ("window", "hmax"), ("multi-goal", "blind")):
        assert run_search(search, minimal, "zero") == run_search(search, minimal, reference), search
    assert [s for s, _ in built] == list(SEARCHES) and all(h.calls > 0 for _, h in built)
