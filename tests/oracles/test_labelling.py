"""The labelling oracle: C_AP(s) = sum_tau P(tau) C*_tau(s), every task's cost from one multi-goal search."""

import json
import subprocess
import sys

import pytest

from oracles.labelling import Labeller, read_state
from planning.domain.grounding import atom_text
from planning.errors import DomainError
from planning.external import fast_downward as fd
from planning.search.optimal import optimal_plan

# Hops between the restaurant's locations (shared/restaurant.md); a move costs 25 x hops.
HOPS = {
    ("countertop", "coffeemachine"): 1,
    ("countertop", "dishwasher"): 2,
    ("countertop", "shelf"): 1,
    ("countertop", "servingtable"): 8,
    ("countertop", "fountain"): 9,
    ("coffeemachine", "dishwasher"): 1,
    ("coffeemachine", "shelf"): 2,
    ("coffeemachine", "servingtable"): 7,
    ("coffeemachine", "fountain"): 8,
    ("dishwasher", "shelf"): 3,
    ("dishwasher", "servingtable"): 8,
    ("dishwasher", "fountain"): 9,
    ("shelf", "servingtable"): 7,
    ("shelf", "fountain"): 8,
    ("servingtable", "fountain"): 2,
}


def move(a, b):
    if a == b:
        return 0
    if "pantry" in (a, b):
        return 25 * 35
    return 25 * HOPS.get((a, b), HOPS.get((b, a)))


def test_minimal_domain_by_hand(minimal):
    """Robot and apple at b: deliver(b) costs 0, deliver(a) pick 1 + 4 moves + place 1 = 6; C_AP = 0.2 x 6."""
    lab = Labeller(minimal, "hmax")
    state = minimal.state_from_atoms(["(robot-at b)", "(hand-free)", "(at apple b)"])
    label = lab.label(state)
    costs = {t.name: int(c) for t, c in zip(minimal.tasks, label.costs)}
    assert costs == {"clear(c)": 0, "deliver(b)": 0, "deliver(a)": 6}
    assert label.c_ap == pytest.approx(0.2 * 6)


def test_probabilities_weight_the_sum(minimal):
    """C_AP is the P-weighted sum, not the mean: from the start (apple in c) both deliveries cost 10."""
    lab = Labeller(minimal, "blind")
    assert lab.goals.probabilities.sum() == pytest.approx(1.0)
    start = lab.label(minimal.init)
    assert {t.name: int(c) for t, c in zip(minimal.tasks, start.costs)} == {
        "clear(c)": 10,
        "deliver(b)": 10,
        "deliver(a)": 10,
    }
    assert start.c_ap == pytest.approx(10.0)  # clear(c) has P = 0: its 10 does not count
    near_a = lab.label(minimal.state_from_atoms(["(robot-at a)", "(hand-free)", "(at apple a)"]))
    near_b = lab.label(minimal.state_from_atoms(["(robot-at b)", "(hand-free)", "(at apple b)"]))
    assert near_a.c_ap == pytest.approx(0.8 * 6) and near_b.c_ap == pytest.approx(0.2 * 6)


@pytest.fixture(scope="module")
def start_label(three_room):
    """The three-room start state, labelled once for the tests below."""
    return Labeller(three_room, "hmax").label(three_room.init)


def test_three_room_start_by_hand(three_room, start_label):
    """The start state's C_AP from the costs worked out with restaurant.md's tables."""
    label = start_label
    costs = {t.name: int(c) for t, c in zip(three_room.tasks, label.costs)}
    assert costs["serve-water(servingtable)"] == 1475  # restaurant.md's reference figure
    # pick cup_0 100, to coffeemachine 25, place 100, brew 50, pick 100, to servingtable 175, place 100
    assert costs["make-coffee(servingtable)"] == 650
    assert costs["wash(bowls)"] == costs["wash(knives)"] == 0  # clean at the countertop already
    assert costs["clear(servingtable)"] == 200 + 100  # walk there and pick the plate up
    # pick knife, cut, put the knife down, pick the bowl, carry it, place it
    assert costs["fruit-bowl(servingtable)"] == 100 + 100 + 100 + 100 + 200 + 100
    where = {
        "cup_0": "countertop",
        "cup_1": "dishwasher",
        "bowl_0": "countertop",
        "knife_0": "countertop",
        "jar_0": "pantry",
        "plate_0": "servingtable",
    }
    pick_place = 0.0
    for o, at in where.items():
        for loc in ["countertop", "coffeemachine", "dishwasher", "shelf", "servingtable", "fountain", "pantry"]:
            want = 0 if loc == at else move("countertop", at) + 100 + move(at, loc) + 100
            assert costs[f"pick-place({o}, {loc})"] == want, (o, loc)
            pick_place += want
    by_hand = 0.25 * 1475 + 0.30 * 650 + 0.05 * 300 + 0.05 * 700 + 0.05 / 42 * pick_place
    assert label.c_ap == pytest.approx(by_hand)


def test_costs_equal_single_task_optimal_plans(two_room):
    """Every task's settled cost equals the internal planner's optimum for that task alone."""
    lab = Labeller(two_room, "hmax")
    state = two_room.apply(two_room.init, two_room.action("pick(cup_0, countertop)"))
    label = lab.label(state)
    for task, c in zip(two_room.tasks, label.costs):
        assert c == optimal_plan(lab.bm, state, task).cost, task.name


def test_costs_equal_fast_downward_sample(three_room, start_label):
    """Three task types from the start state: our costs are Fast Downward's blind A*'s."""
    for name in ["clear(servingtable)", "fruit-bowl(servingtable)", "pick-place(cup_1, shelf)"]:
        task = three_room.tasks.get(name)
        r = fd.solve(three_room, three_room.init, task, 120)
        assert r.status == fd.Status.SOLVED and start_label.costs[task.index] == r.cost, name


def test_heuristics_agree(minimal):
    """Blind, h_max, LM-cut and the pattern databases settle every task at the same cost."""
    states = [minimal.init, minimal.state_from_atoms(["(robot-at x1y2)", "(holding apple)"])]
    for s in states:
        costs = [Labeller(minimal, h).label(s).costs for h in ("blind", "hmax", "lmcut", "pdb")]
        assert all((c == costs[0]).all() for c in costs)


def test_read_state_json_and_pddl(tmp_path, three_room):
    atoms = [atom_text(k) for k in three_room.true_atoms(three_room.init)]
    f = tmp_path / "s.json"
    f.write_text(json.dumps(atoms))
    assert read_state(three_room, f) == three_room.init
    assert read_state(three_room, three_room.files["problem"]) == three_room.init


def test_bad_state_file_is_one_line_error(tmp_path, three_room):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(["(at cup_0 moon)"]))
    with pytest.raises(DomainError, match="bad.json"):
        read_state(three_room, f)
    f.write_text("[oops")
    with pytest.raises(DomainError, match="malformed JSON"):
        read_state(three_room, f)
    r = subprocess.run(
        [sys.executable, "-m", "oracles.labelling", "--domain", "domains/minimal", "--state", str(f)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "bad.json" in r.stderr


def test_command_writes_json(tmp_path):
    out = tmp_path / "label.json"
    r = subprocess.run(
        [sys.executable, "-m", "oracles.labelling", "--domain", "domains/minimal", "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    got = json.loads(out.read_text())
    assert got["c_ap"] == pytest.approx(10.0)
    assert [t["task"] for t in got["tasks"]] == ["clear(c)", "deliver(b)", "deliver(a)"]
    assert {t["cost"] for t in got["tasks"]} == {10}


@pytest.mark.slow
def test_costs_equal_fast_downward_full_sample(three_room):
    """Six myopic-rollout states x all 48 tasks: every cost equals Fast Downward's blind A*."""
    from test_gnn_dataset import oracle

    from oracles.myopic import rollout
    from oracles.rollouts import record_states

    records = list(rollout(three_room, oracle(three_room), seed=3, n_tasks=4))
    states = list(dict.fromkeys(record_states(records)))[:6]
    lab = Labeller(three_room, "lmcut")
    for s in states:
        label = lab.label(s)
        for task in three_room.tasks:
            want = 0 if task.satisfied(s) else fd.solve(three_room, s, task, 600).cost
            assert label.costs[task.index] == want, task.name


@pytest.mark.slow
def test_heuristics_agree_on_the_restaurant(two_room):
    """Dijkstra (blind), h_max and LM-cut settle the same costs on reachable restaurant states."""
    for s in two_room.random_walk_states(2, seed=21, walk=10):
        costs = [Labeller(two_room, h).label(s).costs for h in ("blind", "hmax", "lmcut", "pdb")]
        assert all((c == costs[0]).all() for c in costs)


@pytest.mark.slow
def test_costs_equal_single_task_plans_on_random_states(two_room):
    """On states of random walks (machine water often used up), settled costs are single-task optima."""
    lab = Labeller(two_room, "lmcut")
    for state in two_room.random_walk_states(3, seed=5, walk=30)[::1]:
        label = lab.label(state)
        for task, c in zip(two_room.tasks, label.costs):
            assert c == optimal_plan(lab.bm, state, task).cost, task.name


def test_cache_and_tie_breaking_change_no_cost(two_room):
    """The memoized LM-cut and ties broken lower h first settle the same costs as the plain search;
    labelling neighbouring states one after another reuses heuristic values."""
    states = two_room.random_walk_states(3, seed=8, walk=6)
    plain = Labeller(two_room, "lmcut", cache=False)
    cached = Labeller(two_room, "lmcut")
    deep = Labeller(two_room, "lmcut", tie_break=True)
    for s in states:
        want = plain.label(s).costs
        assert (cached.label(s).costs == want).all() and (deep.label(s).costs == want).all()
    h = cached.h
    assert 0 < h.computed < h.calls


def test_c_ap_under_a_markov_estimate_weighs_the_same_costs_by_p_given_the_task_done(two_room):
    """C_AP under the cook-then-clean stream after make-coffee: sum P(tau' | make-coffee) C*_tau', the same
    search's costs; the known estimate's label is the thesis's."""
    import numpy as np

    from oracles.labelling import Label
    from planning.world.estimators import build
    from planning.world.streams import stream

    s = stream(two_room, "cook-then-clean")
    known = Labeller(two_room, "pdb").label(two_room.init)
    markov = Labeller(two_room, "pdb", estimator=build("markov", two_room, s))
    coffee = two_room.tasks.get("make-coffee(servingtable)")
    after_coffee = markov.label(two_room.init, after=coffee)
    assert np.array_equal(after_coffee.costs, known.costs)
    p = s.probabilities(coffee)
    assert after_coffee.c_ap == pytest.approx(float(p @ known.costs))
    assert after_coffee.c_ap == pytest.approx(known.under(p))
    assert list(after_coffee.probabilities) == list(p)
    start = markov.label(two_room.init)  # no task done yet: the stream's start distribution
    assert start.c_ap == pytest.approx(float(s.probabilities(None) @ known.costs))
    assert abs(after_coffee.c_ap - known.c_ap) > 50  # the restaurant's start state: 402.0 against 628.8
    assert known.c_ap == pytest.approx(float(np.array([t.probability for t in two_room.tasks]) @ known.costs))
    assert known.probabilities is None
    # A task with no plan counts only where the distribution draws it.
    label = Label(0.0, np.array([10, -1, 30]), 0.0, 0, True)
    assert label.under(np.array([0.5, 0.0, 0.5])) == pytest.approx(20.0)
    assert label.under(np.array([0.5, 0.1, 0.4])) == float("inf")


def test_command_labels_under_a_stream_and_keeps_each_distribution_apart(tmp_path):
    """On the grid with a Markov stream (another domain than the restaurant): the file records the
    distribution, a label under another distribution is not replaced without --force, and --after with the
    known estimator is a one-line error."""
    from tests.planning.test_streams import grid_with_streams

    model = grid_with_streams(tmp_path)
    folder = str(model.files["config"].parent)
    out = tmp_path / "label.json"
    cmd = [sys.executable, "-m", "oracles.labelling", "--domain", folder, "--out", str(out)]
    markov = ["--stream", "alternate", "--estimator", "markov", "--after", "clear(c)"]
    r = subprocess.run(cmd + markov, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    got = json.loads(out.read_text())
    assert got["distribution"] == {"estimator": "markov", "stream": "alternate", "after": "clear(c)"}
    # alternate: clear -> deliver 0.9; deliver(b) and deliver(a) share it by [tasks] arguments (0.8 / 0.2)
    assert [t["probability"] for t in got["tasks"]] == pytest.approx([0.1, 0.72, 0.18])
    assert "under markov (stream alternate, after clear(c))" in r.stdout
    r = subprocess.run(cmd, capture_output=True, text=True)  # the known P into the same file
    assert r.returncode == 2 and "another task distribution" in r.stderr and r.stderr.count("\n") == 1
    r = subprocess.run(cmd + ["--after", "clear(c)", "--force"], capture_output=True, text=True)
    assert r.returncode == 2 and "--after" in r.stderr and r.stderr.count("\n") == 1
    r = subprocess.run(cmd + ["--force"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "distribution" not in json.loads(out.read_text())
