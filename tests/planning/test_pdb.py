"""Pattern databases (planning.heuristics.pdb): admissible everywhere, exact where delete relaxations are blind."""

import shutil

import pytest

from oracles.labelling import Labeller
from planning.heuristics.hmax import goal_literals
from planning.heuristics.lmcut import LMCut
from planning.heuristics.pdb import GROW_STATES, PatternDatabases, pattern_databases


def _estimates(model, state):
    pdb = pattern_databases(model, Labeller(model, "blind").bm.n_words)
    return pdb, pdb.per_task(Labeller(model, "blind").bm.pack([state]))[0]


def test_exact_for_every_task_at_the_start(restaurant):
    """From each layout's start, every one of the 48 tasks' estimates is its optimal cost."""
    _, h = _estimates(restaurant, restaurant.init)
    exact = Labeller(restaurant, "lmcut").label(restaurant.init).costs
    assert (h == exact).all(), [(t.name, a, b) for t, a, b in zip(restaurant.tasks, h, exact) if a != b]


def test_sees_the_round_trip_to_the_pantry(three_room):
    """Fetching the jar from the pantry: 875 there, pick 100, 875 back, place 100 = 1,950.
    The projection onto the robot and the jar knows the robot must walk back; LM-cut does not."""
    task = three_room.tasks.get("pick-place(jar_0, servingtable)")
    _, h = _estimates(three_room, three_room.init)
    bm = Labeller(three_room, "blind").bm
    lmcut = LMCut(three_room, bm)(bm.pack([three_room.init]), goal_literals(three_room, task))[0]
    assert h[task.index] == 875 + 100 + 875 + 100
    assert lmcut < 1950


def test_pouring_needs_a_filled_vessel(three_room):
    """With the machine's water used up, coffee needs water fetched and poured first: pick cup_0 100,
    to the fountain 225, fill 1,000, to the machine 200, pour 200, place 100, brew 50, pick 100, to the
    table 175, place 100 = 2,250. The pattern keeps what decides whether a pour refills the machine
    (a vessel held with water in it), so its estimate is exact; LM-cut's is 1,800."""
    state = three_room.init & ~three_room.state_from_atoms(["(at water_machine coffeemachine)"])
    task = three_room.tasks.get("make-coffee(servingtable)")
    _, h = _estimates(three_room, state)
    exact = Labeller(three_room, "lmcut").label(state).costs[task.index]
    assert h[task.index] == exact == 100 + 225 + 1000 + 200 + 200 + 100 + 50 + 100 + 175 + 100


def test_admissible_and_labels_unchanged_on_reachable_states(two_room):
    """On random-walk states every estimate is at most the optimal cost, and the labels are LM-cut's."""
    pdb_lab, lmcut_lab = Labeller(two_room, "pdb"), Labeller(two_room, "lmcut")
    assert pdb_lab.heuristic == "pdb"
    for s in two_room.random_walk_states(6, seed=3, walk=25):
        exact = lmcut_lab.label(s).costs
        assert (pdb_lab.label(s).costs == exact).all()
        assert (pattern_databases(two_room, pdb_lab.bm.n_words).per_task(pdb_lab.bm.pack([s]))[0] <= exact).all()


def test_a_state_outside_the_explored_space_gets_zero(two_room):
    """A hand-written state no run reaches (the robot in two places) is outside every projection that
    keeps the robot's position: those answer 0 (index `size` reads a 0), never a guess."""
    pdb, _ = _estimates(two_room, two_room.init)
    bm = Labeller(two_room, "blind").bm
    robot = bm.pack([two_room.state_from_atoms(["(robot-at fountain)"])])[0]
    batch = bm.pack([two_room.init]) | robot
    keeping = [p for p, _ in pdb.projections.values() if p is not None and (p.mask & robot).any()]
    assert len(keeping) > 5
    assert all(p.index(batch)[0] == p.size for p in keeping)


PICK_PLACES = ["pick-place(plate_0, shelf)", "pick-place(cup_0, servingtable)", "pick-place(cup_1, shelf)"]


def test_saturated_costs_keep_the_distances_and_free_the_rest(two_room):
    """A pattern's saturated costs (per action, the largest drop in its window distances over the
    transitions the action induces) give it the very same distances, and leave cost for others:
    the cup's pattern never needs the plate picked (placing it is what frees the hand). Every move
    lies on some shortest path of the cup's, so the moves stay with the first pattern."""
    pdb, _ = _estimates(two_room, two_room.init)
    window = [two_room.tasks.get(n) for n in PICK_PLACES]
    cup = pdb.projection(frozenset(["cup_0"]))
    togo = cup.window_distances(window)
    need = cup.saturated(togo, cup.costs)
    assert (need >= 0).all() and (need <= cup.costs).all()
    for full, saturated in zip(togo, cup.window_distances(window, need)):
        assert (full == saturated).all()
    picks = [a for a, name in enumerate(two_room.actions) if name.startswith("pick(plate_0,")]
    moves = [a for a, name in enumerate(two_room.actions) if name.startswith("move(")]
    assert len(picks) == 6 and (need[picks] == 0).all() and (cup.costs[picks] > 0).all()
    assert (need[moves] == cup.costs[moves]).all()


@pytest.mark.slow
def test_a_grown_window_pattern_sees_where_the_jar_is_and_proves_a_window_pdb_could_not(three_room):
    """Three-room sequence 0's first K = 4 window (two coffees, a wash, a water): the best window pattern (the cups and
    the machine water) grown by the jar raises the start's estimate from 3,900 to 4,800 and proves the window's
    optimum, 6,075, where the plain pattern databases ran out of time at 5,900 (results/clairvoyant-4-three-room.json
    fell back to the myopic chain's 6,125)."""
    from planning.heuristics import build
    from planning.search.joint import JointSearch
    from planning.world import sequences
    from planning.world.task_stream import PersistentWorld

    seq = sequences.load(three_room, [0])[0]
    world = PersistentWorld(three_room, reset_seed=seq.reset_seed)
    tasks = seq.tasks[:4]
    joint = JointSearch(three_room, max_window=4)
    start = joint._complete(joint.bm.pack([world.state | (1 << joint.n)]), tasks)
    assert int(build("pdb", joint.bm, "window")(start, tasks)[0]) == 3900
    assert int(build("pdb-grown", joint.bm, "window")(start, tasks)[0]) == 4800
    pdb = pattern_databases(three_room, joint.bm.n_words)
    grown = {p.objects for parts in pdb.window(tasks, start[:1], grow=GROW_STATES) for p, _ in parts}
    assert frozenset({"cup_0", "cup_1", "water_machine", "jar_0"}) in grown
    r = joint.plan(world.state, tasks, heuristic="pdb-grown")
    assert r.cost == r.lower_bound == 6075


def test_applicability_is_every_literal_of_each_precondition(minimal, three_room):
    """`_applicability` (one product of state bits and literal counts) says an operator applies exactly where
    every positive precondition word is set and no negative one is: on random states of the grid and of the
    three-room restaurant, against the word-by-word test, for the full model's operators."""
    import numpy as np

    from planning.domain.batched import BatchedModel
    from planning.heuristics.pdb import _applicability, _project_ops

    for model in (minimal, three_room):
        bm = BatchedModel(model)
        ops = _project_ops(model, bm, (1 << model.n_atoms) - 1, [])
        states = bm.pack(list(dict.fromkeys(model.random_walk_states(300, seed=5))))
        want = np.ones((len(states), len(ops.edge)), dtype=bool)
        for w in range(bm.n_words):
            s = states[:, w, None]
            want &= ((~s & ops.pos[None, :, w]) | (s & ops.neg[None, :, w])) == 0
        got = _applicability(ops, bm.n_words)(states)
        assert got.dtype == bool and (got == want).all()
        assert 0 < want.sum() < want.size  # some operators apply, not all


def test_the_disk_cache_gives_the_same_estimates_and_recovers_from_a_bad_entry(minimal, tmp_path, monkeypatch):
    """Each projection's states and goal distances are kept in the user's cache folder (planning.cache): a second
    build loads them and gives the same estimates, a window's too (its graph explored again where needed); an
    entry that cannot be read is computed again and rewritten; PDB_CACHE=0 writes nothing."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    folder = tmp_path / "anticipatory-planning"
    first = PatternDatabases(minimal)
    states = first.bm.pack(minimal.random_walk_states(20, seed=1, walk=10))
    window = list(minimal.tasks.tasks[:3])
    expected = first.per_task(states), first.window_estimate(states, window)
    files = sorted(folder.rglob("*.npz"))
    assert {f.parent.name for f in files} == {"pdb", "pdb-goal"}

    def same(pdb):
        assert all(p is None or p._edges is None for p, _ in pdb.projections.values())  # loaded, not explored
        assert (pdb.per_task(states) == expected[0]).all()
        assert (pdb.window_estimate(states, window) == expected[1]).all()

    same(PatternDatabases(minimal))
    for f in files:
        f.write_bytes(b"cut short")
    first = PatternDatabases(minimal)
    assert all(p is None or p._edges is not None for p, _ in first.projections.values())  # explored again
    same(PatternDatabases(minimal))
    monkeypatch.setenv("PDB_CACHE", "0")
    shutil.rmtree(folder)
    PatternDatabases(minimal).per_task(states)
    assert not folder.exists()
