"""The compiled Bellman–Novelty loop (planning/search/_bn.c) and the compiled Q-network value (learning/q/_qnet.c).

- the compiled successors are Model.successors, in order;
- with the same value the C loop, the Python loop and the reference implementation
  (planning.search.bellman_novelty_reference) do the same thing turn for turn: trace, terminals, stats, plan;
- the compiled q_max and V_AP are BatchedQ's up to float32 rounding, and a state's value does not depend on
  the batch it comes in (nor on the memo);
- identical choices: on the first tasks of sequence 0 of committed guided results (two-room and three-room),
  the search with the committed checkpoint picks exactly the committed plans.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from planning.domain.batched import BatchedModel
from planning.search import bn_kernel
from planning.search.bellman_novelty import bellman_novelty_search
from planning.search.bellman_novelty_reference import bellman_novelty_search_reference
from planning.search.optimal import optimal_plan
from planning.value import ZeroValue

needs_kernel = pytest.mark.skipif(
    bn_kernel.lib() is None, reason="no C compiler: the Python loop runs (it is the reference)"
)


def _checkpoint(layout: str) -> Path:
    p = Path(f"checkpoints/rl-anticipatory-{layout}-seed0.pt")
    if not p.is_file():
        pytest.skip(f"no {p}")
    return p


@pytest.fixture(scope="module")
def values(restaurant):
    pytest.importorskip("torch")
    from learning.q.value import load_value_function
    from planning.parallel import one_thread

    one_thread()
    return load_value_function(_checkpoint(restaurant.layout), restaurant)


@needs_kernel
def test_compiled_successors_are_model_successors(restaurant):
    m = restaurant
    task = m.tasks[0]
    k = bn_kernel.kernel_for(m, task, m.init)
    assert k is not None
    for s in m.random_walk_states(300, 5, walk=30):
        want = [(a, t, c, bool(task.satisfied(t))) for a, t, c in m.successors(s)]
        assert k.successors(bn_kernel.lib(), s, task) == want


def _same(a, b):
    assert a.plan == b.plan
    assert [tuple(t) for t in a.terminals] == [tuple(t) for t in b.terminals]
    for f in (
        "expansions",
        "bellman_expansions",
        "novelty_expansions",
        "forfeited",
        "stale",
        "novelty_skipped",
        "novelty_dropped",
        "novelty_repushed",
        "generated",
        "nodes",
        "value_calls",
        "value_states",
        "c_myo",
        "terminals",
        "eligible",
        "source",
        "v_ap",
        "cost",
        "depth",
    ):
        assert getattr(a.stats, f) == getattr(b.stats, f), f


@needs_kernel
@pytest.mark.parametrize("name", ["make-coffee(servingtable)", "serve-water(servingtable)", "wash(bowls)"])
def test_c_loop_is_the_python_loop_with_the_zero_value(two_room, name):
    m = two_room
    s, task = m.reset_state(2000), m.tasks.get(name)
    ref = optimal_plan(BatchedModel(m), s, task).plan  # the myopic oracle's A* (uniform-cost search: 18 s)
    runs = []
    for kernel in ("c", "python"):
        trace = []
        runs.append(
            (
                bellman_novelty_search(
                    m, s, task, ZeroValue(0.97), budget=1500, beta=1.25, reference_plan=ref, trace=trace, kernel=kernel
                ),
                trace,
            )
        )
    trace = []
    old = bellman_novelty_search_reference(
        m, s, task, ZeroValue(0.97), budget=1500, beta=1.25, reference_plan=ref, trace=trace
    )
    (c, tc), (p, tp) = runs
    assert tc == tp == trace and len(tc) > 1500
    _same(c, p)
    _same(c, old)


@needs_kernel
def test_c_loop_with_the_networks_python_value_is_the_reference_bit_for_bit(restaurant, values):
    """The same value calls (batches included) as the reference, so the same values, keys, turns and choice."""
    m = restaurant
    budget = 1500 if m.layout == "two-room" else 2500
    for seed, name in ((2000, "make-coffee(servingtable)"), (7, "serve-water(servingtable)")):
        s, task = m.reset_state(seed), m.tasks.get(name)
        ref = optimal_plan(BatchedModel(m), s, task).plan
        ta, tb = [], []
        a = bellman_novelty_search(
            m, s, task, values, budget=budget, beta=2.0, reference_plan=ref, trace=ta, kernel="c", native_value=False
        )
        b = bellman_novelty_search_reference(m, s, task, values, budget=budget, beta=2.0, reference_plan=ref, trace=tb)
        assert ta == tb
        _same(a, b)


@needs_kernel
def test_kernel_switches(two_room, monkeypatch):
    m = two_room
    s, task = m.reset_state(3), m.tasks.get("wash(bowls)")
    with pytest.raises(ValueError):
        bellman_novelty_search(m, s, task, ZeroValue(1.0), budget=10, beta=1.0, kernel="fortran")
    monkeypatch.setattr(bn_kernel, "_LIB", False)  # as with ANTICIPATORY_BN_NATIVE=0 or no compiler
    with pytest.raises(RuntimeError):
        bellman_novelty_search(m, s, task, ZeroValue(1.0), budget=10, beta=1.0, kernel="c")
    r = bellman_novelty_search(m, s, task, ZeroValue(1.0), budget=200, beta=1.0)  # the Python loop
    assert r.stats.expansions == 200 and r.stats.value_calls > 1  # Python value calls: the Python loop ran


# ---- the compiled value ----------------------------------------------------------------------------------
def _native(values):
    if values.native is None:
        pytest.skip("no C compiler for learning/q/_qnet.c")
    return values.native


def test_compiled_q_max_and_v_ap_are_batchedq_up_to_rounding(restaurant, values):
    nq = _native(values)
    m = restaurant
    states = m.random_walk_states(600, 3)
    for t in list(m.tasks)[::5]:
        a, b = values.batched.q_max(states, t.index), nq.q_max(states, t.index)
        fin = np.isfinite(a)
        assert (np.isfinite(b) == fin).all()
        assert np.abs(a[fin] - b[fin]).max() < 1e-4
    assert np.abs(values.batched.v_ap(states[:100]) - nq.v_ap(states[:100])).max() < 1e-4


def test_compiled_value_does_not_depend_on_the_batch(restaurant, values):
    from learning.q.inference import NativeQ, _qnet_lib

    _native(values)
    fresh = NativeQ(values.batched, _qnet_lib(), memo=False)
    m = restaurant
    states = list(dict.fromkeys(m.random_walk_states(300, 4)))[:200]
    task = m.tasks.get("make-coffee(servingtable)").index
    together = fresh.q_max(states, task)
    one_by_one = np.concatenate([fresh.q_max([s], task) for s in states])
    shuffled = np.random.default_rng(0).permutation(len(states))
    assert (together == one_by_one).all()
    assert (fresh.q_max([states[i] for i in shuffled], task) == together[shuffled]).all()
    memo = NativeQ(values.batched, _qnet_lib(), memo=True)
    assert (memo.q_max(states[:50], task) == together[:50]).all()
    assert (memo.q_max(states, task) == together).all()  # 50 from the memo, 150 computed
    assert memo.memo_stats()["hits"] == 50 and memo.memo_stats()["entries"] == len(states)
    assert (memo.v_ap(states[:20]) == fresh.v_ap(states[:20])).all()


# ---- identical choices on committed results --------------------------------------------------------------
COMMITTED = {
    "two-room": ("results/rl-guided-anticipatory-two-room-seed0.json", 0, 14),
    "three-room": ("results/rl-guided-anticipatory-three-room-seed0.json", 1, 17),
}


@needs_kernel
@pytest.mark.parametrize("layout", ["two-room", "three-room"])
def test_the_search_picks_the_committed_plans(layout, request):
    """Sequence 0 of a committed guided results file: the world is brought to task `first` along the committed
    plans (the three-room's task 0 has a reference plan that takes half a minute to find), then every searched
    task up to `last` is planned (optimal reference plan, the search with the committed checkpoint and the
    layout's settings) and must choose the committed plan, action for action."""
    from learning.agents.guided import search_defaults
    from learning.q.value import load_value_function
    from planning.parallel import one_thread
    from planning.world.sequences import load
    from planning.world.task_stream import PersistentWorld

    path, first, last = COMMITTED[layout]
    if not Path(path).is_file():
        pytest.skip(f"no {path}")
    one_thread()
    m = request.getfixturevalue("two_room" if layout == "two-room" else "three_room")
    saved = json.loads(Path(path).read_text())
    value = load_value_function(saved["config"]["checkpoint"], m)
    d = search_defaults(m)
    assert (saved["config"]["beta"], saved["config"]["budget"], saved["config"]["depth_cap"]) == (
        d["beta"],
        d["budget"],
        d["depth_cap"],
    )
    rows = {r["index"]: r for r in saved["per_task"] if r["sequence"] == 0}
    seq = load(m, [0])[0]
    world, bm, checked = PersistentWorld(m, seq.reset_seed), BatchedModel(m), 0
    for i, task in enumerate(seq.tasks[: last + 1]):
        row = rows[i]
        if world.begin(task):
            assert row["auto"]
            continue
        if i >= first:
            ref = optimal_plan(bm, world.state, task)
            r = bellman_novelty_search(
                m,
                world.state,
                task,
                value,
                budget=d["budget"],
                beta=d["beta"],
                depth_cap=d["depth_cap"],
                reference_plan=ref.plan,
            )
            assert [m.actions[a] for a in r.plan] == row["plan"], f"task {i} {task.name}"
            assert (r.stats.cost, r.stats.source, r.stats.c_myo) == (row["cost"], row["source"], row["c_myo"])
            checked += 1
        world.execute([m.action(a) for a in row["plan"]])
    assert checked >= 9
