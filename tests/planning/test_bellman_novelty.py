"""The Bellman–Novelty search (thesis Algorithms 3-4) and its novelty tables, on hand-made graphs and the restaurant."""

import random

import numpy as np
import pytest

from planning.search.bellman_novelty import bellman_novelty_search
from planning.search.novelty import NoveltyTables, atom_indices
from planning.search.optimal import uniform_cost_search
from planning.search.terminals import Terminal, select_terminal
from planning.value import ZeroValue


# ---- hand-made models ---------------------------------------------------------------------------
class GraphModel:
    """A model given by its edges: {state: [(action, next_state, cost)]}; states are bitsets over n atoms."""

    def __init__(self, edges: dict, n_atoms: int):
        self.edges = edges
        self.atoms = list(range(n_atoms))
        self.action_cost = {a: c for out in edges.values() for a, _, c in out}
        self.config = {"reward": {"cost_scale": 1}}

    def successors(self, state):
        return list(self.edges.get(state, []))

    def apply(self, state, action):
        return next(t for a, t, _ in self.edges[state] if a == action)


class GoalTask:
    """A task satisfied in a set of states; consumption maps a state (identity if not listed)."""

    name, index = "goal", 0

    def __init__(self, goals, consume=None):
        self.goals, self.after = set(goals), dict(consume or {})

    def satisfied(self, state):
        return state in self.goals

    def consume(self, state):
        assert state in self.goals
        return self.after.get(state, state)


class TableValue:
    """q_max and V_AP from tables (default 0); records its batches."""

    def __init__(self, q=None, v=None, gamma=1.0):
        self.q, self.v, self.gamma = dict(q or {}), dict(v or {}), gamma
        self.q_batches, self.v_batches = [], []

    def q_max(self, states, task):
        self.q_batches.append(list(states))
        return np.array([self.q.get(s, 0.0) for s in states], dtype=float)

    def v_ap(self, states):
        self.v_batches.append(list(states))
        return np.array([self.v.get(s, 0.0) for s in states], dtype=float)


NEVER = GoalTask([])


def bits(*atoms) -> int:
    return sum(1 << a for a in atoms)


# ---- novelty ------------------------------------------------------------------------------------
def test_widths_on_hand_made_states():
    t = NoveltyTables(4)
    assert t.width(bits(0, 1)) == 1  # nothing registered yet
    t.register(bits(0, 1))
    assert t.width(bits(0, 1)) is None and t.width(bits(1)) is None
    assert t.width(bits(0, 2)) == 1  # atom 2 is new
    t.register(bits(1, 2))
    assert t.width(bits(0, 2)) == 2  # atoms known, pair {0, 2} new
    assert t.width(bits(0, 1, 2)) == 2
    t.register(bits(0, 2))
    assert t.width(bits(0, 1, 2)) is None  # pairs 01, 12, 02 all seen
    assert t.width(bits(0, 3)) == 1
    assert t.atom_table().tolist() == [True, True, True, False]
    pairs = t.pair_table()
    assert (pairs == pairs.T).all() and pairs[0, 2] and not pairs[0, 3] and pairs.sum() == 9


def test_register_reports_change_and_version():
    t = NoveltyTables(3)
    assert t.register(bits(0, 1)) and t.version == 1
    assert not t.register(bits(0)) and not t.register(bits(0, 1)) and t.version == 1
    assert t.register(bits(1, 2)) and t.version == 2


def test_fast_path_is_exact_for_a_child_of_a_registered_parent():
    rng = random.Random(0)
    n = 12
    for _ in range(300):
        t = NoveltyTables(n)
        for _ in range(rng.randrange(6)):
            t.register(bits(*rng.sample(range(n), 4)))
        parent = bits(*rng.sample(range(n), 5))
        t.register(parent)  # expanded on a novelty turn
        dele = bits(*rng.sample(atom_indices(parent), 2))
        add = bits(*rng.sample(range(n), 2))
        child = (parent & ~dele) | add
        assert t.width(child, child & ~parent) == t.width(child)


# ---- the schedule -------------------------------------------------------------------------------
R, A, B, C = bits(0), bits(0, 1), bits(0, 2), bits(0, 1, 3)
SMALL = {R: [(1, A, 1), (2, B, 5)], A: [(3, C, 1)]}


def turns(trace):
    return [(e[0], e[1]) if len(e) > 1 else (e[0],) for e in trace]


def test_schedule_forfeits_an_empty_lane_and_does_not_charge_a_stale_pop():
    trace = []
    r = bellman_novelty_search(GraphModel(SMALL, 4), R, NEVER, TableValue(), budget=100, beta=1.0, trace=trace)
    # Bellman R, A, C (best G first); the novelty turn skips stale R and A, expands B;
    # B's Bellman entry is then stale (no charge), and the empty Bellman heap forfeits twice.
    assert turns(trace) == [
        ("bellman", R),
        ("bellman", A),
        ("bellman", C),
        ("novelty", B),
        ("stale", B),
        ("forfeit",),
        ("forfeit",),
    ]
    s = r.stats
    assert (s.expansions, s.bellman_expansions, s.novelty_expansions, s.stale, s.forfeited) == (4, 3, 1, 1, 2)
    assert s.novelty_skipped == 3  # R, A, then C on the last novelty turn
    assert r.plan is None and s.terminals == 0  # nothing completes the task: no selection


def test_budget_counts_expansions_only():
    trace = []
    r = bellman_novelty_search(GraphModel(SMALL, 4), R, NEVER, TableValue(), budget=3, beta=1.0, trace=trace)
    assert turns(trace) == [("bellman", R), ("bellman", A), ("bellman", C)] and r.stats.expansions == 3


def tree(depth: int, branching: int = 2) -> tuple:
    """A tree whose node k is the state with atom k alone, every edge of cost 1."""
    edges, nxt, level = {}, 1, [0]
    for _ in range(depth):
        new = []
        for k in level:
            kids = list(range(nxt, nxt + branching))
            nxt += branching
            edges[1 << k] = [(kid, 1 << kid, 1) for kid in kids]
            new += kids
        level = new
    return edges, nxt


def test_three_bellman_turns_to_one_novelty_turn():
    edges, n = tree(5)
    trace = []
    r = bellman_novelty_search(GraphModel(edges, n), 1, NEVER, TableValue(), budget=30, beta=1.0, trace=trace)
    lane = ["N" if e[0] == "novelty" else "B" for e in trace]
    assert "".join(lane) == ("BBBN" * 20)[: len(lane)]
    assert r.stats.novelty_expansions >= 7 and r.stats.expansions == 30


def test_novelty_pop_recomputes_the_width():
    # The root's children p, q, y, x are dear (cost 50), so the Bellman lane walks a cheap
    # chain c0, c1, ... (cost 1 each, a fresh atom each) and the novelty turns decide them.
    root, p, q, y, x = bits(0), bits(0, 1), bits(0, 2), bits(1, 2), bits(1)
    chain = [bits(3, 4 + k) for k in range(12)]
    edges = {root: [(1, p, 50), (2, q, 50), (3, y, 50), (4, x, 50), (10, chain[0], 1)]}
    for k in range(len(chain) - 1):
        edges[chain[k]] = [(11 + k, chain[k + 1], 1)]
    trace = []
    r = bellman_novelty_search(GraphModel(edges, 16), root, NEVER, TableValue(), budget=12, beta=1.0, trace=trace)
    # All four were pushed with width 1 (empty tables). Turn 4 expands p (registers {0, 1}),
    # turn 8 q (registers {0, 2}); at turn 12 y = {1, 2} has width 2 (pair new): re-pushed;
    # x = {1} is no longer novel: dropped; the turn goes on to the newest chain node.
    assert [e[1] for e in trace if e[0] == "novelty"] == [p, q, chain[8]]
    assert [e[0][0] for e in trace] == list("bbbnbbbnbbbn")
    s = r.stats
    assert (s.novelty_repushed, s.novelty_dropped, s.novelty_skipped, s.expansions) == (1, 1, 9, 12)


# ---- dedup --------------------------------------------------------------------------------------
def test_dedup_keeps_the_best_G_per_state_and_depth():
    s0, a, b, c, x, goal = bits(0), bits(1), bits(2), bits(5), bits(3), bits(4)
    # x at depth 2 via a (G -4), then via b (G -2: admitted again), then via c (G -6: rejected).
    edges = {s0: [(1, a, 1), (2, b, 1), (6, c, 1)], a: [(3, x, 3)], b: [(4, x, 1)], c: [(7, x, 5)], x: [(5, goal, 1)]}
    trace = []
    r = bellman_novelty_search(
        GraphModel(edges, 6), s0, GoalTask([goal]), TableValue(), budget=100, beta=1.0, trace=trace
    )
    # B: s0, a, b; N: c (its x rejected); B: c stale, x (G -2), x (G -4) stale; N: nothing left.
    assert turns(trace) == [
        ("bellman", s0),
        ("bellman", a),
        ("bellman", b),
        ("novelty", c),
        ("stale", c),
        ("bellman", x),
        ("stale", x),
    ]
    assert r.stats.nodes == 6  # s0, a, b, c, and x twice
    assert [t.cost for t in r.terminals] == [3] and r.plan == [2, 4, 5]


def test_the_novelty_lane_may_expand_a_superseded_copy():
    # Algorithm 3 keeps a superseded node in both heaps; STALE only looks at `expanded`.
    s0, a, b, x, goal = bits(0), bits(1), bits(2), bits(3), bits(4)
    edges = {s0: [(1, a, 1), (2, b, 1)], a: [(3, x, 3)], b: [(4, x, 1)], x: [(5, goal, 1)]}
    r = bellman_novelty_search(GraphModel(edges, 5), s0, GoalTask([goal]), TableValue(), budget=100, beta=1.0)
    # the novelty turn pops x's first (dearer) copy; the Bellman lane then expands the better
    # one, whose terminal has a higher G and is admitted as well
    assert [t.cost for t in r.terminals] == [5, 3] and r.stats.c_myo == 3 and r.plan == [2, 4, 5]


def test_terminal_dedup_admits_only_a_better_G():
    s0, a, b, goal = bits(0), bits(1), bits(2), bits(3)
    for cost_b, costs in ((1, [6, 2]), (9, [6])):
        edges = {s0: [(1, a, 1), (2, b, 1)], a: [(3, goal, 5)], b: [(4, goal, cost_b)]}
        r = bellman_novelty_search(GraphModel(edges, 4), s0, GoalTask([goal]), TableValue(), budget=100, beta=5.0)
        assert [t.cost for t in r.terminals] == costs


def test_same_state_at_another_depth_is_not_a_duplicate_and_the_cap_gates_open_nodes():
    s0, a, goal = bits(0), bits(1), bits(2)
    edges = {s0: [(1, a, 1)], a: [(2, s0, 1), (3, goal, 1)]}
    r = bellman_novelty_search(
        GraphModel(edges, 3), s0, GoalTask([goal]), TableValue(), budget=100, beta=9.0, depth_cap=5
    )
    # open: s0@0, a@1, s0@2, a@3, s0@4 (a@5 is at the cap); the goal from a@1 and a@3
    assert [t.depth for t in r.terminals] == [2, 4] and r.stats.expansions == 5
    r = bellman_novelty_search(
        GraphModel(edges, 3), s0, GoalTask([goal]), TableValue(), budget=100, beta=9.0, depth_cap=2
    )
    assert [t.depth for t in r.terminals] == [2]  # at the cap, yet admitted: terminals are not capped
    assert r.stats.expansions == 2


# ---- selection ----------------------------------------------------------------------------------
def T(cost, v, depth=1, source="search"):
    return Terminal(source, cost, depth, -cost, 0, v)


def test_selection_honours_the_cost_bound():
    ts = [T(4, 0.0, source="reference"), T(5, 1.0), T(6, 2.0)]
    assert select_terminal(ts, 4, 1.0) == 0
    assert select_terminal(ts, 4, 1.25) == 1  # 5 <= 1.25 * 4
    assert select_terminal(ts, 4, 1.5) == 2
    assert select_terminal([], 4, 2.0) is None
    assert select_terminal([T(9, 1.0)], 4, 2.0) is None  # nothing within the bound


def test_selection_tie_breaks():
    assert select_terminal([T(5, 1.0), T(4, 1.0)], 4, 2.0) == 1  # V_AP tie: lower cost
    assert select_terminal([T(4, 1.0, depth=3), T(4, 1.0, depth=2)], 4, 2.0) == 1  # then smaller depth
    assert select_terminal([T(4, 1.0, depth=2), T(4, 1.0, depth=2)], 4, 2.0) == 0  # then discovery order
    assert select_terminal([T(8, 1.5), T(4, 1.0)], 4, 2.0) == 0  # V_AP first


def test_reference_is_admitted_first_and_always_eligible():
    # The reference (cost 10) is dearer than the search's terminal (cost 2); β = 1 keeps both.
    s0, a, good, cheap = bits(0), bits(1), bits(2), bits(3)
    edges = {s0: [(1, a, 5), (2, cheap, 2)], a: [(3, good, 5)]}
    value = TableValue(v={good: 3.0, cheap: 1.0})
    r = bellman_novelty_search(
        GraphModel(edges, 4), s0, GoalTask([good, cheap]), value, budget=100, beta=1.0, reference_plan=[1, 3]
    )
    assert r.terminals[0].source == "reference" and r.stats.c_myo == 10
    assert r.plan == [1, 3] and r.stats.source == "reference" and r.stats.v_ap == 3.0
    assert r.stats.eligible == 2
    # Without it, C_myo is the cheapest search terminal: only that one is eligible at β = 1.
    r = bellman_novelty_search(GraphModel(edges, 4), s0, GoalTask([good, cheap]), value, budget=100, beta=1.0)
    assert r.stats.c_myo == 2 and r.plan == [2] and r.stats.source == "search" and r.stats.eligible == 1


def test_terminals_carry_their_fields_and_only_the_eligible_are_scored():
    s0, a, good, cheap = bits(0), bits(1), bits(2), bits(3)
    edges = {s0: [(1, a, 5), (2, cheap, 2)], a: [(3, good, 5)]}
    task = GoalTask([good, cheap])
    value = TableValue(v={good: 3.0, cheap: 1.0}, gamma=0.5)
    # the reference is cut where the task first holds (action 9 is never replayed): G = -5 - 0.5 * 5; the
    # search's own way to `good` has the same G at the same depth, so it is not admitted again
    r = bellman_novelty_search(GraphModel(edges, 4), s0, task, value, budget=100, beta=1.0, reference_plan=[1, 3, 9])
    assert r.terminals == [Terminal("reference", 10, 2, -7.5, good, 3.0), Terminal("search", 2, 1, -2.0, cheap, 1.0)]
    assert r.plan == [1, 3] and (r.stats.source, r.stats.cost, r.stats.depth) == ("reference", 10, 2)
    # without it C_myo = 2: `good` is not eligible at β = 1, so it is not scored
    value = TableValue(v={good: 3.0, cheap: 1.0}, gamma=0.5)
    r = bellman_novelty_search(GraphModel(edges, 4), s0, task, value, budget=100, beta=1.0)
    assert r.terminals == [Terminal("search", 2, 1, -2.0, cheap, 1.0), Terminal("search", 10, 2, -7.5, good, None)]
    assert value.v_batches == [[cheap]] and r.plan == [2] and r.stats.eligible == 1


def test_terminals_are_scored_after_consumption_in_one_batch():
    s0, x, y, x_after, y_after = bits(0), bits(1), bits(2), bits(3), bits(4)
    edges = {s0: [(1, x, 1), (2, y, 1)]}
    value = TableValue(v={x: 9.0, x_after: 0.0, y: 0.0, y_after: 1.0})  # the consumed y is better prepared
    r = bellman_novelty_search(
        GraphModel(edges, 5), s0, GoalTask([x, y], {x: x_after, y: y_after}), value, budget=10, beta=1.0
    )
    assert r.plan == [2] and r.stats.v_ap == 1.0
    assert value.v_batches == [[x_after, y_after]]


def test_children_are_valued_in_batches_and_only_if_pushed():
    edges, n = tree(4, branching=3)
    value = TableValue()
    r = bellman_novelty_search(GraphModel(edges, n), 1, NEVER, value, budget=10, beta=1.0, prefetch=0)
    valued = [s for batch in value.q_batches for s in batch]
    assert len(valued) == len(set(valued)) == r.stats.value_states  # each state valued once
    assert all(len(b) >= 3 for b in value.q_batches[1:])  # a whole expansion's children per call
    assert r.stats.value_calls < r.stats.expansions


def test_bad_arguments():
    with pytest.raises(ValueError):
        bellman_novelty_search(GraphModel(SMALL, 4), R, NEVER, TableValue(), budget=1, beta=0.5)
    with pytest.raises(ValueError):
        bellman_novelty_search(GraphModel(SMALL, 4), R, NEVER, object(), budget=1, beta=1.0)  # no gamma
    with pytest.raises(ValueError):  # a reference that does not complete the task
        bellman_novelty_search(
            GraphModel(SMALL, 4), R, GoalTask([B]), TableValue(), budget=1, beta=1.0, reference_plan=[1]
        )


def test_root_that_already_completes_the_task():
    r = bellman_novelty_search(GraphModel(SMALL, 4), R, GoalTask([R]), TableValue(), budget=10, beta=1.0)
    assert r.plan == [] and r.stats.cost == 0 and r.stats.expansions == 0


# ---- the restaurant -----------------------------------------------------------------------------
def replay(model, state, plan):
    cost = 0
    for a in plan:
        state = model.apply(state, a)
        cost += model.action_cost[a]
    return state, cost


@pytest.mark.parametrize(
    "name, optimal",
    [("clear(servingtable)", 300), ("pick-place(jar_0, servingtable)", 400), ("pick-place(plate_0, fountain)", 450)],
)
def test_zero_value_finds_the_myopic_optimal_cost(two_room, name, optimal):
    m = two_room
    s, task = m.reset_state(2000), m.tasks.get(name)
    assert uniform_cost_search(m, s, task).cost == optimal
    r = bellman_novelty_search(m, s, task, ZeroValue(1.0), budget=1000, beta=1.0)
    assert r.stats.c_myo == optimal and r.stats.cost == optimal and r.stats.source == "search"
    end, cost = replay(m, s, r.plan)
    assert task.satisfied(end) and cost == optimal


@pytest.mark.parametrize("name", ["make-coffee(servingtable)", "wash(bowls)"])
def test_zero_value_with_the_reference_keeps_its_cost(two_room, name):
    m = two_room
    s, task = m.reset_state(2000), m.tasks.get(name)
    ref = uniform_cost_search(m, s, task)
    r = bellman_novelty_search(m, s, task, ZeroValue(0.97), budget=1000, beta=1.25, reference_plan=ref.plan)
    assert r.stats.c_myo == ref.cost and r.stats.cost == ref.cost
    end, cost = replay(m, s, r.plan)
    assert task.satisfied(end) and cost == ref.cost


def test_same_inputs_same_plan_with_the_q_network(two_room):
    from pathlib import Path

    ckpt = Path("checkpoints/rl-anticipatory-two-room-seed0.pt")
    if not ckpt.is_file():
        pytest.skip("no two-room checkpoint")
    torch = pytest.importorskip("torch")
    torch.set_num_threads(1)
    from learning.q.value import load_value_function

    m = two_room
    vf = load_value_function(ckpt, m)
    s, task = m.reset_state(2000), m.tasks.get("make-coffee(servingtable)")
    ref = uniform_cost_search(m, s, task).plan
    runs = [bellman_novelty_search(m, s, task, vf, budget=800, beta=1.25, reference_plan=ref) for _ in range(2)]
    a, b = runs
    assert a.plan == b.plan and a.stats.expansions == b.stats.expansions == 800
    head = lambda r: [(t.source, t.cost, t.depth, t.G) for t in r.terminals]
    assert head(a) == head(b)
    end, cost = replay(m, s, a.plan)
    assert task.satisfied(end) and cost == a.stats.cost <= 1.25 * a.stats.c_myo
    # without prefetching the same nodes are expanded and the same terminal chosen
    c = bellman_novelty_search(m, s, task, vf, budget=800, beta=1.25, reference_plan=ref, prefetch=0)
    assert c.plan == a.plan and c.stats.nodes == a.stats.nodes
