"""LM-cut: exact on tiny hand-built tasks, between h_max and the optimal cost on the restaurant."""

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import planning.heuristics.lmcut as lmcut_module
from planning.domain.batched import BatchedModel
from planning.domain.model import Op
from planning.heuristics.hmax import HMax, goal_literals
from planning.heuristics.lmcut import LMCut
from planning.search.optimal import optimal_plan, uniform_cost_search
from planning.states import INF_64


class _Bits:
    """The one method LM-cut needs of a BatchedModel, for hand-built one-word models."""

    def __init__(self, model):
        self.model = model

    def to_bits(self, batch):
        return ((batch[:, :1] >> np.arange(self.model.n_atoms, dtype=np.uint64)) & np.uint64(1)).astype(np.uint8)


@pytest.fixture(params=["native", "numpy"], autouse=True)
def implementation(request, monkeypatch):
    """Every test runs on both the compiled LM-cut and the numpy one (skipped: no C compiler)."""
    if request.param == "native":
        if lmcut_module.native() is None:
            pytest.skip("no C compiler: the numpy LM-cut only")
    else:
        monkeypatch.setattr(lmcut_module, "_NATIVE", False)
    return request.param


def tiny(n_atoms, actions):
    """An LMCut over atoms 0..n-1 and actions [(pre atoms, add atoms, delete atoms, cost)]."""
    mask = lambda atoms: sum(1 << a for a in atoms)
    model = SimpleNamespace(
        n_atoms=n_atoms,
        ops=[Op(mask(p), 0, mask(a), mask(d)) for p, a, d, _ in actions],
        op_action=list(range(len(actions))),
        action_cost=[c for *_, c in actions],
    )
    bm = _Bits(model)
    return LMCut(model, bm, HMax(model, bm)), HMax(model, bm)


def h_of(h, state_atoms, goal):
    return int(h(np.array([[sum(1 << a for a in state_atoms)]], dtype=np.uint64), goal)[0])


def test_two_independent_goals_add_up():
    # a costs 3, b costs 4: h_max sees 4, LM-cut both landmarks, 7.
    lm, hm = tiny(2, [((), (0,), (), 3), ((), (1,), (), 4)])
    assert h_of(hm, [], [[0, 1]]) == 4
    assert h_of(lm, [], [[0, 1]]) == 7


def test_a_shared_achiever_is_counted_once():
    # As above plus one action adding both for 5: the optimum and LM-cut are 5.
    lm, _ = tiny(2, [((), (0,), (), 3), ((), (1,), (), 4), ((), (0, 1), (), 5)])
    assert h_of(lm, [], [[0, 1]]) == 5


def test_chains_negative_literals_and_dead_ends():
    # Atom 2 needs atom 0 (cost 2) then 10; (not 1) needs deleting atom 1 for 6.
    lm, _ = tiny(3, [((), (0,), (), 2), ((0,), (2,), (), 10), ((), (), (1,), 6)])
    n = 3
    assert h_of(lm, [1], [[2, n + 1]]) == 18
    assert h_of(lm, [0, 1], [[2, n + 1]]) == 16
    assert h_of(lm, [], [[2, n + 1]]) == 12  # (not 1) already holds
    lm2, _ = tiny(3, [((), (0,), (), 2)])
    assert h_of(lm2, [], [[2]]) == INF_64  # nothing adds atom 2


def test_a_disjunctive_goal_takes_the_cheaper_conjunction():
    lm, _ = tiny(3, [((), (0,), (), 3), ((), (1,), (), 4), ((), (2,), (), 9)])
    assert h_of(lm, [], [[0, 1], [2]]) == 7
    assert h_of(lm, [], [[0, 1], [2], []]) == 0  # an empty conjunction always holds


def test_start_state_values(restaurant):
    # serve-water from :init costs 1475; h_max sees only fill + the longer branch (1225).
    bm = BatchedModel(restaurant)
    lm = LMCut(restaurant, bm)
    goal = goal_literals(restaurant, restaurant.tasks.get("serve-water(servingtable)"))
    assert lm(bm.pack([restaurant.init]), goal)[0] == 1450


def test_between_hmax_and_the_optimal_cost(two_room):
    bm = BatchedModel(two_room)
    hm = HMax(two_room, bm)
    lm = LMCut(two_room, bm, hm)
    states = two_room.random_walk_states(300, seed=5)
    batch = bm.pack(states)
    stronger = 0
    for name in ["make-coffee(servingtable)", "serve-water(servingtable)", "wash(bowls)", "fruit-bowl(servingtable)"]:
        goal = goal_literals(two_room, two_room.tasks.get(name))
        a, b = hm(batch, goal), lm(batch, goal)
        assert (b >= a).all()
        stronger += int((b > a).sum())
    assert stronger > 300  # strictly above h_max on most of them
    rng = np.random.default_rng(5)
    cheap = [t for t in two_room.tasks if t.type in ("make-coffee", "clear", "wash", "pick-place")]
    compared = 0
    for i in rng.choice(len(states), 10, replace=False):
        task = cheap[rng.integers(len(cheap))]
        exact = uniform_cost_search(two_room, states[i], task, max_expansions=100_000)
        if exact.plan is None:
            continue
        assert lm(bm.pack([states[i]]), goal_literals(two_room, task))[0] <= exact.cost
        r = optimal_plan(bm, states[i], task, heuristic="lmcut")
        assert r.cost == exact.cost and r.expansions <= exact.expansions + 1
        compared += 1
    assert compared >= 5


def test_hmax_remains_selectable(two_room):
    bm = BatchedModel(two_room)
    task = two_room.tasks.get("make-coffee(servingtable)")
    a = optimal_plan(bm, two_room.init, task, heuristic="hmax")
    b = optimal_plan(bm, two_room.init, task)
    assert a.cost == b.cost == 650 and b.expansions < a.expansions


def test_native_and_numpy_agree_exactly(two_room, monkeypatch, implementation):
    # Same cuts, same ties (the first costliest precondition): the same values, dead ends included.
    if implementation == "numpy":
        pytest.skip("compares both implementations itself: runs once, under the native parameter")
    bm = BatchedModel(two_room)
    lm = LMCut(two_room, bm)
    batch = bm.pack(two_room.random_walk_states(200, seed=9))
    for name in ["serve-water(servingtable)", "make-coffee(servingtable)", "fruit-bowl(servingtable)"]:
        goal = goal_literals(two_room, two_room.tasks.get(name))
        fast = lm(batch, goal)
        monkeypatch.setattr(lmcut_module, "_NATIVE", False)
        slow = lm(batch, goal)
        monkeypatch.setattr(lmcut_module, "_NATIVE", None)
        assert (fast == slow).all()


@pytest.mark.slow
def test_the_slowest_myopic_task_is_fast_with_lmcut(two_room):
    # Sequence 4, task 21: make-coffee once the machine water is used up (h_max A*: 532,766 states).
    from planning.world.sequences import load
    from planning.world.task_stream import PersistentWorld

    path = Path("results/myopic-oracle-internal-two-room.json")
    if not path.is_file():
        pytest.skip(f"{path} not here; python -m oracles.myopic --planner internal writes it")
    rows = [r for r in json.loads(path.read_text())["per_task"] if r["sequence"] == 4]
    seq = load(two_room, [4])[0]
    world = PersistentWorld(two_room, seq.reset_seed)
    for row, task in zip(rows[:21], seq.tasks):
        if not world.begin(task):
            world.execute([two_room.action(a) for a in row["plan"]])
    r = optimal_plan(BatchedModel(two_room), world.state, seq.tasks[21])
    assert r.cost == 3025 and r.expansions < 30_000


def test_landmarks_are_cuts_every_plan_crosses(two_room, implementation):
    """Each reported cut holds an action of every plan (checked on optimal plans); the cuts' count
    and the value agree with the plain LM-cut. The landmarks come from the compiled kernel only."""
    if implementation == "numpy":
        pytest.skip("landmarks come from the compiled LM-cut")
    bm = BatchedModel(two_room)
    lm = LMCut(two_room, bm)
    states = two_room.random_walk_states(40, seed=7)
    checked = 0
    for name in ["serve-water(servingtable)", "make-coffee(servingtable)", "wash(knives)"]:
        task = two_room.tasks.get(name)
        relaxed = lm.tables(goal_literals(two_room, task))
        h, cuts = lm.landmarks(bm.pack(states[:8]), relaxed)
        assert (h == lm(bm.pack(states[:8]), goal_literals(two_room, task))).all()
        for s, state_cuts in zip(states[:8], cuts):
            plan = optimal_plan(bm, s, task).plan
            if not plan:
                continue
            for cut in state_cuts:
                actions = {two_room.op_action[relaxed.op_keys[o]] for o in cut}
                assert actions & set(plan), (name, [two_room.actions[a] for a in actions])
                checked += 1
    assert checked > 20
