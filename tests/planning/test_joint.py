"""Windows of tasks planned jointly (the clairvoyant oracle's problem): our search and Fast Downward agree."""

import re

import pytest

from planning.domain.batched import BatchedModel
from planning.external.fast_downward import run_planner
from planning.heuristics.hmax import goal_literals
from planning.heuristics.layered import LayeredLMCut
from planning.search.joint import JointSearch, joint_up_problem
from planning.search.optimal import optimal_plan
from planning.world.task_stream import PersistentWorld


@pytest.fixture(scope="module")
def joint(two_room):
    return JointSearch(two_room)


@pytest.fixture(scope="module")
def layered_lmcut(two_room, joint):
    """The window search's "layered" heuristic on the joint states."""
    return LayeredLMCut(two_room, joint.bm)


def fast_downward_cost(model, state, window):
    _, log = run_planner(joint_up_problem(model, state, window))
    return int(re.findall(r"Plan cost: (\d+)", log)[-1])


def test_window_of_one_is_the_single_task_problem(two_room, joint):
    bm = BatchedModel(two_room)
    names = ["serve-water(servingtable)", "wash(knives)", "clear(servingtable)", "pick-place(cup_1, shelf)"]
    for seed, name in enumerate(names):
        state, task = two_room.reset_state(seed), two_room.tasks.get(name)
        assert joint.plan(state, [task]).cost == optimal_plan(bm, state, task).cost


@pytest.mark.parametrize(
    "names,cost",
    [
        pytest.param(["make-coffee(servingtable)", "wash(bowls)"], 650, marks=pytest.mark.slow),  # Fast Downward: 30 s
        (["clear(servingtable)", "pick-place(plate_0, shelf)"], 575),
    ],
)
def test_short_windows_match_fast_downward(two_room, joint, names, cost):
    state = two_room.reset_state(0)
    window = [two_room.tasks.get(n) for n in names]
    r = joint.plan(state, window)
    assert r.cost == cost == fast_downward_cost(two_room, state, window)
    world = PersistentWorld(two_room)  # the plan completes both tasks in the persistent world
    world.state = state
    plan = iter(r.plan)
    for task in window:
        if not world.begin(task):
            while world.task is not None:
                world.act(next(plan))
    assert all(o.success for o in world.outcomes) and sum(o.cost for o in world.outcomes) == cost


@pytest.mark.parametrize("heuristic", ["pdb", "lmcut", pytest.param("layered", marks=pytest.mark.slow)])
def test_two_water_tasks_fetch_the_jar(two_room, joint, heuristic):
    # Myopic: 1475 from the start, then 1300 for the second (the robot is at the table).
    # Jointly: fetch and fill the jar (move 25, pick 100, move 200, fill 1000, move 50, place 100),
    # then two refills with cup_0 (move 200, pick 100, move 200, refill 50, place 100; pick 100,
    # refill 50, place 100): 2375 < 2775.
    water = two_room.tasks.get("serve-water(servingtable)")
    r = joint.plan(two_room.reset_state(0), [water, water], heuristic=heuristic)
    assert r.cost == 2375
    assert "fill(jar_0, water_fountain, fountain)" in [two_room.actions[a] for a in r.plan]


JAR_RUN = [
    "move(countertop, pantry)",
    "pick(jar_0, pantry)",
    "move(pantry, fountain)",
    "fill(jar_0, water_fountain, fountain)",
    "move(fountain, servingtable)",
    "place(jar_0, servingtable)",
    "move(servingtable, countertop)",
    "pick(cup_0, countertop)",
    "move(countertop, servingtable)",
]
REFILL = ["refill-water(cup_0, jar_0, servingtable)", "place(cup_0, servingtable)"]
FIRST_FILL = [
    "pick(cup_0, countertop)",
    "move(countertop, fountain)",
    "fill(cup_0, water_fountain, fountain)",
    "move(fountain, servingtable)",
    "place(cup_0, servingtable)",
]
REFILL_AT_FOUNTAIN = [
    "pick(cup_0, servingtable)",
    "move(servingtable, fountain)",
    "fill(cup_0, water_fountain, fountain)",
    "move(fountain, servingtable)",
    "place(cup_0, servingtable)",
]


def water_plans(n):
    """Hand plans for n serve-waters from the three-room start: with the jar, and fountain trips only."""
    jar = JAR_RUN + REFILL + (["pick(cup_0, servingtable)"] + REFILL) * (n - 1)
    return jar, FIRST_FILL + REFILL_AT_FOUNTAIN * (n - 1)


@pytest.mark.parametrize("n,jar,fountain", [(2, 3900, 2775), (3, 4150, 4075), (4, 4400, 5375)])
def test_three_room_jar_breaks_even_at_four_water_tasks(three_room, n, jar, fountain):
    # By hand (restaurant.md): fetching, filling and parking the jar costs 3,000 and the first cup
    # 650 more (walk to the countertop and back, refill, place); every later water task is pick,
    # refill, place = 250. Without the jar: 1,475, then 1,300 a task (pick, walk to the fountain
    # and back, fill, place). 3,650 + 250 (n - 1) < 1,475 + 1,300 (n - 1) from n = 4 on.
    water = three_room.tasks.get("serve-water(servingtable)")
    costs = []
    for plan in water_plans(n):
        world = PersistentWorld(three_room)
        world.state = three_room.init
        steps = iter(three_room.action(a) for a in plan)
        for _ in range(n):
            assert not world.begin(water)
            while world.task is not None:
                world.act(next(steps))
        assert next(steps, None) is None and all(o.success for o in world.outcomes)
        costs.append(sum(o.cost for o in world.outcomes))
    assert costs == [jar, fountain]


def test_three_room_jar_only_from_four_water_tasks(three_room):
    # The break-even worked out by hand (test_three_room_jar_breaks_even_at_four_water_tasks): fetching and
    # filling the jar costs 3,900 / 4,150 / 4,400 for 2 / 3 / 4 water tasks, fountain trips
    # 2,775 / 4,075 / 5,375. The joint optimum takes the jar only for four.
    water = three_room.tasks.get("serve-water(servingtable)")
    joint = JointSearch(three_room)
    for n, cost, jar in [(2, 2775, False), (3, 4075, False), (4, 4400, True)]:
        r = joint.plan(three_room.init, [water] * n)
        assert r.cost == cost, n
        assert any("jar_0" in three_room.actions[a] for a in r.plan) == jar, n


@pytest.mark.slow
def test_water_then_coffee_matches_fast_downward(two_room, joint):
    state = two_room.reset_state(0)
    window = [two_room.tasks.get("serve-water(servingtable)"), two_room.tasks.get("make-coffee(servingtable)")]
    assert joint.plan(state, window).cost == 2275 == fast_downward_cost(two_room, state, window)


def test_clairvoyant_k1_reproduces_the_myopic_oracle(two_room):
    from oracles.clairvoyant import ClairvoyantOracle
    from oracles.myopic import MyopicOracle
    from planning.world.runner import play_sequence
    from planning.world.sequences import Sequence, load

    seq = load(two_room, [1])[0]
    short = Sequence(seq.id, seq.reset_seed, seq.tasks[:8])
    k1 = play_sequence(two_room, ClairvoyantOracle(1, 60), short)
    myopic = play_sequence(two_room, MyopicOracle("internal", 60), short)
    assert [(r["cost"], r.get("plan")) for r in k1] == [(r["cost"], r.get("plan")) for r in myopic]
    assert all(r["optimal"] for r in k1 if "window" in r)


def test_clairvoyant_window_timeout_falls_back_and_is_marked(two_room, joint):
    from oracles.clairvoyant import ClairvoyantOracle

    oracle = ClairvoyantOracle(2, time_limit=0.01)
    oracle.start(two_room, None)
    water = two_room.tasks.get("serve-water(servingtable)")
    state = two_room.reset_state(0)
    reply = oracle.plan(state, water, [water])
    info = reply.info
    assert info["bounded"] and not info["optimal"] and len(reply.plan) == 5
    # The bracket: the interrupted A*'s bound <= the optimal joint cost <= the myopic chain's cost.
    first = optimal_plan(oracle._bm, state, water)
    after = water.consume(_run(two_room, state, first.plan))
    second = optimal_plan(oracle._bm, after, water)
    assert info["window_cost"] == first.cost + second.cost == 1475 + 1300
    best = joint.plan(state, [water, water]).cost
    assert info["lower_bound"] <= best < info["window_cost"]


def test_clairvoyant_chain_that_meets_the_proven_bound_is_optimal(two_room, monkeypatch):
    # A search stopped after its first state has proved the root's f (575 for the plate to the
    # shelf, exact); the chain costs the same, so the window is optimal, though bounded in time.
    import functools

    from oracles.clairvoyant import ClairvoyantOracle

    oracle = ClairvoyantOracle(2)
    oracle.start(two_room, None)
    monkeypatch.setattr(oracle._joint, "plan", functools.partial(oracle._joint.plan, max_states=1))
    state = two_room.reset_state(0)
    plate, cup = (two_room.tasks.get(n) for n in ["pick-place(plate_0, shelf)", "pick-place(cup_0, servingtable)"])
    info = oracle.plan(state, plate, [plate]).info
    assert info["bounded"] and info["optimal"] and info["window_cost"] == info["lower_bound"] == 575
    info = oracle.plan(state, plate, [cup]).info  # the chain (1,000) is above the bound (775)
    assert info["bounded"] and not info["optimal"] and (info["lower_bound"], info["window_cost"]) == (775, 1000)


def test_clairvoyant_escalates_only_the_windows_its_first_heuristic_leaves_unproven(two_room, monkeypatch):
    # "pdb,lmcut": the pdb search is stopped after its first state; where the chain meets the bound it
    # proved (the plate to the shelf twice, 575) the window is decided without LM-cut, else LM-cut searches
    # it again from scratch and proves the joint optimum.
    from oracles.clairvoyant import ClairvoyantOracle

    oracle = ClairvoyantOracle(2, heuristic="pdb,lmcut")
    assert oracle.run_name == "clairvoyant-2-pdb-then-lmcut"
    oracle.start(two_room, None)
    searched = []
    plan = oracle._joint.plan

    def stopped_pdb(state, tasks, heuristic, **kw):
        searched.append(heuristic)
        return plan(state, tasks, heuristic=heuristic, **kw, **({"max_states": 1} if heuristic == "pdb" else {}))

    monkeypatch.setattr(oracle._joint, "plan", stopped_pdb)
    state = two_room.reset_state(0)
    plate, cup = (two_room.tasks.get(n) for n in ["pick-place(plate_0, shelf)", "pick-place(cup_0, servingtable)"])
    info = oracle.plan(state, plate, [plate]).info
    assert searched == ["pdb"] and info["heuristic"] == "pdb"
    assert info["bounded"] and info["optimal"] and info["window_cost"] == info["lower_bound"] == 575
    searched.clear()
    reply = oracle.plan(state, plate, [cup])
    best = plan(state, [plate, cup], heuristic="pdb")
    assert searched == ["pdb", "lmcut"] and reply.info["heuristic"] == "lmcut"
    assert not reply.info["bounded"] and reply.info["optimal"]
    assert reply.info["window_cost"] == reply.info["lower_bound"] == best.cost < 1000  # below the chain's 1,000


def _run(model, state, plan):
    for a in plan:
        state = model.apply(state, a)
    return state


def joint_states_along(joint, state, window, plan):
    """The joint states a plan passes through, stage completions applied, with the cost so far."""
    rows = joint._complete(joint.bm.pack([state | (1 << joint.n)]), window)
    out = [(rows, 0)]
    g = 0
    for a in plan:
        rows, cost = joint.bm.step(rows, [a])
        rows = joint._complete(rows, window)
        g += int(cost[0])
        out.append((rows, g))
    return out


@pytest.mark.parametrize(
    "names,cost",
    [
        (["make-coffee(servingtable)", "wash(bowls)"], 650),
        (["clear(servingtable)", "pick-place(plate_0, shelf)"], 575),
        (["clear(servingtable)", "pick-place(plate_0, shelf)", "pick-place(cup_0, servingtable)"], 1000),
    ],
)
def test_layered_relaxation_is_admissible_along_optimal_plans(two_room, joint, layered_lmcut, names, cost):
    # Exact costs by A* with LM-cut of the current stage alone, then the
    # layered LM-cut of every state on that optimal plan stays below the cost still to pay.
    state = two_room.reset_state(0)
    window = [two_room.tasks.get(n) for n in names]
    exact = joint.plan(state, window, heuristic="lmcut")
    assert exact.cost == cost
    layered = joint.plan(state, window, heuristic="layered")
    assert layered.cost == exact.cost and layered.expansions <= exact.expansions
    K = len(window)
    for rows, g in joint_states_along(joint, state, window, exact.plan):
        stage = int(joint._stages(rows, K)[0])
        if stage < K:
            h = int(layered_lmcut(rows, window[stage:])[0])
            assert h <= exact.cost - g


def test_saturated_window_partition_adds_disjoint_patterns_admissibly(two_room, joint):
    # With a budget that holds one object at a time, the three pick-places' patterns are disjoint:
    # alone the best says 575 at the start, partitioned (each rotation) they add to 775; every
    # estimate stays below the cost still to pay along an optimal plan (1,125, A* with LM-cut).
    from planning.heuristics.pdb import pattern_databases

    state = two_room.reset_state(0)
    window = [
        two_room.tasks.get(n)
        for n in ["pick-place(plate_0, shelf)", "pick-place(cup_0, servingtable)", "pick-place(cup_1, shelf)"]
    ]
    exact = joint.plan(state, window, heuristic="lmcut")
    assert exact.cost == 1125
    pdb = pattern_databases(two_room, joint.bm.n_words)
    K = len(window)
    value = lambda parts, rows: sum(int(togo[0][proj.index(rows)[0]]) for proj, togo in parts)
    for rows, g in joint_states_along(joint, state, window, exact.plan):
        stage = int(joint._stages(rows, K)[0])
        estimates = pdb.window(window[stage:], rows, max_states=2000) if stage < K else []
        if g == 0:
            assert max(value(p, rows) for p in estimates if len(p) == 1) == 575
            assert [value(p, rows) for p in estimates if len(p) > 1] == [775, 600, 525]
        for parts in estimates:
            assert value(parts, rows) <= exact.cost - g


def test_layered_relaxation_sees_the_second_water(two_room, joint, layered_lmcut):
    # Per stage, LM-cut sees one water task (1450); layered over both: the first cup's water is
    # consumed, so the second needs water again; a jar filled once carries over (1500 < 2 fills).
    water = two_room.tasks.get("serve-water(servingtable)")
    start = joint.bm.pack([two_room.reset_state(0) | (1 << joint.n)])
    goal = goal_literals(two_room, water)
    assert int(layered_lmcut.lmcut(start, goal)[0]) == 1450
    assert int(layered_lmcut(start, [water, water])[0]) == 1500
    coffee = two_room.tasks.get("make-coffee(servingtable)")
    assert int(layered_lmcut(start, [water, coffee])[0]) == 1600


def test_layered_values_agree_between_native_and_numpy(two_room, joint, layered_lmcut, monkeypatch):
    import planning.heuristics.lmcut as lmcut_module

    if lmcut_module.native() is None:
        pytest.skip("no C compiler")
    water, coffee = two_room.tasks.get("serve-water(servingtable)"), two_room.tasks.get("make-coffee(servingtable)")
    states = two_room.random_walk_states(150, seed=4)
    for window, stage in [([water, water], 0), ([water, coffee, water], 1)]:
        batch = joint.bm.pack([s | (1 << (joint.n + stage)) for s in states])
        relaxed = layered_lmcut.relaxation(window[stage:])
        fast = layered_lmcut.lmcut.of_relaxed(batch, relaxed)
        monkeypatch.setattr(lmcut_module, "_NATIVE", False)
        slow = layered_lmcut.lmcut.of_relaxed(batch, relaxed)
        monkeypatch.setattr(lmcut_module, "_NATIVE", None)
        assert (fast == slow).all() and fast.min() > 0


def test_weighted_search_is_bounded_and_its_lower_bound_holds(two_room, joint):
    water = two_room.tasks.get("serve-water(servingtable)")
    coffee = two_room.tasks.get("make-coffee(servingtable)")
    state = two_room.reset_state(0)
    best = joint.plan(state, [water, coffee])  # 2275, as Fast Downward (slow test)
    w = joint.plan(state, [water, coffee], weight=2)
    assert best.cost <= w.cost <= 2 * best.cost
    assert w.lower_bound <= best.cost == best.lower_bound
    cut = joint.plan(state, [water, coffee], max_states=5)  # interrupted: a bound, no plan
    assert cut.plan is None and not cut.complete and 0 < cut.lower_bound <= best.cost


@pytest.mark.parametrize(
    "names,cost",
    [
        (["serve-water(servingtable)", "serve-water(servingtable)"], 2375),
        pytest.param(["make-coffee(servingtable)", "wash(bowls)"], 650, marks=pytest.mark.slow),  # 1 min
        pytest.param(
            ["clear(servingtable)", "pick-place(plate_0, shelf)", "pick-place(cup_0, servingtable)"],
            1000,
            marks=pytest.mark.slow,
        ),
    ],
)
def test_window_pattern_databases_are_admissible_along_optimal_plans(two_room, joint, names, cost):
    # Every window pattern (the leading tasks' objects, each task's own, with neighbours) follows
    # all stages; along an optimal plan (costs checked above against Fast Downward, LM-cut and by
    # hand) none overestimates what is left to pay.
    from planning.heuristics.pdb import pattern_databases

    state = two_room.reset_state(0)
    window = [two_room.tasks.get(n) for n in names]
    r = joint.plan(state, window)
    assert r.cost == cost
    pdb = pattern_databases(two_room, joint.bm.n_words)
    K = len(window)
    assert len(pdb.window(window)) > 1
    for rows, g in joint_states_along(joint, state, window, r.plan):
        stage = int(joint._stages(rows, K)[0])
        for parts in pdb.window(window[stage:], rows) if stage < K else []:
            assert sum(int(togo[0][proj.index(rows)[0]]) for proj, togo in parts) <= cost - g


def test_the_time_limit_leaves_out_the_heuristics_building(two_room, monkeypatch):
    """A window heuristic that spends 8 s building on its second call (as a window's later stage builds its
    pattern databases when the search first reaches it) and says so (`building`): a 6 s limit still finds
    the two-water window's optimum; the same heuristic that does not say so runs out of time."""
    import time as clock

    import planning.search.joint as joint_module
    from planning.heuristics import build

    pdb = build("pdb", JointSearch(two_room, max_window=2).bm, "window")
    spent = {"calls": 0, "building": 0.0}

    def slow(batch, goals):
        spent["calls"] += 1
        if spent["calls"] == 2:
            clock.sleep(8.0)
            spent["building"] += 8.0
        return pdb(batch, goals)

    water = two_room.tasks.get("serve-water(servingtable)")
    for says, cost in ((True, 2375), (False, None)):
        spent.update(calls=0, building=0.0)
        if says:
            slow.building = lambda: spent["building"]
        elif hasattr(slow, "building"):
            del slow.building
        monkeypatch.setattr(joint_module, "build", lambda name, bm, search: slow)
        r = JointSearch(two_room, max_window=2).plan(two_room.reset_state(0), [water, water], time_limit=6.0)
        assert r.cost == cost
